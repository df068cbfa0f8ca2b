"""The deformable brush's reaction beside the 1 kHz loop: a worker and its solver process.

A :class:`ReactionWorker` evaluates a :class:`ReactionModel` (the deformable
brush, :mod:`station.drivers.haptic.deformable`: milliseconds per pose) on the
loop's newest pose at the sim rate and hands each result to the loop as a
timed frame, which the loop interpolates (as it does the simulation's frames).

The solves run in a child process (``python -m
station.drivers.haptic.reaction FD``) connected by a socket pair: in a thread
they would share the GIL with the loop, which then waits behind them.  The
worker thread only sends the pose and waits for the answer, which releases
the GIL.  The child is started with the interpreter's ``-m`` rather than
``multiprocessing``'s spawn, which would re-run the parent's main script.
The model travels pickled over the private socket pair, between two
processes of the same program.
"""

from __future__ import annotations

import logging
import os
import socket
import subprocess
import sys
import threading
import time
from multiprocessing.connection import Connection
from typing import TYPE_CHECKING, Protocol

from station.drivers.haptic.contact import BrushState, Vec3

if TYPE_CHECKING:
    from station.drivers.haptic.loop import HapticSession

log = logging.getLogger(__name__)

ZERO: Vec3 = (0.0, 0.0, 0.0)
ANSWER_TIMEOUT_S = 1.0
SWITCH_INTERVAL_S = 0.0002
"""GIL switch interval while a worker computes in a thread beside the loop, s."""


class ReactionModel(Protocol):
    """A brush whose reaction is too costly for every tick (the deformable brush)."""

    def reaction(self, state: BrushState) -> Vec3:
        """The canvas's reaction at the handle, N, without friction or grain."""
        ...


class ReactionWorker:
    """Evaluates ``model`` on the session's newest pose at ``rate_hz`` (module docstring).

    ``process=False`` solves in the worker thread itself (tests, a machine
    without ``-m``).  Until the solver answers (the child loads it: a second or
    two), and whenever an answer is late by more than a second, no frame comes
    and the loop's watchdog keeps the reaction at zero.  Frames are stamped with
    the pose's time, so the loop renders them one frame late and smoothly.
    """

    def __init__(self, session: HapticSession, model: ReactionModel, rate_hz: float,
                 process: bool = True) -> None:
        self.session = session
        self.model = model
        self.period = 1.0 / rate_hz
        self.process = process
        self.ready = threading.Event()
        """Set once the solver answers."""
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="haptic-reaction", daemon=True)
        self._proc: subprocess.Popen[bytes] | None = None
        self._conn: Connection | None = None

    def start(self) -> None:
        if self.process:
            mine, theirs = socket.socketpair()
            try:
                self._proc = subprocess.Popen(
                    [sys.executable, "-m", "station.drivers.haptic.reaction",
                     str(theirs.fileno())], pass_fds=(theirs.fileno(),))
            finally:
                theirs.close()
            self._conn = Connection(mine.detach())
            self._conn.send(self.model)
        elif sys.getswitchinterval() > SWITCH_INTERVAL_S:
            # A thread computing holds the GIL for slices of sys.getswitchinterval()
            # (5 ms by default): the loop thread would wait that long behind a solve.
            sys.setswitchinterval(SWITCH_INTERVAL_S)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        if self._conn is not None:
            try:
                self._conn.send(None)
            except (OSError, ValueError):
                pass
        if self._proc is not None:
            try:
                self._proc.wait(timeout=2.0)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()
        if self._conn is not None:
            self._conn.close()

    def _alive(self) -> bool:
        return self._proc is None or self._proc.poll() is None

    def _evaluate(self, state: BrushState) -> Vec3:
        conn = self._conn
        if conn is None:
            return self.model.reaction(state)
        conn.send(state)
        if not conn.poll(ANSWER_TIMEOUT_S):
            raise TimeoutError(f"no answer from the reaction process within "
                               f"{ANSWER_TIMEOUT_S:g} s")
        answer = conn.recv()
        if isinstance(answer, BaseException):
            raise answer
        fx, fy, fz = answer
        return (float(fx), float(fy), float(fz))

    def _run(self) -> None:
        s = self.session
        conn = self._conn
        try:
            if conn is not None:
                while not conn.poll(0.1):  # the child's "ready": its solver is loaded
                    if self._stop.is_set() or not self._alive():
                        return
                conn.recv()
        except (EOFError, OSError):
            log.error("haptic reaction process failed to start; reaction force off")
            return
        self.ready.set()
        next_t = time.monotonic()
        while not self._stop.is_set():
            state = s.state
            if state is not None and s.gone is None:
                t0 = time.monotonic()
                try:
                    force = self._evaluate(state)
                except (EOFError, OSError):  # the child died: no more frames (watchdog: 0)
                    log.error("haptic reaction process ended; reaction force off")
                    return
                except Exception:  # a failed solve must not end the loop: zero, logged
                    log.exception("haptic reaction failed; zero until the next frame")
                    force = ZERO
                s.stats.reaction_s += time.monotonic() - t0
                s.submit_reaction(force, state.t)
            next_t += self.period
            wait = next_t - time.monotonic()
            if wait < 0:
                next_t = time.monotonic()
                wait = 0.0
            self._stop.wait(wait)


def serve(conn: Connection) -> None:
    """The child: receive the model, load its solver, answer poses until ``None``."""
    try:
        model: ReactionModel = conn.recv()
        warm = getattr(model, "warm_up", None)
        if warm is not None:
            warm()
        conn.send("ready")
        while True:
            state = conn.recv()
            if state is None:
                return
            try:
                answer: Vec3 | RuntimeError = model.reaction(state)
            except Exception as exc:  # the parent logs it and renders zero
                answer = RuntimeError(f"{exc.__class__.__name__}: {exc}")
            conn.send(answer)
    except (EOFError, OSError, KeyboardInterrupt):
        return  # the parent went away (or ^C reached the group): nothing to answer


if __name__ == "__main__":
    fd = int(sys.argv[1])
    os.set_inheritable(fd, False)
    serve(Connection(fd))
