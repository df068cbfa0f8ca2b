"""One painting: the live simulation running inside the kiosk process.

:class:`KioskSession` holds a :class:`~station.sim.live.LiveSim` (the same bus
subscription, session clock, session log and exact-replay time stamping as
``station sim``; :attr:`KioskSession.sim`) and adds what a window needs:

* pen samples arrive in *screen* coordinates (a calibrated driver maps the
  tablet onto the screen); the view maps them to canvas coordinates before
  the player sees them, and samples over the UI panel never reach the canvas;
* the tiles that may have changed since the last frame (dirty tiles), so the
  CPU display re-renders only those;
* for the latency benchmark, the driver read time of every sample that made
  paint, until a frame shows it;
* a simulation thread (:meth:`KioskSession.start_worker`), so the window never
  waits for a step.

The simulation thread.  Steps are due 30 times a second and take several
milliseconds each on the CPU backends; run in the frame loop, a pen sample
arriving as a step starts waits for the step and then for a frame.  So the
steps run in a thread of their own, and a lock (:attr:`KioskSession.lock`)
keeps the window's thread and the steps apart — but only while a step takes
what it needs from the brush (:meth:`SessionPlayer.take_step`: the stamps due and
their shares, the beads, the deformable brush's pick-ups).  The rest of the step
(:meth:`SessionPlayer.apply_step`: the stamps summed and added, the beads run out,
the canvas kernel; nearly all of it) runs with the lock released
(:meth:`KioskSession.run_step`; the kernel in a niced thread of its own): then the
window applies the pen samples that only feed the brush (their stamps wait for the
next step's take, as they would anyway), a stroke's first sample included, and
renders the tiles it needs.  An autosave's
compression and write run with it released too (:meth:`KioskSession._maybe_autosave`).
Everything else (commands, tools, the eraser) waits for the step to end.  A sample
applied during step *k* is logged in the time slot of step *k + 1*, where its stamps
go, so a replay of the log (``station paint``) gives the same pixels.  The
display may read a tile while the kernel writes it; the tile is marked dirty
by the step and rendered again in the next frame.

Undo checkpoints.  The live sim's undo history copies the canvas (44 MB at
800×600) before a stroke's first sample; done there, in the window's thread,
that copy stalled the frames and every sample queued behind it for tens of
milliseconds at each stroke start.  Here the checkpoint keeps the canvas's
arrays by reference (the player is copied at once, as before), and the copy is
made before anything next changes the canvas: at the start of the next step
(in the simulation thread, lock released as for the kernel), or before a
command or a tool's sample.  Nothing changes the canvas in between, so the
checkpoint holds the same numbers as one copied at once.  A step copies only the
arrays a step writes (:data:`~station.canvas.state.STEP_FIELDS`): the paper, the dried
layers (``r_composed``, 94 MiB at 1920×1080), the mask and the tools' fields stay shared
until a command or a tool's dab comes, and are then copied once for every checkpoint
sharing them.  An array that is zero in every bit (a slot's ``removed_p``, the ``q`` of a
fresh wash) is kept as a zero view, no memory.  The step copies in pieces
(:data:`PIECE_BYTES`), each after the window's frame in progress, if any, has ended (for
at most :data:`PIECE_WAIT_S`): the copy does not take the cores from a frame.  A stroke
that starts while step *k*'s kernel runs is logged after step *k*, so its checkpoint must be
the canvas as step *k* leaves it: the arrays are shared anyway, and the small
fields and the step count are taken when the step is over
(:meth:`KioskSession.finish_mid_step`).  Samples applied while the step copies
checkpoints (before it takes the stamps) are logged before it, as they paint.

Why in-process and not a separate ``station sim`` feeding the window over the
bus: the window needs the canvas every frame (60 per second); across a
process boundary that is a 800×600×3 float image per frame on the CPU, or a
shared GL context that two processes cannot have.  The pen still comes over
the bus, so drivers, recorders and the blueprint see the same traffic as with
``station sim``.
"""

from __future__ import annotations

import logging
import threading
import time
import weakref
from collections import deque
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numba
import numpy as np

