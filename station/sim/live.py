"""The live simulation (``station sim``): :class:`LiveCore` paints, ``LiveSim`` listens.

:class:`LiveCore` is the simulation without a bus, for ``station sim`` and the
kiosk alike: feed it pen samples and commands (:meth:`LiveCore.feed_sample`,
:meth:`LiveCore.feed_command`, or :meth:`LiveCore.handle` for bus messages),
call :meth:`LiveCore.tick` as often as you can (it runs the steps due at the
fixed ``rate`` of steps per wall-clock second, whatever the input rate, flushes
the log, autosaves and watches for silent devices), and :meth:`LiveCore.shutdown`
at the end.  :class:`~station.sim.live_bus.LiveSim` adds the bus: it subscribes to
``pen.*``, ``hb.*`` and ``cmd`` (also on a command endpoint of its own, for ``station send``) and
publishes the status on the ``status`` topic twice a second and whenever a
device falls silent.  SIGTERM, SIGINT or a ``stop`` command end it cleanly:
pending stamps go into the canvas, the state and the log are saved, exit 0.

No painting is lost.  Every run keeps a session log (:mod:`station.sim.journal`:
``--log`` or a new file in the user's data directory; an existing log is never
overwritten).  Every record is in the kernel before the step that paints it
runs, so a ``kill -9`` loses nothing painted.  Every ``autosave`` seconds,
between strokes, the full state (canvas, player, counters, and how many log
records it holds) is written atomically next to the log.  ``--recover LOG``
loads that state, replays the log records after it exactly as they were applied
(:mod:`station.sim.recovery`) and goes on appending to the same log.

Time stamps.  Publishers have their own clocks, so every record is logged in
the simulation's session clock (seconds since ``station sim`` started): a pen
sample keeps its device's spacing — its time is ``sample.t + offset``, the
offset fixed by the device's first sample and re-synchronised when the mapped
time strays more than :data:`RESYNC_S` from the receipt time — and is clamped
so the log never goes back in time, and moved into the time slot of the step
it is applied before (a process that falls behind compresses the records into
the steps it actually ran, keeping a slot's samples' spacing:
:meth:`LiveCore._compressed`).  That slot *is* the step index: a replay applies
each record after exactly ``floor((t + waited)·rate)`` steps, as this process
did.  On exit a ``wait {"seconds": 0}`` marks the session time of the last
step.  So ``station paint`` of the log, or a recovery from any autosave, gives
the same pixels on the same backend.

Devices.  A device whose publisher sends heartbeats (``hb.<device>``) and then
stops for :data:`SILENCE_INTERVALS` intervals is *silent*: the status names it
at once, and a stroke in progress is ended with a synthesised pen-up (counted
in ``synthetic_pen_ups`` and logged, so replays agree).

Bad messages: the bus drops undecodable ones (counted in ``bus.malformed``);
a command the player rejects (unknown pigment, bad numbers) is counted in
``bad_commands``, a pen sample it refuses (a ninth pigment in the layer) in
``bad_samples``, stamps the canvas refuses in ``dropped_sources``; each is
warned about once and not logged.  The process never crashes on input.
"""

from __future__ import annotations

import json
import logging
import math
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from station.answer import Answerer, ReplyRequest, parse_request
from station.backends.factory import create_distributed, make_backend
from station.backends.protocol import CanvasBackend
from station.bus import runtime_dir
from station.canvas.palette import default_palette
from station.canvas.state import CanvasState
from station.durable import atomic_write
from station.errors import BadInput
from station.events import Command, PenSample
from station.sessionlog import SessionHeader
from station.sim import live_checkpoint, recovery
from station.sim.haptic import HapticFeedback
from station.sim.journal import (
    SessionJournal,
    StorageReport,
    autosave_path,
    default_log_path,
    free_path,
    record_line,
)
from station.sim.live_config import DEFAULT_CMD_ENDPOINT as DEFAULT_CMD_ENDPOINT
from station.sim.live_config import (
    FLOOD_BURST,
    FLOOD_RATE,
    MAX_DEVICES,
    MAX_WARNINGS,
    RESYNC_S,
    DeviceState,
    StepHooks,
)
from station.sim.live_config import KIOSK_CMD_ENDPOINT as KIOSK_CMD_ENDPOINT
from station.sim.live_config import SYNC_EVERY_S as SYNC_EVERY_S
from station.sim.live_config import Counters as Counters
from station.sim.live_config import LiveConfig as LiveConfig
from station.sim.live_config import default_status_endpoint as default_status_endpoint
from station.sim.paint import write_image
from station.sim.player import SessionPlayer, check_sent_command
from station.sim.undo import UndoHistory
from station.wire import HapticForce, Heartbeat

