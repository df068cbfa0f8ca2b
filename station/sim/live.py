"""The live simulation process (``station sim``).

It subscribes to pen samples (``pen.*``) and commands (``cmd``) on the bus,
feeds them to the :class:`~station.sim.player.SessionPlayer` (round brush →
canvas backend), steps the canvas at a fixed rate of ``rate`` steps per
second of wall-clock time whatever the input rate, writes a session log of
everything it applied, and publishes its status on the ``status`` topic twice
a second.  SIGTERM, SIGINT or a ``stop`` command end it cleanly: pending
stamps go into the canvas, the state and the log are saved, exit code 0.

Time stamps.  Publishers have their own clocks, so every record is logged in
the simulation's session clock (seconds since ``station sim`` started): a pen
sample keeps its device's spacing — its time is ``sample.t + offset``, the
offset fixed by the device's first sample and re-synchronised when the mapped
time strays more than :data:`RESYNC_S` from the receipt time — and is clamped
so the log never goes back in time, and moved into the time slot of the step
it is applied before (a process that falls behind compresses the records into
the steps it actually ran).  On exit a ``wait {"seconds": 0}`` marks the
session time of the last step.  Replaying the log with ``station paint`` then
applies every record between the same two steps with the same times, so on
the same backend it repaints the live canvas exactly.

Bad messages: the bus drops undecodable ones (counted in ``bus.malformed``);
a command the player rejects (unknown pigment, bad numbers) is counted in
``bad_commands``, a pen sample it refuses (a ninth pigment in the layer) in
``bad_samples``, stamps the canvas refuses in ``dropped_sources``; each is
warned about once and not logged.  The process never crashes on input.
"""

from __future__ import annotations

import logging
import math
import os
import signal
import time
from dataclasses import dataclass
from types import FrameType
from typing import Any

from station.errors import BadInput
from station.events import Command, PenSample
from station.sessionlog import SessionHeader, SessionLogWriter
from station.sim.player import SessionPlayer

log = logging.getLogger(__name__)

RESYNC_S = 1.0
STATUS_EVERY_S = 0.5
DRAIN_MAX = 2000  # messages handled between two steps at most (steps must go on)


@dataclass
class LiveConfig:
    """Settings of one ``station sim`` run."""

    bus: str | None
    width: int = 800
    height: int = 600
    profile: str = "watercolor"
    backend: str = "auto"
    seed: int = 0
    rate: float | None = None
    log_path: str | None = None
    state_path: str | None = None
    png_path: str | None = None
    status: str | None = None  # endpoint for status; "none" disables
    duration: float | None = None  # stop after this many seconds (tests, benchmarks)
    resume: str | None = None  # continue this saved canvas state (size, profile, seed)
    distributed: bool = False  # rank 0 of an MPI job: the canvas spans every rank


def default_status_endpoint(bus: str | None) -> str:
    """Where status goes: the proxy's publisher side when subscribed to the
    proxy (``ipc:sub``), else a socket of our own, ``ipc:sim-status``."""
    if bus and bus.lstrip(">@") == "ipc:sub":
        return ">ipc:pub"
    return "@ipc:sim-status"