from station.answer import parse_request
from station.brush.deformable import DeformableBrush
from station.brush.stamp import RoundBrush
from station.bus import Subscriber, runtime_dir
from station.canvas.state import ARRAY_FIELDS, STEP_FIELDS
from station.events import Command, PenSample, Tool
from station.kiosk.locked_backend import OffloadedKernel, SharedState
from station.kiosk.moisture import DAMP_WATER, Moisture
from station.kiosk.niced import NicedRunner
from station.sim.haptic import HapticFeedback
from station.sim.journal import SessionJournal
from station.sim.live import SYNC_EVERY_S, Counters, LiveConfig
from station.sim.live_bus import LiveSim
from station.sim.player import SessionPlayer
from station.sim.undo import Checkpoint, UndoHistory

log = logging.getLogger(__name__)

#: Commands that may change every cell: the display re-renders the whole canvas.
WHOLE_CANVAS_COMMANDS = frozenset({"dry", "new_layer", "clear", "profile", "undo"})

#: Rounds of undo-checkpoint copies with the lock released before a step's kernel (a
#: stroke that starts during one is copied in the next; after these, under the lock).
COPY_ROUNDS = 4

DRAIN_BUDGET_S = 0.004  # bus messages handled per frame at least this long, if waiting

#: Commands whose only canvas writes are a step's (a brush swap hands its stamps over):
#: before them the deferred checkpoints copy only :data:`STEP_FIELDS`.
STEP_WRITE_COMMANDS = frozenset({"brush", "wait"})

#: A step's checkpoint copy goes in pieces of at most this many bytes (~1 ms each) ...
PIECE_BYTES = 2 << 20
#: ... each after the window's frame in progress has ended, waiting for it at most this long.
PIECE_WAIT_S = 0.004
_PROBE = 4099  # every this many elements probed first: most arrays are not all zero

Pause = Callable[[], None]


def _no_pause() -> None:
    """Copy straight through (the lock is held: nobody could use a pause)."""