log = logging.getLogger(__name__)

class LiveCore:
    """The live simulation without a bus (see the module docstring)."""

    process_kind = "sim"  # what answers to `station send` call this process

    def __init__(self, cfg: LiveConfig) -> None:
        self.cfg = cfg
        self.report = StorageReport()
        self.counters = Counters()
        self.devices: dict[str, DeviceState] = {}
        self._warned: set[str] = set()
        self.answerer = Answerer(self.process_kind)
        self._buckets: dict[str, list[float]] = {}  # device -> [tokens, last refill]
        self.flood_rate, self.flood_burst = FLOOD_RATE, FLOOD_BURST
        self._flood_logged = -math.inf
        self._last_t = 0.0
        self._offsets: dict[str, float] = {}
        # when the last step began (session time) and the wall seconds a step's slot
        # has lately taken: a process behind its rate spreads a slot's samples over it
        # (:meth:`_compressed`)
        self._step_began: float | None = None
        self._slot_wall = 0.0
        # a host's seams (station.kiosk.session): records a step ahead while its kernel
        # runs, and what to do around every step (its display's dirty tiles)
        self.slot_ahead: Callable[[], bool] | None = None
        self.step_hooks: StepHooks | None = None
        plan = recovery.plan(cfg.recover) if cfg.recover else None
        start = None
        if plan is not None:
            h = plan.header
            cfg.width, cfg.height, cfg.profile, cfg.seed = h.width, h.height, h.profile, h.seed
            cfg.rate = plan.rate
            start = plan.state
        elif cfg.resume:
            start = CanvasState.load(cfg.resume)
            cfg.width, cfg.height = start.width, start.height
            cfg.profile, cfg.seed = start.profile, start.seed
        self.canvas: CanvasBackend
        if cfg.distributed:  # this is rank 0; the others follow (backends.distributed.relay)
            # in the function: mpi4py is the optional ``mpi`` extra
            from station.backends.distributed.relay import Leader

            dist, self.backend_name = create_distributed(cfg.backend, cfg.width, cfg.height,
                                                       cfg.profile, cfg.seed)
            self.canvas = Leader(dist)
        else:
            self.canvas, self.backend_name = make_backend(cfg.backend, cfg.width, cfg.height,
                                                          cfg.profile, cfg.seed,
                                                          **cfg.backend_opts)
        if start is not None:
            self.canvas.load_state(start)
        session = plan.session if plan is not None else None
        profile = session["player"]["profile"] if session else (
            start.profile if start is not None else cfg.profile)
        self.player = SessionPlayer(self.canvas, cfg.width, cfg.height, profile,
                                    rate=cfg.rate, pigments=default_palette())
        # undo/redo of strokes (the kiosk's button, the undo/redo commands); it reaches
        # back to the strokes made since this process started or recovered
        self.history = UndoHistory(self.player)
        # the deformable brush's reaction for haptic devices (station.sim.haptic)
        self.haptics = HapticFeedback(self.publish_haptic)
        if session:
            self._restore(session)
        elif start is not None:
            self.player.layer_pigments.update(start.slots)

        if plan is not None:
            self.log_path = plan.log_path
            self.header_line = plan.header_line
            self.journal = SessionJournal(self.log_path, None, self.report,
                                          records=plan.records_total)
        else:
            if cfg.log_path:
                wanted = Path(cfg.log_path)
                self.log_path = free_path(wanted)
                if self.log_path != wanted:
                    log.warning("%s exists and is kept; this session logs to %s "
                                "(continue the old one with --recover)", wanted, self.log_path)
            else:
                self.log_path = default_log_path()
            header = SessionHeader(
                width=cfg.width, height=cfg.height, profile=cfg.profile, seed=cfg.seed,
                extra={"sim": {"rate": self.player.rate}, "recorded_by": "station sim",
                       **({"resumed_from": str(Path(cfg.resume).resolve())}
                          if cfg.resume else {})})
            self.header_line = record_line(header).decode().rstrip("\n")
            self.journal = SessionJournal(self.log_path, header, self.report)
        self.autosave_path = autosave_path(self.log_path)
        self.start = time.monotonic()
        if plan is not None:
            self._replay(plan)
        elif cfg.brush:  # --brush: the first command of a new session (a recovery has it)
            self.player.command(Command(t=0.0, cmd="brush", args=cfg.brush))
            self.journal.write(Command(t=0.0, cmd="brush", args=cfg.brush))
        self.journal.flush()
        self._next_autosave = time.monotonic() + (cfg.autosave or math.inf)
        self._save_requested = False
        self.stop_requested = False
        self.newly_silent: list[str] = []  # fell silent since the caller last looked

    # -- seams for a host that runs this simulation inside its own loop (the kiosk) --
    def records_in_next_step(self) -> bool:
        """Whether a record applied now belongs to the step after the one about to run
        (a host that applies samples while a step's kernel runs says so; see
        :meth:`_in_this_step`).  ``False`` here: records land in the step about to run."""
        return self.slot_ahead is not None and self.slot_ahead()

    # -- clock ---------------------------------------------------------------
    def now(self) -> float:
        """Session time: seconds since start (after a recovery: since the log's start,
        the time the process was down left out)."""
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
        k = p.counters.steps + (1 if self.records_in_next_step() else 0)
        lo = math.ceil((k / p.rate - p.waited) * 1e6) / 1e6
        hi = math.floor(((k + 1) / p.rate - p.waited - 2e-6) * 1e6) / 1e6
        # The previous record lies in this slot or an earlier one, so it bounds t from
        # below even where ``hi``'s float floor comes out a µs short of it (after a
        # wait whose end falls just before a step boundary: 0.6 - 0.5 - 2e-6 floors
        # to 0.099997); a replay puts that µs in the same step (floor with 1e-9 slack).
        t = max(round(min(max(t, lo, self._last_t), max(hi, lo)), 6), self._last_t)
        self._last_t = t
        return t

    def _compressed(self, t: float) -> float:
        """A sample's session time ``t`` (its device's clock), for a process behind
        its rate: the samples that arrive while a step runs belong to the next step's
        slot, but their device times span the step's wall time, longer than the slot.
        Clamped into it they would all take its end, so every stamp of the step would
        land at once (the arcs of issue 21 item 8, a dry brush's speed unknown);
        scaled by the slot's length over the wall time a slot lately takes, they keep
        their spacing in the slot. A process that keeps up (``t`` inside the slot) is
        left as it was, so its log does not change."""
        p = self.player
        k = p.counters.steps + (1 if self.records_in_next_step() else 0)
        slot = 1.0 / p.rate
        if self._step_began is None or t < (k + 1) * slot - p.waited:
            return t
        wall = max(slot, self._slot_wall)
        return k * slot - p.waited + (t - self._step_began) * slot / wall

    def _stamp_sample(self, s: PenSample, now: float) -> PenSample:
        off = self._offsets.get(s.device)
        if off is None or abs(s.t + off - now) > RESYNC_S:
            off = self._offsets[s.device] = now - s.t
        return s.with_(t=self._in_this_step(self._compressed(min(now, s.t + off))),
                       t_mono=0.0)

    # -- input -----------------------------------------------------------------
    def handle(self, kind: str, value: object, topic: str = "", replay: bool = False) -> None:
        """One bus message (``Message.kind``/``value``/``topic``/``replay``)."""
        if kind == "pen" and isinstance(value, PenSample):
            if self._admit(value.device):
                self.feed_sample(value, replay=replay)
        elif kind == "cmd" and isinstance(value, Command):
            self.feed_command(value)
        elif kind == "heartbeat" and isinstance(value, Heartbeat):
            name = topic.partition(".")[2]
            if name in self.devices or len(self.devices) < MAX_DEVICES:
                self._seen(name, value.interval_s)

    def _admit(self, device: str) -> bool:
        """The flood gate: a token bucket per device (see :data:`FLOOD_RATE`)."""
        now = time.monotonic()
        bucket = self._buckets.get(device)
        if bucket is None:
            if len(self._buckets) >= MAX_DEVICES:
                return self._flooded(f"more than {MAX_DEVICES} devices on the bus")
            bucket = self._buckets[device] = [self.flood_burst, now]
        bucket[0] = min(self.flood_burst, bucket[0] + (now - bucket[1]) * self.flood_rate)
        bucket[1] = now
        if bucket[0] < 1.0:
            return self._flooded(f"device {device[:40]} sends more than "
                                 f"{self.flood_rate:g} samples/s")
        bucket[0] -= 1.0
        return True

    def _flooded(self, why: str) -> bool:
        self.counters.flood_dropped += 1
        now = time.monotonic()
        if now >= self._flood_logged + 10.0:  # one line per 10 s, with the count
            self._flood_logged = now
            log.warning("bus flood: %s; dropping (%d dropped so far)", why,
                        self.counters.flood_dropped)
        return False

    def _seen(self, device: str, heartbeat_s: float | None = None) -> DeviceState:
        dev = self.devices.get(device)
        if dev is None:
            dev = self.devices[device] = DeviceState(last_seen=time.monotonic())
        dev.last_seen = time.monotonic()
        if heartbeat_s is not None:
            dev.heartbeat_s = heartbeat_s
        if dev.silent:
            dev.silent = False
            log.warning("device %s is back", device)
        return dev

    def feed_sample(self, sample: PenSample, replay: bool = False) -> bool:
        """Apply a pen sample now; ``False`` if it was not painted (counted)."""
        dev = self._seen(sample.device)
        if dev.resume_seq is not None and sample.seq:
            # First samples after a recovery: the publisher re-sends the current
            # proximity period to us, a late joiner; drop what the log already has.
            if replay and sample.seq <= dev.resume_seq:
                self.counters.recovered_duplicates += 1
                return False
            if sample.seq > dev.resume_seq + 1:
                self.counters.missed_while_down += sample.seq - dev.resume_seq - 1
            dev.resume_seq = None
        return self._apply_sample(self._stamp_sample(sample, self.now()), dev)

    def _apply_sample(self, rec: PenSample, dev: DeviceState, synthetic: bool = False
                      ) -> bool:
        try:
            self.player.apply(rec)
        except BadInput as exc:  # e.g. a ninth pigment in the layer: not painted
            self.counters.bad_samples += 1
            self._warn(f"sample not painted: {exc}")
            return False
        if synthetic:
            self.counters.synthetic_pen_ups += 1
        else:
            self.counters.samples += 1
        dev.touching = rec.touching and rec.proximity
        dev.last_sample = rec
        self.journal.write(rec)
        if not synthetic:
            self.haptics.on_sample(self.player.brush, rec, self.now())
        return True

    def feed_command(self, command: Command) -> bool:
        """Apply a command now; ``False`` if it was rejected (counted).  A command
        that asks for an answer (``station send``, see :mod:`station.answer`) gets one,
        and is held to stricter rules: a key its command does not read and a command
        meant for another kind of process are refused, not ignored."""
        req = parse_request(command.reply, runtime_dir()) if command.reply else None
        if req is not None:
            why = self._refusal(command, req)
            if why is not None:
                self.counters.bad_commands += 1
                self._warn(f"rejected command {command.cmd!r}: {why}")
                self._answer(req, command.cmd, False, why)
                return False
        cmd = Command(t=self._in_this_step(self.now()), cmd=command.cmd, args=command.args)
        if cmd.cmd == "stop":
            self.stop_requested = True
            self._answer(req, cmd.cmd, True, "stopping (the log and outputs are written "
                         "on the way out)")
            return True
        if cmd.cmd == "save":
            self._save_requested = True
            self.write_outputs()
            self._answer(req, cmd.cmd, True, "saved " + ", ".join(
                str(p) for p in (self.cfg.png_path, self.cfg.state_path) if p) or
                "saved (this process writes no picture or state file)")
            return True
        try:
            self.player.command(cmd)
        except BadInput as exc:
            self.counters.bad_commands += 1
            self._warn(f"rejected command {cmd.cmd!r}: {exc}")
            self._answer(req, cmd.cmd, False, str(exc))
            return False
        self.counters.commands += 1
        self.journal.write(cmd)
        did = (self.history.last if cmd.cmd in ("undo", "redo") and self.history.last
               else _did(cmd))  # an undo that found nothing says why (the history's cap)
        self._answer(req, cmd.cmd, True, f"{did} at session time {cmd.t:.2f} s "
                     f"(step {self.player.counters.steps})")
        if cmd.cmd == "wait":  # its painting time runs now, as in a replay
            while (self.player.counters.steps < self.player.steps_due(cmd.t)
                   and not self.stop_requested):  # SIGTERM cuts a long wait short
                self.step()
                self.on_wait_step()
        return True

    def _refusal(self, command: Command, req: ReplyRequest) -> str | None:
        """Why an answered command is refused before it runs, or ``None``."""
        if req.expect is not None and req.expect != self.process_kind:
            return (f"this is a {self.process_kind}, not a {req.expect} (send it with "
                    f"--to {self.process_kind}, or to the {req.expect}'s own endpoint)")
        try:
            check_sent_command(command, self.player.pigments)
        except BadInput as exc:
            return str(exc)
        return None

    def _answer(self, req: ReplyRequest | None, cmd: str, ok: bool, text: str) -> None:
        if req is not None:
            self.answerer.answer(req, cmd, ok, text, self.log_path.stem)

    def answer(self, req: ReplyRequest | None, cmd: str, ok: bool, text: str) -> None:
        """Answer a ``station send`` for a process that holds this sim (the kiosk)."""
        self._answer(req, cmd, ok, text)

    def answer_as(self, kind: str) -> None:
        """Answer ``station send`` as ``kind`` (a kiosk holding this sim)."""
        self.process_kind = kind
        self.answerer = Answerer(kind)

    def on_wait_step(self) -> None:
        """Called between the steps of a long ``wait`` (LiveSim publishes status)."""

    def _warn(self, text: str) -> None:
        """Warn once per distinct message (a bad stroke must not flood the log)."""
        if text not in self._warned:
            if len(self._warned) >= MAX_WARNINGS:
                self.counters.warnings_suppressed += 1
                return
            self._warned.add(text)
            log.warning("%s", text)

    # -- steps ---------------------------------------------------------------------
    def step(self) -> None:
        """One step; stamps the canvas refuses are dropped (counted), the step runs.

        Everything applied before it is handed to the kernel first: what is
        painted is in the log.
        """
        began = self.now()
        if self._step_began is not None:  # the samples from now on are the next slot's
            # a gap of more than a second (a host that paused its steps) says nothing of
            # what a step costs: it would squeeze the next slots' samples to their start
            lately = min(began - self._step_began, 1.0)
            self._slot_wall = lately if self._slot_wall == 0.0 else (
                0.5 * (self._slot_wall + lately))
        self._step_began = began
        hooks = self.step_hooks
        if hooks is not None:
            hooks.before_step()
        self.journal.flush()
        p = self.player
        take = p.take_step()

        def canvas_part() -> None:
            p.apply_step(take, self._sources_refused)

        if hooks is not None:
            hooks.run_step(canvas_part)
        else:
            canvas_part()
        p.end_step()
        if hooks is not None:
            hooks.after_step()

    def _sources_refused(self, exc: BadInput) -> None:
        self.counters.dropped_sources += 1
        self._warn(f"brush sources dropped: {exc}")

    def publish_haptic(self, device: str, force: HapticForce) -> None:
        """Send a reaction frame to ``haptic.<device>`` (no bus here: dropped)."""

    def steps_due(self) -> int:
        return self.player.steps_due(self.now()) - self.player.counters.steps

    def seconds_to_next_step(self) -> float:
        p = self.player
        return (p.counters.steps + 1) / p.rate - p.waited - self.now()

    def tick(self) -> bool:
        """Run at most one due step, then housekeeping; ``True`` if a step ran."""
        ran = False
        if self.steps_due() > 0:
            self.step()
            ran = True
            self.maybe_autosave()
        self.journal.maybe_sync(SYNC_EVERY_S)
        self.check_devices()
        return ran

    # -- devices -----------------------------------------------------------------
    def heard_until(self) -> float:
        """Monotonic time up to which every message sent to this process has been read
        (no bus here: now)."""
        return time.monotonic()

    def check_devices(self) -> list[str]:
        """Mark devices silent after their heartbeats stop; end their strokes.
        Returns the devices that fell silent now.  Silence is judged up to the time the
        bus was last read empty, not the clock: a process that stalled (a loaded machine,
        a long step) with a device's samples still queued would otherwise end a stroke
        the painter never lifted."""
        now = self.heard_until()
        fell: list[str] = []
        for name, dev in self.devices.items():
            timeout = dev.timeout()
            if dev.silent or timeout is None or now - dev.last_seen <= timeout:
                continue
            dev.silent = True
            fell.append(name)
            self.newly_silent.append(name)
            log.warning("device %s is silent (no message for %.1f s)", name,
                        now - dev.last_seen)
            if dev.touching and dev.last_sample is not None:
                up = dev.last_sample.with_(t=self._in_this_step(self.now()), touching=False,
                                           proximity=False, pressure=0.0, buttons=0, seq=0)
                self._apply_sample(up, dev, synthetic=True)
        return fell

    def silent_devices(self) -> list[str]:
        return sorted(n for n, d in self.devices.items() if d.silent)

    # -- autosave ------------------------------------------------------------------
    def maybe_autosave(self) -> None:
        """Autosave when due (or asked for by ``save``), between strokes only: then
        no stroke state is pending and the state plus the log is the whole truth."""
        if self.autosave_due():
            self.autosave()

    def autosave_due(self) -> bool:
        """Whether :meth:`maybe_autosave` would save now."""
        due = self._save_requested or (self.cfg.autosave
                                       and time.monotonic() >= self._next_autosave)
        return bool(due) and not self.player.brush.drawing and not self.player.brush.pending

    def autosave(self) -> bool:
        """Write the checkpoint now; ``False`` (reported) if storage refuses."""
        job = self.begin_autosave()
        return job is not None and job()

    def begin_autosave(self, state: CanvasState | None = None) -> Callable[[], bool] | None:
        """The part of an autosave that must see the session as it is: the log synced,
        the session's data and the canvas (``state``: one the host guarantees to
        hold still, shared rather than copied; else a copy).  Returns the rest, the
        compression and the write (seconds for a 1920×1080 canvas), which a host may
        run without its lock; ``None`` if storage refused the log's sync."""
        self._next_autosave = time.monotonic() + (self.cfg.autosave or math.inf)
        self._save_requested = False
        if not self.journal.sync():  # the checkpoint may only count records on disk
            return None
        st = self.canvas.state() if state is None else state
        session = self.checkpoint_session()

        def write() -> bool:
            data = st.npz_bytes(extra={"session": session}, quick=True)
            try:
                # the painting is private like its log (0600)
                atomic_write(self.autosave_path, data, mode=0o600)
            except OSError as exc:
                self.report.failed(f"autosave {self.autosave_path}", exc)
                return False
            self.report.recovered(f"autosave {self.autosave_path}")
            self.counters.autosaves += 1
            return True

        return write

    def checkpoint_session(self) -> dict[str, Any]:
        """What an autosave keeps besides the canvas (:func:`live_checkpoint.session`)."""
        return live_checkpoint.session(self)

    def _restore(self, s: dict[str, Any]) -> None:
        live_checkpoint.restore(self, s)

    def _replay(self, plan: recovery.Plan) -> None:
        live_checkpoint.replay(self, plan)

    def status(self) -> dict[str, Any]:
        p, c = self.player, self.counters
        now = time.monotonic()
        session = self.now()
        return {
            "width": self.cfg.width, "height": self.cfg.height, "profile": p.profile,
            "backend": self.backend_name, "renderer": str(getattr(self.canvas, "renderer", "")),
            "steps": p.counters.steps, "sim_time": p.counters.steps * p.dt,
            "painting_time": p.painting_time, "session_time": session,
            "lag_s": max(0.0, session + p.waited - p.painting_time),
            "rate": p.rate,
            "samples": c.samples, "commands": c.commands,
            "bad_commands": c.bad_commands, "bad_samples": c.bad_samples,
            "dropped_sources": c.dropped_sources, "synthetic_pen_ups": c.synthetic_pen_ups,
            "recovered_duplicates": c.recovered_duplicates, "flood_dropped": c.flood_dropped,
            "missed_while_down": c.missed_while_down, "unread_at_stop": c.unread_at_stop,
            "stamps": p.brush.stamps, "eraser_samples": p.brush.eraser_samples,
            "devices": {n: {"state": "silent" if d.silent else "live",
                            "last_seen_s": round(now - d.last_seen, 3),
                            "heartbeat_s": d.heartbeat_s, "touching": d.touching}
                        for n, d in sorted(self.devices.items())},
            "silent_devices": self.silent_devices(),
            "log": str(self.log_path), "log_records": self.journal.records,
            "log_pending_bytes": self.journal.pending_bytes,
            "log_dropped": self.journal.dropped,
            "autosave": str(self.autosave_path), "autosaves": c.autosaves,
            "storage_failures": self.report.failures,
            "storage_problems": dict(self.report.problems),
            "undo": self.history.status(),
            **p.brush_counters(),
        }

    # -- end -----------------------------------------------------------------------
    def write_outputs(self) -> None:
        """Write ``--state`` and ``--png`` now (atomically; failures reported)."""
        if self.cfg.state_path:
            try:
                self.canvas.state().save(self.cfg.state_path)
            except OSError as exc:
                self.report.failed(f"state {self.cfg.state_path}", exc)
        if self.cfg.png_path:
            png = Path(self.cfg.png_path)
            tmp = png.with_name(f".{png.name}.tmp-{os.getpid()}")
            try:  # all or nothing, like the state: a full disk keeps the old image
                write_image(str(tmp), self.canvas.render())
                os.replace(tmp, png)
            except OSError as exc:
                tmp.unlink(missing_ok=True)
                self.report.failed(f"image {self.cfg.png_path}", exc)

    def finish(self) -> None:
        """Hand pending stamps to the canvas, write the end marker, the outputs and
        a last autosave, close the log."""
        p = self.player
        try:
            p.flush_sources(whole=True)
        except BadInput as exc:
            self.counters.dropped_sources += 1
            self._warn(f"brush sources dropped: {exc}")
        # End marker: a no-op wait at the session time the last step belongs to, so
        # a replay of the log runs as many steps as this process did.
        # (rounded up to the µs, so it does not fall just short of the step's end)
        t_end = max(self._last_t, p.counters.steps / p.rate - p.waited)
        t_end = math.ceil(t_end * 1e6) / 1e6
        self._last_t = t_end
        self.journal.write(Command(t=t_end, cmd="wait", args={"seconds": 0.0}))
        if self.cfg.distributed:
            # the log is whole before the canvas is gathered: that needs every rank alive
            self.journal.flush()
        self.write_outputs()
        if self.cfg.autosave and not p.brush.drawing:
            self.autosave()
        self.journal.close()
        if self.cfg.distributed and hasattr(self.canvas, "close"):
            self.canvas.close()  # the follower ranks return


def _did(cmd: Command) -> str:
    """A command in words, for its answer: ``brush set (size 12, water 0.8)``."""
    if not cmd.args:
        return f"{cmd.cmd} done"
    parts = ", ".join(f"{k} {json.dumps(v)}" for k, v in sorted(cmd.args.items()))
    return f"{cmd.cmd} set ({parts[:200]})"