class LiveSim:
    """The running simulation process (see the module docstring)."""

    def __init__(self, cfg: LiveConfig) -> None:
        from station.bus import Publisher, Subscriber
        from station.canvas.palette import default_palette
        from station.sim.paint import make_backend

        self.cfg = cfg
        start = None
        if cfg.resume:
            from station.canvas.state import CanvasState

            start = CanvasState.load(cfg.resume)
            cfg.width, cfg.height = start.width, start.height
            cfg.profile, cfg.seed = start.profile, start.seed
        self.canvas: Any
        if cfg.distributed:  # this is rank 0; the others follow (station.distributed.relay)
            from station.distributed.relay import Leader
            from station.sim.paint import make_distributed

            dist, self.backend_name = make_distributed(cfg.backend, cfg.width, cfg.height,
                                                       cfg.profile, cfg.seed)
            self.canvas = Leader(dist)
        else:
            self.canvas, self.backend_name = make_backend(cfg.backend, cfg.width, cfg.height,
                                                          cfg.profile, cfg.seed)
        if start is not None:
            self.canvas.load_state(start)
        self.player = SessionPlayer(self.canvas, cfg.width, cfg.height, cfg.profile,
                                    rate=cfg.rate, pigments=default_palette())
        if start is not None:
            self.player.layer_pigments.update(start.slots)
        self.sub = Subscriber(cfg.bus, topics=("pen.", "cmd"))
        status_ep = cfg.status or default_status_endpoint(cfg.bus)
        self.pub = None if status_ep == "none" else Publisher(status_ep)
        header = SessionHeader(
            width=cfg.width, height=cfg.height, profile=cfg.profile, seed=cfg.seed,
            extra={"sim": {"rate": self.player.rate}, "recorded_by": "station sim",
                   **({"resumed_from": cfg.resume} if cfg.resume else {})})
        # distributed: another rank's death kills this process from outside (mpiexec),
        # so every record goes to the OS at once and the log stays whole
        self.writer = (SessionLogWriter(cfg.log_path, header, line_buffered=cfg.distributed)
                       if cfg.log_path else None)
        self.stop_requested = False
        self.start = time.monotonic()
        self._offsets: dict[str, float] = {}
        self._last_t = 0.0
        self.samples = 0
        self.commands = 0
        self.bad_commands = 0
        self.bad_samples = 0
        self.dropped_sources = 0
        self._warned: set[str] = set()
        self._next_status = 0.0
        self._fps_mark = (self.start, 0)
        self.fps = 0.0

    # -- clock ---------------------------------------------------------------
    def now(self) -> float:
        """Session time: seconds since start."""
        return time.monotonic() - self.start

    def _in_this_step(self, t: float) -> float:
        """``t`` moved into the painting-time slot of the step about to run.

        A record applied now lands in step ``steps`` (0-based), which a replay
        gives to session times in ``[steps/rate, (steps+1)/rate) - waited``.
        Clamping the logged time into that slot (and never before the previous
        record) makes ``station paint`` of the log apply every record between
        the same two steps as this process did, so the replay is exact.
        """
        p = self.player
        lo = math.ceil((p.counters.steps / p.rate - p.waited) * 1e6) / 1e6
        hi = math.floor(((p.counters.steps + 1) / p.rate - p.waited - 2e-6) * 1e6) / 1e6
        t = round(min(max(t, lo, self._last_t), max(hi, lo)), 6)
        self._last_t = t
        return t

    def _stamp_sample(self, s: PenSample, now: float) -> PenSample:
        off = self._offsets.get(s.device)
        if off is None or abs(s.t + off - now) > RESYNC_S:
            off = self._offsets[s.device] = now - s.t
        return s.with_(t=self._in_this_step(min(now, s.t + off)), t_mono=0.0)

    # -- messages ------------------------------------------------------------
    def handle(self, kind: str, value: Any) -> None:
        now = self.now()
        if kind == "pen" and isinstance(value, PenSample):
            rec = self._stamp_sample(value, now)
            try:
                self.player.apply(rec)
            except BadInput as exc:  # e.g. a ninth pigment in the layer: not painted
                self.bad_samples += 1
                self._warn(f"sample not painted: {exc}")
                return
            self.samples += 1
            if self.writer is not None:
                self.writer.write(rec)
        elif kind == "cmd" and isinstance(value, Command):
            cmd = Command(t=self._in_this_step(now), cmd=value.cmd, args=value.args)
            if cmd.cmd == "stop":
                self.stop_requested = True
                return
            try:
                self.player.command(cmd)
            except BadInput as exc:
                self.bad_commands += 1
                self._warn(f"rejected command {cmd.cmd!r}: {exc}")
                return
            self.commands += 1
            if self.writer is not None:
                self.writer.write(cmd)
            if cmd.cmd == "wait":  # its painting time runs now, as in a replay
                while (self.player.counters.steps < self.player.steps_due(cmd.t)
                       and not self.stop_requested):  # SIGTERM cuts a long wait short
                    self.step()
                    self.maybe_publish_status()

    def _warn(self, text: str) -> None:
        """Warn once per distinct message (a bad stroke must not flood the log)."""
        if text not in self._warned:
            self._warned.add(text)
            log.warning("%s", text)

    def step(self) -> None:
        """One step; stamps the canvas refuses are dropped (counted), the step runs."""
        try:
            self.player.flush_sources()
        except BadInput as exc:
            self.dropped_sources += 1
            self._warn(f"brush sources dropped: {exc}")
        self.player.step()

    def drain(self, timeout_ms: int) -> None:
        msg = self.sub.recv(timeout_ms)
        n = 0
        while msg is not None:
            self.handle(msg.kind, msg.value)
            n += 1
            if n >= DRAIN_MAX or self.stop_requested:
                return
            msg = self.sub.recv(0)

    # -- status --------------------------------------------------------------
    def status(self) -> dict[str, Any]:
        p = self.player
        now = time.monotonic()
        mark_t, mark_steps = self._fps_mark
        if now - mark_t >= 0.25:
            self.fps = (p.counters.steps - mark_steps) / (now - mark_t)
            self._fps_mark = (now, p.counters.steps)
        session = now - self.start
        return {
            "process": "sim", "pid": os.getpid(),
            "width": self.cfg.width, "height": self.cfg.height, "profile": p.profile,
            "backend": self.backend_name, "renderer": str(getattr(self.canvas, "renderer", "")),
            "steps": p.counters.steps, "sim_time": p.counters.steps * p.dt,
            "painting_time": p.painting_time, "session_time": session,
            "lag_s": max(0.0, session + p.waited - p.painting_time),
            "fps": self.fps, "rate": p.rate,
            "samples": self.samples, "commands": self.commands,
            "bad_commands": self.bad_commands, "bad_samples": self.bad_samples,
            "dropped_sources": self.dropped_sources,
            "lost_samples": self.sub.stats.lost, "bus": self.sub.stats.as_dict(),
            "stamps": p.brush.stamps, "eraser_samples": p.brush.eraser_samples,
        }

    def maybe_publish_status(self) -> None:
        """Publish the status when the last one is :data:`STATUS_EVERY_S` old."""
        now = time.monotonic()
        if now >= self._next_status:
            self._next_status = now + STATUS_EVERY_S
            self.publish_status()

    def publish_status(self, final: bool = False) -> None:
        if self.pub is None:
            return
        st = self.status()
        st["state"] = "stopped" if final else "running"
        try:
            self.pub.publish_status(st)
        except Exception as exc:  # status is best effort; painting goes on
            log.warning("cannot publish status: %s", exc)

    # -- main loop -----------------------------------------------------------
    def run(self) -> dict[str, Any]:
        """Run until stopped; returns the final status."""
        p = self.player
        try:
            while not self.stop_requested:
                now = self.now()
                if self.cfg.duration is not None and now >= self.cfg.duration:
                    break
                if p.counters.steps < p.steps_due(now):
                    self.step()
                    self.drain(0)
                else:
                    next_step = (p.counters.steps + 1) / p.rate - p.waited
                    self.drain(max(0, min(100, int((next_step - now) * 1000) + 1)))
                self.maybe_publish_status()
        finally:
            final = self.shutdown()
        return final

    def shutdown(self) -> dict[str, Any]:
        """Hand pending stamps to the canvas, save state, PNG and log."""
        p = self.player
        try:
            p.flush_sources()
        except BadInput as exc:
            self.dropped_sources += 1
            self._warn(f"brush sources dropped: {exc}")
        if self.writer is not None:
            # End marker: a no-op wait at the session time the last step belongs to, so
            # a replay of the log runs as many steps as this process did.
            # (rounded up to the µs, so it does not fall just short of the step's end)
            t_end = max(self._last_t, p.counters.steps / p.rate - p.waited)
            t_end = math.ceil(t_end * 1e6) / 1e6
            self.writer.write(Command(t=t_end, cmd="wait", args={"seconds": 0.0}))
            # closed before the canvas is saved: the log survives whatever happens next
            # (a distributed canvas needs every rank alive to gather its state)
            self.writer.close()
        if self.cfg.state_path:
            self.canvas.state().save(self.cfg.state_path)
        if self.cfg.png_path:
            from station.sim.paint import write_image

            write_image(self.cfg.png_path, self.canvas.render())
        if hasattr(self.canvas, "close") and self.cfg.distributed:
            self.canvas.close()  # the follower ranks return
        final = self.status()
        self.publish_status(final=True)
        self.sub.close()
        if self.pub is not None:
            self.pub.close()
        return final

    def install_signal_handlers(self) -> None:
        def on_signal(signum: int, frame: FrameType | None) -> None:
            self.stop_requested = True

        signal.signal(signal.SIGTERM, on_signal)
        signal.signal(signal.SIGINT, on_signal)