def frozen_copy(a: np.ndarray, pause: Pause = _no_pause, piece: int = PIECE_BYTES
                ) -> np.ndarray:
    """A checkpoint's copy of ``a``: a read-only zero view (no memory) when every bit of
    ``a`` is zero (``-0.0`` is not: the copy is bit-exact), else a copy made in pieces of
    at most ``piece`` bytes with ``pause()`` between them."""
    if not a.flags.c_contiguous:
        return a.copy()
    flat = a.reshape(-1)
    bits = flat.view(np.dtype(f"u{a.itemsize}")) if a.itemsize in (1, 2, 4, 8) else None
    if bits is not None and not bits[::_PROBE].any() and not bits.any():
        return np.broadcast_to(np.zeros((), a.dtype), a.shape)
    out = np.empty_like(a)
    dst = out.reshape(-1)
    step = max(1, piece // max(a.itemsize, 1))
    for i in range(0, flat.size, step):
        if i:
            pause()
        dst[i:i + step] = flat[i:i + step]
    return out


def _shared_with(cp: Any, live: Any) -> set[str]:
    """The arrays of checkpoint state ``cp`` that are (views of) the live canvas's: those a
    deferred checkpoint must still copy (the steady arrays of an earlier checkpoint of the
    same epoch, :meth:`UndoHistory.canvas_checkpoint`, are copies already)."""
    return {n for n in ARRAY_FIELDS if np.may_share_memory(getattr(cp, n), getattr(live, n))}


def held_bytes(a: np.ndarray) -> int:
    """Memory ``a`` holds of its own: none for a zero view (all strides 0)."""
    return 0 if a.size and not any(a.strides) else int(a.nbytes)


@dataclass
class Deferred:
    """An undo checkpoint (held weakly: the history lets old ones go) and the names of
    the arrays it still shares with the live canvas."""

    ref: weakref.ref[Checkpoint]
    pending: set[str] = field(default_factory=lambda: set(ARRAY_FIELDS))

    @property
    def cp(self) -> Checkpoint | None:
        return self.ref()


@dataclass
class LockWaits:
    """How long the window's thread waited for the session's lock (the simulation thread
    held it): ``n`` times it took it, ``waited`` of them longer than 1 ms, ``total_s``
    and ``max_s`` seconds (``station bench latency`` reports them)."""

    n: int = 0
    waited: int = 0
    total_s: float = 0.0
    max_s: float = 0.0

    def add(self, seconds: float) -> None:
        self.n += 1
        self.total_s += seconds
        if seconds > 1e-3:
            self.waited += 1
        self.max_s = max(self.max_s, seconds)


PenMapper = Callable[[PenSample], "PenSample | None"]
KioskCommands = Callable[[Command], bool]


class KioskSession:
    """The live simulation of one painting (see the module docstring).

    It holds ``station sim``'s :class:`LiveSim` (:attr:`sim`) and plugs into its two
    seams: records applied while a step's kernel runs belong to the next step
    (:meth:`LiveSim.records_in_next_step`), and every step tells the display which
    tiles changed (:class:`~station.sim.live.StepHooks`).

    ``map_pen`` turns a screen-space sample into the canvas-space sample to
    paint, or ``None`` when the canvas must not see it (the pen is over the UI).
    """

    process_kind = "kiosk"

    def __init__(self, cfg: LiveConfig, map_pen: PenMapper | None = None,
                 kiosk_command: KioskCommands | None = None) -> None:
        self.sim = LiveSim(cfg)
        self.sim.answer_as(self.process_kind)
        self.sim.slot_ahead = self._slot_ahead
        self.sim.step_hooks = self
        self.map_pen = map_pen
        self.kiosk_command = kiosk_command
        self.started_wall = time.time()
        self.started_mono = time.monotonic()  # the window's own devices (the mouse) count from here
        ty, tx = self._tile_shape()
        self.dirty = np.ones((ty, tx), bool)  # everything needs its first render
        self.whole_dirty = True
        self.awaiting_paint: list[float] = []  # driver read times (monotonic) not yet shown
        self.last_pen: PenSample | None = None  # last screen-space sample
        self.last_canvas_pen: PenSample | None = None
        self.painted_stamps = 0
        self.painting_id = ""  # the gallery id the window gives this painting
        self.resumed = False  # the painting in progress a killed kiosk left, continued
        # the simulation thread (start_worker) and what it shares with the window
        self.lock = threading.Condition()
        self.inflight = False  # the canvas kernel of a step runs now, the lock released
        self._copying = False  # (with inflight) the step copies undo checkpoints first
        self._release_for_step = False  # run_step releases the lock (_step_unlocked)
        self.sim_seconds = 0.0  # wall time spent in steps (either thread)
        # (start, end) perf_counter times of the recent steps, for a bench's window
        self.step_times: deque[tuple[float, float]] = deque(maxlen=4096)
        self.samples_during_steps = 0  # pen samples applied while a kernel ran
        self.lock_waits = LockWaits()  # the window's waits for the lock (window_lock)
        self.worker_error: BaseException | None = None
        self.queue_log: list[float] | None = None  # bench: driver read → handled [s]
        self._worker: threading.Thread | None = None
        self._nice = 0  # the kernel thread's niceness above the window's
        # the step's kernel, niced (start_worker)
        self._runner: NicedRunner | None = None
        self._halt = threading.Event()
        self._window_waits = 0  # the window's thread waits for the step to end
        # undo checkpoints still holding the live canvas arrays (see the module docstring)
        self._lazy: list[Deferred] = []
        self._mid_step: list[Deferred] = []  # ... taken while a step's kernel ran
        self.checkpoint_bytes_copied = 0  # into deferred checkpoints, so far
        self._frame_idle = threading.Event()  # no window frame is being drawn now
        self._frame_idle.set()
        self._checkpoint_now = self.history._checkpoint
        self.history._checkpoint = self._checkpoint_deferred  # type: ignore[method-assign]

    # -- the simulation's parts the window reads ------------------------------------
    @property
    def cfg(self) -> LiveConfig:
        return self.sim.cfg

    @property
    def player(self) -> SessionPlayer:
        return self.sim.player

    @property
    def canvas(self) -> Any:
        """The backend (numpy, cpu or gl canvas: :func:`station.sim.paint.make_backend`)."""
        return self.sim.canvas

    @property
    def history(self) -> UndoHistory:
        return self.sim.history

    @property
    def counters(self) -> Counters:
        return self.sim.counters

    @property
    def sub(self) -> Subscriber:
        """The bus subscription the pen and commands come on."""
        return self.sim.sub

    @property
    def journal(self) -> SessionJournal:
        return self.sim.journal

    @property
    def haptics(self) -> HapticFeedback:
        return self.sim.haptics

    @property
    def backend_name(self) -> str:
        return self.sim.backend_name

    @property
    def log_path(self) -> Path:
        return Path(self.sim.log_path)

    @property
    def autosave_path(self) -> Path:
        return Path(self.sim.autosave_path)

    @property
    def stop_requested(self) -> bool:
        return self.sim.stop_requested

    def now(self) -> float:
        """Session time (s): :meth:`LiveSim.now`."""
        return self.sim.now()

    def status(self) -> dict[str, Any]:
        return self.sim.status()

    def shutdown(self) -> dict[str, Any]:
        """End the painting's simulation: :meth:`LiveSim.shutdown` (log end marker, last
        autosave, endpoints closed)."""
        return self.sim.shutdown()

    # -- geometry ----------------------------------------------------------------
    def _tile_shape(self) -> tuple[int, int]:
        canvas: Any = self.canvas  # every backend has params (the protocol does not say)
        ts = int(canvas.params.tile_size)
        return -(-self.cfg.height // ts), -(-self.cfg.width // ts)

    @property
    def cpu_state(self) -> Any:
        """The live :class:`CanvasState` of a CPU backend (no copy), else ``None``."""
        return getattr(self.canvas, "live_state", None)

    # -- input -------------------------------------------------------------------
    def handle(self, kind: str, value: Any, topic: str = "", replay: bool = False) -> None:
        if kind == "pen" and isinstance(value, PenSample):
            self.last_pen = value
            if self.queue_log is not None and value.t_mono > 0.0:
                self.queue_log.append(time.monotonic() - value.t_mono)
            sample = self.map_pen(value) if self.map_pen is not None else value
            if sample is None:
                return
            self.last_canvas_pen = sample
            with self.window_lock():
                self._apply_pen(value, sample, topic, replay)
            return
        if kind == "cmd" and isinstance(value, Command) and self.kiosk_command is not None:
            req = parse_request(value.reply, runtime_dir()) if value.reply else None
            if req is not None and req.expect not in (None, self.process_kind):
                self.sim.counters.bad_commands += 1  # a `station send --to sim` found us
                self.sim.answer(req, value.cmd, False, f"this is a kiosk, not a {req.expect}")
                return
            if self.kiosk_command(value):
                # the window's own command (view, save, screenshot): not the canvas's
                self.sim.answer(req, value.cmd, True, f"the kiosk window took {value.cmd}")
                return
        with self.lock:
            if kind == "cmd":  # a command may change the canvas (heartbeats do not)
                self._wait_step()
                step_only = isinstance(value, Command) and value.cmd in STEP_WRITE_COMMANDS
                self.materialize_checkpoints(STEP_FIELDS if step_only else None)
            self.sim.handle(kind, value, topic, replay)
            if kind == "cmd" and isinstance(value, Command) and value.cmd in WHOLE_CANVAS_COMMANDS:
                self.mark_all_dirty()

    def _apply_pen(self, value: PenSample, sample: PenSample, topic: str,
                   replay: bool) -> None:
        """Apply one mapped pen sample (lock held)."""
        if self._brush_only(sample):
            if self.inflight:
                self.samples_during_steps += 1
        else:
            self._wait_step()
            self.materialize_checkpoints()  # a tool's dab changes the canvas
        before = self.player.brush.stamps
        self.sim.handle("pen", sample, topic, replay)
        made = self.player.brush.stamps - before
        if made > 0:
            self.painted_stamps += made
            if value.t_mono > 0.0:
                self.awaiting_paint.append(value.t_mono)

    def run_step(self, job: Callable[[], None]) -> None:
        """A step's canvas part (``job``: the stamps summed and added, the beads, the
        dryer, the kernel; :meth:`SessionPlayer.apply_step`), after the step took its
        stamps and beads from the brush under the lock: in a step of the simulation
        thread (:meth:`_step_unlocked`), run with the lock released, its kernel in the
        niced kernel thread (:meth:`offload`, :class:`OffloadedKernel`; the sum and add
        keep the window's priority: they hold the interpreter's lock between numpy's
        calls, and a niced holder descheduled under load would hold the window with
        it).  Under load
        a full-HD step's sum and add held every pen sample for up to 150 ms.  Brush
        samples go straight on meanwhile, a stroke's first included: they belong to the
        next step (:meth:`_slot_ahead`), whose take takes their stamps, as a replay
        applying them after this step does.  The tiles wait for the step's end;
        commands and tools wait (:meth:`_wait_step`).  Elsewhere (a ``wait`` command's
        steps, the steps of a kiosk without the thread) ``job`` runs here, the lock
        held."""
        if not self._release_for_step:
            job()
            return
        with self._lock_released(copying=False):
            job()

    @contextmanager
    def _lock_released(self, copying: bool = True) -> Iterator[None]:
        """The lock released in the simulation thread (held on entry and on exit) while
        ``inflight`` and ``_copying`` (a checkpoint's copy, an autosave's write) or not
        (a step's canvas part) say why: the window draws on, commands and tools wait."""
        self.inflight = True
        self._copying = copying
        self.lock.release()
        try:
            yield
        finally:
            self.lock.acquire()
            self.inflight = self._copying = False
            self._prune()
            self.lock.notify_all()

    @contextmanager
    def window_lock(self) -> Iterator[None]:
        """The lock, as the window's thread takes it for a pen sample or the preview: how
        long it waited for the simulation thread is counted (:attr:`lock_waits`)."""
        t0 = time.perf_counter()
        with self.lock:
            self.lock_waits.add(time.perf_counter() - t0)
            yield

    def _brush_only(self, s: PenSample) -> bool:
        """Whether applying ``s`` touches nothing but the brush's own state (no
        canvas read or write; its stamps reach the canvas in the next step): no tool in
        hand, no diffusion controller, no eraser.  Both brushes qualify: the deformable
        one reads only the paper's height, which no step changes, and queues its
        pick-ups for the next step.  A stroke's first sample is one: its undo checkpoint shares the
        canvas and is finished after the step (see :meth:`finish_mid_step`)."""
        p = self.player
        return (isinstance(p.brush, RoundBrush | DeformableBrush) and p.tool is None
                and p.controller is None and s.tool is not Tool.ERASER)

    # -- undo checkpoints, copied when the canvas is next changed ---------------------
    def _checkpoint_deferred(self) -> Any:
        """The undo history's checkpoint with the canvas arrays by reference (copied by
        :meth:`materialize_checkpoints`); during an undo's replay, a copy at once."""
        st = self.cpu_state
        if self.history.replaying or st is None:
            return self._checkpoint_now()
        p = self.player
        real = p.backend
        p.backend = SharedState(real, st)
        try:
            cp = self._checkpoint_now()
        finally:
            p.backend = real
        entry = Deferred(weakref.ref(cp), _shared_with(cp.state, st))
        self._lazy.append(entry)
        if self.inflight and not self._copying:
            self._mid_step.append(entry)
        self._prune()
        return cp

    def finish_mid_step(self) -> None:
        """Finish the checkpoints taken while a step's kernel ran (lock held, the step
        over).  Such a stroke's records belong after that step (:meth:`_in_this_step`),
        so its checkpoint is the canvas as the step left it: the arrays are shared and
        were written by the kernel, the small fields are taken now, and the player's
        step count is the step's.  The player's other fields were taken when the stroke
        started; a step changes none of them after its kernel."""
        if not self._mid_step:
            return
        p = self.player
        real = p.backend
        p.backend = SharedState(real, self.cpu_state)
        try:
            for entry in self._mid_step:
                cp = entry.cp
                if cp is None:
                    continue
                # the canvas only: the player was copied when the stroke started
                cp.state, cp.n_slots, cp.nbytes = self.history.canvas_checkpoint()
                cp.player["counters"].steps = p.counters.steps
                entry.pending = _shared_with(cp.state, self.cpu_state)  # shared again
        finally:
            p.backend = real
        self._mid_step.clear()

    def materialize_checkpoints(self, fields: frozenset[str] | None = None) -> None:
        """Copy the arrays named by ``fields`` (all: ``None``) into the checkpoints that
        still share them with the canvas, before something writes them: a step
        :data:`STEP_FIELDS`, a command or a tool's dab all of them.  Lock held, or in
        the simulation thread during a step's copy (:meth:`_copy_unlocked`: the list
        is changed only under the lock)."""
        pause = self._between_frames if self._copying else _no_pause
        self._copy_pending(list(self._lazy), fields, pause)
        if not self._copying:
            self._prune()

    def _copy_pending(self, entries: list[Deferred], fields: frozenset[str] | None,
                      pause: Pause) -> None:
        """The copies themselves: each array once, however many checkpoints share it."""
        made: dict[tuple[str, int, tuple[int, ...]], np.ndarray] = {}
        for entry in entries:
            cp = entry.cp
            if cp is None:
                continue
            names = entry.pending if fields is None else entry.pending & fields
            for name in sorted(names):
                a = getattr(cp.state, name)
                key = (name, int(a.__array_interface__["data"][0]), a.shape)
                got = made.get(key)
                if got is None:
                    got = made[key] = frozen_copy(a, pause)
                    self.checkpoint_bytes_copied += held_bytes(got)
                setattr(cp.state, name, got)
            entry.pending -= names

    def _prune(self) -> None:
        """Forget the checkpoints copied whole or let go by the history (lock held)."""
        self._lazy = [e for e in self._lazy if e.pending and e.cp is not None]

    def pending_bytes(self, fields: frozenset[str] | None = None) -> int:
        """Bytes the deferred checkpoints still share with the canvas (of ``fields``)."""
        out = 0
        for e in self._lazy:
            cp = e.cp
            if cp is not None:
                names = e.pending if fields is None else e.pending & fields
                out += sum(getattr(cp.state, n).nbytes for n in names)
        return out

    def frame_begins(self) -> None:
        """The window draws a frame now: a step's copy waits for it (:data:`PIECE_WAIT_S`)."""
        self._frame_idle.clear()

    def frame_ends(self) -> None:
        self._frame_idle.set()

    def _between_frames(self) -> None:
        self._frame_idle.wait(PIECE_WAIT_S)

    def _wait_step(self) -> None:
        """Wait (lock held) until no canvas kernel runs.  The thread lets a waiting
        window in before its next step (a thread behind schedule steps back to back)."""
        self._window_waits += 1
        try:
            while self.inflight:
                self.lock.wait()
        finally:
            self._window_waits -= 1

    def wait_step(self) -> None:
        """Wait (lock held) until no step's kernel writes the canvas: what a screenshot
        shows is the canvas between steps."""
        self._wait_step()

    @property
    def kernel_running(self) -> bool:
        """Whether a step's canvas part (its stamps' add, beads, kernel:
        :meth:`run_step`) writes the canvas now (the lock released meanwhile): the state
        is half old, half new until it ends."""
        return self.inflight and not self._copying

    def _slot_ahead(self) -> bool:
        """While step *k*'s canvas part runs (:meth:`run_step`: its take is over) a record
        belongs to step *k + 1* (its stamps were not in step *k*); not while the step
        copies checkpoints (it has not taken the stamps yet)."""
        return self.inflight and not self._copying

    def render_between_steps(self) -> np.ndarray:
        """The whole canvas rendered (linear RGB, H×W×3), with no step running."""
        with self.lock:
            self._wait_step()
            return np.asarray(self.canvas.render())

    def command(self, name: str, **args: Any) -> None:
        """Apply a command from the UI exactly as one from the bus (and log it)."""
        self.handle("cmd", Command(t=self.now(), cmd=name, args=args))

    def eraser_selected(self) -> bool:
        return self.last_pen is not None and self.last_pen.tool is Tool.ERASER

    # -- stepping ------------------------------------------------------------------
    def step(self) -> None:
        """One step of the simulation (:meth:`LiveSim.step`, with :meth:`before_step`
        and :meth:`after_step` around it)."""
        self.sim.step()

    def before_step(self) -> None:
        """The tiles active before the step (it may dry them), and the undo checkpoints
        copied before its kernel writes the canvas."""
        st = self.cpu_state
        if st is not None:
            self._note_active(st)
        if any(e.pending & STEP_FIELDS for e in self._lazy):
            self._copy_unlocked()

    def after_step(self) -> None:
        st = self.cpu_state
        if st is not None:
            self._note_active(st)

    def _note_active(self, st: Any) -> None:
        if not st.tiling:
            self.whole_dirty = True
            return
        self.dirty |= st.tile_ttl > 0

    # -- the simulation thread ------------------------------------------------------
    def start_worker(self, nice: int = 0) -> None:
        """Run the due steps in a thread of their own from now on (see module docstring),
        their kernels ``nice`` steps lower in the system's priority than the window's
        thread (:mod:`station.kiosk.niced`: what runs under the lock keeps the window's
        priority, and so do the undo checkpoints' copies, unlocked: the step waits for
        them, and niced a 1920×1080 canvas's copy took 10-13 s at load 15).  Not for a
        GPU canvas: its GL context belongs to the window's thread."""
        if self._worker is not None or self.cpu_state is None:
            return
        self._nice = nice
        # the window's thread needs a core of its own to show the pen: the simulation's
        # parallel loops take the others (numba's count is per launching thread).  On
        # the 2-core development machine one thread even steps faster than two that
        # fight the window for the cores (bench latency: 8 against 11 ms a step).
        self._runner = NicedRunner(nice, max(1, numba.get_num_threads() - 1))
        self._halt.clear()
        self._worker = threading.Thread(target=self._work, name="kiosk-sim", daemon=True)
        self._worker.start()

    @property
    def threaded(self) -> bool:
        """Whether the steps run in the simulation thread."""
        return self._worker is not None

    def stop_worker(self) -> None:
        """Stop the simulation thread after its current step (the painting stays whole)."""
        worker, self._worker = self._worker, None
        if worker is None:
            return
        self._halt.set()
        worker.join()
        runner, self._runner = self._runner, None
        if runner is not None:
            runner.close()

    def offload(self, job: Callable[[], None]) -> None:
        """Run ``job`` (a step's kernel: the lock released by the caller) in the niced
        kernel thread when the simulation thread asks, else here."""
        runner = self._runner
        if runner is None or threading.current_thread() is not self._worker:
            job()
        else:
            runner.run(job)

    def check_worker(self) -> None:
        """Raise what stopped the simulation thread, in the window's thread."""
        err, self.worker_error = self.worker_error, None
        if err is not None:
            raise err

    def _work(self) -> None:
        # at the window's priority: this thread holds the lock that every pen sample
        # needs; the kernel goes to the niced runner (offload).  Its own
        # parallel loops (a deformable brush's pick-ups) leave the window a core too.
        numba.set_num_threads(max(1, numba.get_num_threads() - 1))
        try:
            while not self._halt.is_set():
                with self.lock:
                    while self._window_waits:  # the window first (lock released meanwhile)
                        self.lock.wait(0.002)
                    wait = self.sim.seconds_to_next_step()
                    if wait <= 0.0:
                        t0 = time.perf_counter()
                        self._step_unlocked()
                        t1 = time.perf_counter()
                        self.sim_seconds += t1 - t0
                        self.step_times.append((t0, t1))
                        self._maybe_autosave()
                    sync = self.sim.journal.sync_due(SYNC_EVERY_S)
                    if sync:  # what the window's records handed the kernel so far
                        self.sim.journal.flush()
                if sync:  # ... made durable, the lock free (housekeeping does not)
                    self.sim.journal.fsync_flushed()
                if wait <= 0.0:
                    continue
                self._halt.wait(min(wait, 0.05))
        except BaseException as exc:  # the window's thread reports it (check_worker)
            log.exception("the simulation thread failed")
            self.worker_error = exc

    def _maybe_autosave(self) -> None:
        """:meth:`LiveSim.maybe_autosave` in the simulation thread (lock held) with the
        compression and the write done with the lock released, the canvas shared, not
        copied: at 1920×1080 a wet canvas's autosave took 8 s, every pen sample held.
        Nothing writes the canvas meanwhile: brush samples touch only the brush (and
        belong to the step about to run, as during the checkpoints' copy), commands and
        tools wait for the flag as for a kernel."""
        sim = self.sim
        st = self.cpu_state
        if threading.current_thread() is not self._worker or st is None:
            sim.maybe_autosave()
            return
        if not sim.autosave_due():
            return
        job = sim.begin_autosave(SharedState(self.canvas, st).state())
        if job is None:
            return
        with self._lock_released():
            job()

    def sim_busy(self, t0: float, t1: float) -> float:
        """Seconds of ``[t0, t1]`` (``perf_counter``) spent in steps."""
        return sum(max(0.0, min(b, t1) - max(a, t0)) for a, b in list(self.step_times))

    def _copy_unlocked(self) -> None:
        """:meth:`materialize_checkpoints` with the lock released when the simulation
        thread holds it (brush samples go on meanwhile; nothing else changes the canvas).
        A stroke that started during the copy: its checkpoint (the canvas before this
        step, as its records are) is copied next, before the kernel writes the canvas,
        with the lock released again (copied under it, a whole 1920×1080 canvas held every
        pen sample for 2.6 s at load 17), up to :data:`COPY_ROUNDS` times."""
        if threading.current_thread() is not self._worker:
            self.materialize_checkpoints(STEP_FIELDS)
            return
        for _ in range(COPY_ROUNDS):
            if not any(e.pending & STEP_FIELDS for e in self._lazy):
                return
            with self._lock_released():
                self.materialize_checkpoints(STEP_FIELDS)
        self.materialize_checkpoints(STEP_FIELDS)  # strokes kept starting: under the lock

    def _step_unlocked(self) -> None:
        """One step (lock held), its canvas part run with the lock released
        (:meth:`run_step`)."""
        p = self.player
        real = p.backend
        p.backend = OffloadedKernel(real, self.offload)
        self._release_for_step = True
        try:
            self.step()
        finally:
            self._release_for_step = False
            p.backend = real
        self.finish_mid_step()

    def run_due_steps(self, max_steps: int = 2) -> int:
        """Run the steps due by the session clock: one, or up to ``max_steps`` when more
        than three are due (a frame waits for at most that many; a slow machine falls
        behind and catches up as ``station sim`` does); then ``station sim``'s
        housekeeping (autosave between strokes, log sync, silent devices)."""
        sim = self.sim
        limit = max_steps if sim.steps_due() > 3 else 1
        n = 0
        t0 = time.perf_counter()
        while n < limit and sim.steps_due() > 0:
            self.step()
            n += 1
        if n:
            t1 = time.perf_counter()
            self.sim_seconds += t1 - t0
            self.step_times.append((t0, t1))
        if n:
            sim.maybe_autosave()
        sim.journal.maybe_sync(SYNC_EVERY_S)
        sim.check_devices()
        return n

    def housekeeping(self) -> None:
        """``station sim``'s housekeeping when the thread runs the steps (the log handed to
        the kernel, silent devices; the simulation thread fsyncs the log, without the lock:
        an fsync here held the window's frame), in the window's thread after each pass:
        not when the simulation thread
        holds the lock (the start or end of a step), the next pass does it.  Waiting
        for it made the window's slowest frames on a wholly wet 1920×1080 canvas
        (140-650 ms at load 6-8, when a step summed and added its stamps under the lock)."""
        if not self.lock.acquire(blocking=False):
            return
        try:
            self.sim.journal.flush()  # (the simulation thread fsyncs, without the lock)
            self.sim.check_devices()
        finally:
            self.lock.release()

    def pump(self) -> None:
        """Handle the messages waiting on the bus (no blocking)."""
        self.drain(0)

    def drain(self, timeout_ms: int, budget_s: float = DRAIN_BUDGET_S,
              floor_s: float = DRAIN_BUDGET_S) -> None:
        """Handle waiting messages for at most ``budget_s``, but at least ``floor_s``
        (after waiting up to ``timeout_ms`` for the first): a window that fell behind
        draws what it has handled and takes the rest in the next frames, instead of
        handling a growing queue before it draws again (each frame longer, the queue
        longer).  At least one message is handled when one is there."""
        sub = self.sim.sub
        msg = sub.recv(timeout_ms)
        deadline = time.perf_counter() + max(budget_s, floor_s)
        while msg is not None:
            self.handle(msg.kind, msg.value, msg.topic, msg.replay)
            if self.stop_requested or time.perf_counter() > deadline:
                return
            msg = sub.recv(0)

    def mark_all_dirty(self) -> None:
        self.whole_dirty = True
        self.dirty[:] = True

    def take_dirty(self) -> np.ndarray:
        """Tiles whose pixels may have changed since the last call: the active ones
        grown by one tile (a pass reaches one cell into a quiet neighbour)."""
        if self.whole_dirty:
            out = np.ones_like(self.dirty)
        else:
            d = self.dirty
            out = d.copy()
            out[1:] |= d[:-1]
            out[:-1] |= d[1:]
            out[:, 1:] |= out[:, :-1].copy()
            out[:, :-1] |= out[:, 1:].copy()
        self.dirty[:] = False
        self.whole_dirty = False
        return out

    # -- status --------------------------------------------------------------------
    def wet_fraction(self) -> float | None:
        """Share of cells holding surface water (CPU backends; ``None`` on GL)."""
        st = self.cpu_state
        if st is None:
            return None
        return float(np.count_nonzero(st.w > 0)) / float(st.w.size)

    def moisture(self) -> Moisture | None:
        """How wet the paper is (CPU backends; ``None`` on GL, whose state is on the GPU)."""
        st = self.cpu_state
        if st is None:
            return None
        wet = st.w > 0
        damp = ~wet & (st.wc > DAMP_WATER)
        n = float(st.w.size)
        return Moisture(float(np.count_nonzero(wet)) / n, float(np.count_nonzero(damp)) / n)

    def active_tiles(self) -> int | None:
        st = self.cpu_state
        return None if st is None else int(np.count_nonzero(st.tile_ttl > 0))
