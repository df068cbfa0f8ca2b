"""The session player: pen samples and commands → round brush → canvas backend.

The simulation runs at a fixed rate decoupled from the input rate: ``rate``
steps per second of *painting time*, each step ``dt`` of simulation time (the
profile's ``params.dt``).  Painting time is the session clock plus every
``wait`` so far: a ``wait {"seconds": s}`` inserts ``s`` seconds of painting
time at that point (``round(s·rate)`` extra steps) without the script having
to leave a gap in its timestamps.

Before a record with session time ``t`` is applied, the player runs every step
whose end lies at or before ``t + waited`` (step ``k`` ends at ``(k+1)/rate``),
so what a record does lands in the step that follows it.  The brush stamps
collected between two steps go into the backend as one ``add_sources`` call
just before the step.  Everything is a pure function of the records and the
backend: the same log on the same backend gives the same pixels.

Commands: ``brush`` (validated against the palette), ``profile``, ``wait``,
``dry``, ``new_layer``, ``clear``.  Known tools that are not implemented yet
(``tissue``, ``eraser``, ``mask``, ``diffusion``, ``palette``, ``stop``) and
unknown commands are warned about once per name and skipped (counted in
:attr:`PlayerCounters.skipped_commands`).  Bad arguments to a command this
player executes raise :class:`~station.errors.BadInput`; :meth:`SessionPlayer.play`
stops there, so the caller can still save what was painted.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable, Container, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from station.arttools import diffusion as diffusion_tool
from station.arttools import eraser as eraser_tool
from station.arttools import mask as mask_tool
from station.arttools import tissue as tissue_tool
from station.arttools import well as well_tool
from station.backends.numpy_canvas import NumpyCanvas
from station.backends.protocol import CanvasBackend, edit_state
from station.brush.deformable import DeformableBrush
from station.brush.reservoir import pickup
from station.brush.solver import SolverCounters
from station.brush.sources import Sources
from station.brush.stamp import STAMP_KIND, BrushModel, BrushSettings, RoundBrush
from station.canvas.paper import make_paper
from station.canvas.params import Profile
from station.canvas.profiles import get_profile, profile_names
from station.canvas.removal import HairDryer, StateSurface, blow
from station.canvas.state import DEFAULT_SLOTS, CanvasState
from station.errors import BadInput
from station.events import Command, PenSample, Tool
from station.sim.undo import UndoHistory

log = logging.getLogger(__name__)

MAX_WAIT_SECONDS = 3600.0
MAX_PAINTING_SECONDS = 86400.0
"""Longest painting time a replayed session may reach (session time + waits +
``--settle``): one day.  A record past it (``t`` = 1e12 would mean simulating
for millennia) is refused as bad input instead of running "forever"."""
MAX_RATE = 1000.0
"""Most simulation steps per second of painting time a replay may ask for."""


class PlayerError(BadInput):
    """A command the player executes has wrong arguments."""


@dataclass
class PlayerCounters:
    """What the player did; every number counts records, stamps or steps."""

    steps: int = 0
    samples: int = 0
    commands: dict[str, int] = field(default_factory=dict)
    skipped_commands: dict[str, int] = field(default_factory=dict)
    waited_s: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        return {"steps": self.steps, "samples": self.samples, "commands": dict(self.commands),
                "skipped_commands": dict(self.skipped_commands), "waited_s": self.waited_s}


class SessionPlayer:
    """Plays pen samples and commands into a canvas backend.

    Args:
        backend: a canvas backend (``station.backends.factory`` protocol), already
            set to ``profile``.
        width, height: canvas size in cells.
        profile: the starting paint profile (brush model, defaults and ``dt``).
        rate: simulation steps per second of painting time; default ``1/dt``
            (painting time then equals simulated time).
        pigments: names a ``brush`` command may use (the palette; any
            container with ``in``); ``None`` leaves the check to the backend.
        brush_scale: factor applied to every brush size (the canvas was
            resized from the size the session was made for).
    """

    def __init__(
        self,
        backend: CanvasBackend,
        width: int,
        height: int,
        profile: str = "watercolor",
        rate: float | None = None,
        pigments: Container[str] | None = None,
        brush_scale: float = 1.0,
    ) -> None:
        prof = get_profile(profile)
        self.dt = prof.params.dt
        rate = 1.0 / self.dt if rate is None else rate
        if not (isinstance(rate, (int, float)) and math.isfinite(rate) and rate > 0):
            raise BadInput(f"simulation rate {rate!r} must be a positive number of steps/s")
        self.backend = backend
        self._grain_h: Any = None  # the paper height, read once (see _grain)
        self.rate = float(rate)
        self.pigments = pigments
        self.brush_scale = brush_scale
        self.profile = prof.name
        self.width, self.height = width, height
        self.brush: RoundBrush | DeformableBrush = RoundBrush(
            width, height, brush_defaults(prof).scaled(brush_scale), brush_model(prof),
            time_scale=self.rate * self.dt, paper=self._grain())
        self.pickups_skipped = 0  # pick-ups on a backend whose arrays are not in memory
        self.solver = SolverCounters()  # the deformable brushes' spine solves, all kinds
        self.counters = PlayerCounters()
        # Pigments painted into the active layer, to refuse a ninth one at the pen
        # sample that would bring it (the canvas would only notice at the next step).
        self.layer_pigments: set[str] = set()
        self.n_slots = int(getattr(backend, "n_slots", None) or DEFAULT_SLOTS)
        self.dryer: HairDryer | None = None  # the hair dryer while it blows
        self.dryer_until = 0  # step count at which it stops
        self.width, self.height = width, height
        self.waited = 0.0  # painting seconds inserted by wait commands
        self.last_t = 0.0  # session time of the last record applied
        self._warned: set[str] = set()
        # the tool in the painter's hand instead of the brush (None: the brush)
        self.tool: str | None = None
        self.controller: diffusion_tool.Controller | None = None  # the brush writes it
        self._controller_field: np.ndarray | None = None
        self._controller_count = 0
        self.history: UndoHistory | None = None  # when undo is wanted
        self.well: well_tool.MixingWell | None = None  # the palette's mixing well
        self.tilt = (0.0, 90.0)  # canvas tilt (angle, direction) [deg]; kept across profiles
        self.mask_radius = 6.0
        self.eraser = eraser_tool.Eraser()
        self.tissue = tissue_tool.Tissue()
        self._tissue_tex: np.ndarray | None = None
        self._dab: np.ndarray | None = None  # cells the previous dab / this press hit
        self._tool_last: tuple[float, float] | None = None  # the tool's last dab [cells]

    # -- time ------------------------------------------------------------------
    @property
    def painting_time(self) -> float:
        """Painting seconds simulated so far (steps / rate)."""
        return self.counters.steps / self.rate

    def steps_due(self, t: float) -> int:
        """Steps that must have run before a record at session time ``t``."""
        return int(math.floor((t + self.waited) * self.rate + 1e-9))

    def step(self) -> None:
        """One simulation step with the brush sources due before it (each stamp is
        spread over the two steps around its time: :mod:`station.brush.sources`)."""
        self.flush_sources()
        dryer = self.dryer
        if dryer is not None:
            if self.counters.steps < self.dryer_until:
                edit_state(self.backend, lambda st: blow(st, dryer, self.dt))
            else:
                self.dryer = None
        self.backend.step()
        self.counters.steps += 1

    def advance_to(self, t: float, on_step: Callable[[SessionPlayer], None] | None = None) -> None:
        """Run the steps due at session time ``t``."""
        due = self.steps_due(t)
        while self.counters.steps < due:
            self.step()
            if on_step is not None:
                on_step(self)

    def flush_sources(self, whole: bool = False) -> None:
        """Hand the pending brush stamps to the backend (no step): all of them
        (``whole``: before a command that needs the canvas as painted, at the end), or
        the part due before the step about to run (a step, a live preview between steps).

        A deformable brush first lifts wet paint under its footprints (dirty
        brush) from the canvas arrays, where the backend keeps them in memory
        (``live_state``); a GPU backend's pick-ups are counted and skipped.
        """
        if isinstance(self.brush, DeformableBrush):
            requests = self.brush.take_pickups()
            state = getattr(self.backend, "live_state", None)
            if requests and state is None:
                self.pickups_skipped += len(requests)
            elif requests and state is not None:
                for r in requests:
                    pickup(StateSurface(state), self.brush.reservoir, r.weight, r.y0, r.x0,
                           self.brush.shape.pickup)
        src = self.brush.take(None if whole else self.counters.steps)
        if src is not None:
            add_sources(self.backend, src)

    # -- records -----------------------------------------------------------------
    def apply(self, record: PenSample | Command, where: str | None = None) -> None:
        """Apply one record now (no time advance: see :meth:`play`)."""
        self.last_t = max(self.last_t, record.t)
        if isinstance(record, PenSample):
            if self.history is not None:
                self.history.before(record)
            self.counters.samples += 1
            tool = "eraser" if record.tool is Tool.ERASER else self.tool
            if tool is not None:
                self._tool_sample(tool, record, where)
                if record.tool is not Tool.ERASER:  # the brush sees the pen hovering
                    record = dataclasses.replace(record, touching=False, pressure=0.0)
            elif record.touching:
                self._check_layer(where)
                if self.controller is not None:
                    self._write_controller(record)
            self.brush.clock = (self.rate, self.waited)
            self.brush.feed(record)
        else:
            self.command(record, where)

    def _write_controller(self, rec: PenSample) -> None:
        """Every ``interval``-th touching brush sample writes the controller's pattern under
        the brush (its radius at full size)."""
        ctrl = self.controller
        if ctrl is None:
            return
        self._controller_count += 1
        if (self._controller_count - 1) % ctrl.interval:
            return
        if self._controller_field is None:
            self._controller_field = ctrl.field(self.height, self.width)
        field = self._controller_field
        cx, cy = rec.x * self.width, rec.y * self.height
        radius = max(self.brush.settings.size / 2.0, 0.5)
        edit_state(self.backend, lambda st: diffusion_tool.write(st, field, ctrl.strength, cx, cy,
                                                               radius))

    def _tool_sample(self, tool: str, rec: PenSample, where: str | None) -> None:
        """A pen sample with a tool in hand: a dab where the pen touches, the press ends
        (and with it the cells marked as hit) where it lifts."""
        if not rec.touching:
            self._dab = None
            self._tool_last = None
            return
        self.flush_sources(whole=True)  # what the brush painted before comes first
        cx, cy = rec.x * self.width, rec.y * self.height
        # dabs every third of the tool's radius between two samples, as the brush stamps
        radius = {"mask": self.mask_radius, "eraser": self.eraser.radius}.get(
            tool, self.tissue.radius)
        points = [(cx, cy)]
        last = self._tool_last
        if last is not None and tool != "tissue":  # a tissue is pressed, not dragged
            n = int(math.hypot(cx - last[0], cy - last[1]) / max(radius / 3.0, 0.5))
            points = [(last[0] + (cx - last[0]) * k / (n + 1),
                       last[1] + (cy - last[1]) * k / (n + 1)) for k in range(1, n + 2)]
        self._tool_last = (cx, cy)
        try:
            for x, y in points:
                self._dab_at(tool, x, y, rec.pressure)
        except BadInput as exc:
            raise PlayerError(str(exc), where) from None

    def _dab_at(self, tool: str, cx: float, cy: float, pressure: float) -> None:
        prev = self._dab
        if tool == "mask":
            edit_state(self.backend, lambda st: mask_tool.paint(st, cx, cy, self.mask_radius))
        elif tool == "eraser":
            self._dab = edit_state(self.backend, lambda st: eraser_tool.erase(
                st, self.eraser, cx, cy, pressure, prev))
        else:  # tissue
            if self._tissue_tex is None:
                t = self.tissue
                self._tissue_tex = tissue_tool.texture(t.kind, self.height, self.width,
                                                       t.scale, t.seed, t.image)
            tex = self._tissue_tex
            self._dab = edit_state(self.backend, lambda st: tissue_tool.blot(
                st, self.tissue, tex, cx, cy, pressure, prev))[1]

    def _check_layer(self, where: str | None) -> None:
        names = [k for k, a in self.brush.settings.pigment.items() if a > 0.0]
        if isinstance(self.brush, DeformableBrush):  # a dirty brush carries what it picked up
            names += [k for k, m in self.brush.reservoir.mass.items()
                      if m > 0.0 and k not in names]
        new = [k for k in names if k not in self.layer_pigments]
        if not new:
            return
        if len(self.layer_pigments) + len(new) > self.n_slots:
            held = ", ".join(sorted(self.layer_pigments))
            raise PlayerError(
                f"the active layer already holds {len(self.layer_pigments)} of {self.n_slots} "
                f"pigments ({held}); start a new layer to paint with {', '.join(new)}", where)
        self.layer_pigments.update(new)

    def command(self, cmd: Command, where: str | None = None) -> None:
        name = cmd.cmd
        if self.history is not None and name in _HANDLERS:
            self.history.before(cmd)
        handler = _HANDLERS.get(name)
        if handler is None:
            self.counters.skipped_commands[name] = self.counters.skipped_commands.get(name, 0) + 1
            if name not in self._warned:
                self._warned.add(name)
                what = "not implemented yet" if cmd.known else "unknown"
                log.warning("%scommand %r is %s: skipped", f"{where}: " if where else "", name,
                            what)
            return
        handler(self, cmd.args, where)
        self.counters.commands[name] = self.counters.commands.get(name, 0) + 1

    def _brush(self, args: Mapping[str, object], where: str | None) -> None:
        self.tool = None  # the brush back in hand
        base = self.brush.settings
        unscaled = BrushSettings(base.kind, base.size / self.brush_scale, base.water,
                                 base.pigment)
        settings = BrushSettings.from_args(args, where, self.pigments, unscaled)
        canonical = getattr(self.pigments, "get", None)
        if canonical is not None:  # the palette: use its spelling of each name
            settings = BrushSettings(settings.kind, settings.size, settings.water,
                                     {canonical(k).name: v for k, v in settings.pigment.items()})
        self._use(settings.scaled(self.brush_scale))

    def _use(self, settings: BrushSettings) -> None:
        """Set the brush, swapping the stamp brush and a deformable one as the kind asks."""
        deformable = settings.kind != STAMP_KIND
        if deformable == isinstance(self.brush, DeformableBrush):
            self.brush.set(settings)
            return
        self.flush_sources(whole=True)
        old = self.brush
        if deformable:
            self.brush = DeformableBrush(self.width, self.height, settings, old.model,
                                         self._paper(), time_scale=old.time_scale,
                                         counters=self.solver)
        else:
            self.brush = RoundBrush(self.width, self.height, settings, old.model,
                                    time_scale=old.time_scale, paper=self._grain())
        # the counters of the session go on across brushes
        self.brush.stamps, self.brush.samples = old.stamps, old.samples
        self.brush.strokes, self.brush.eraser_samples = old.strokes, old.eraser_samples

    def brush_counters(self) -> dict[str, Any]:
        """What the brushes did: stamps, strokes, eraser samples, spine solves."""
        b = self.brush
        out: dict[str, Any] = {"stamps": b.stamps, "strokes": b.strokes,
                               "eraser_samples": b.eraser_samples}
        if self.solver.solves:
            out.update(brush_solves=self.solver.solves,
                       brush_fallbacks=self.solver.fallbacks,
                       pickups_skipped=self.pickups_skipped)
        if isinstance(b, DeformableBrush):
            out["brush_reservoir"] = b.reservoir.ledger()
        return out

    def _grain(self) -> Any:
        """The paper height the round brush's edge and dry-brush follow, or ``None`` for a
        backend that shows no state (a spy): the brush then paints geometric footprints.
        Read once per player (a GPU backend reads it back). A rank of a distributed canvas
        gets the state's metadata only (its ``state`` is collective, every rank's player
        asks at the same record): it makes the same paper from the preset and seed, so
        every rank's brush lays the same stamps."""
        if self._grain_h is None:
            state = getattr(self.backend, "live_state", None)
            if not isinstance(state, CanvasState):
                read = getattr(self.backend, "state", None)
                state = read() if callable(read) else None
            if not isinstance(state, CanvasState):
                return None
            h = state.h
            if h.shape != (self.height, self.width):
                h = make_paper(state.paper_preset, self.height, self.width, state.seed)
            self._grain_h = h
        return self._grain_h

    def _paper(self) -> np.ndarray:
        """The paper height of the backend (read back once from a GPU backend)."""
        state = getattr(self.backend, "live_state", None)
        if state is None:
            state = self.backend.state()
        return state.h

    def _profile(self, args: Mapping[str, object], where: str | None) -> None:
        name = _profile_name(args, where)
        self.flush_sources(whole=True)
        try:
            self.backend.set_profile(name)
        except BadInput as exc:
            raise PlayerError(str(exc).removeprefix("--profile: "), where) from None
        prof = get_profile(name)
        self.profile = name
        if self.tilt[0] != 0.0:
            _apply_tilt(self)
        # The rate (steps per painting second) stays; a profile with another dt
        # changes how much simulated time a painting second holds.
        self.dt = prof.params.dt
        self.brush.time_scale = self.rate * self.dt
        self.brush.model = brush_model(prof)
        self._use(brush_defaults(prof).scaled(self.brush_scale))

    def _wait(self, args: Mapping[str, object], where: str | None) -> None:
        seconds = _wait_seconds(args, where)
        self.waited += float(seconds)
        self.counters.waited_s += float(seconds)

    # -- whole streams -------------------------------------------------------------
    def play(
        self,
        records: Iterable[PenSample | Command],
        where: Callable[[], str] | None = None,
        on_step: Callable[[SessionPlayer], None] | None = None,
    ) -> None:
        """Play a stream of records in time order.

        ``where`` names the current record (``file:line``) for error messages.
        A :class:`BadInput` from the stream or from a record stops the play
        with everything before it applied (and simulated up to that record's
        time); pending brush stamps are flushed into the backend first, so
        nothing already painted is lost.
        """
        try:
            for rec in records:
                self._check_time(rec.t, 0.0, where)
                self.advance_to(rec.t, on_step)
                self.apply(rec, where() if where else None)
                if isinstance(rec, Command) and rec.cmd == "wait":
                    self._check_time(rec.t, 0.0, where)
                    self.advance_to(rec.t, on_step)
        except BadInput:
            try:  # keep what was painted before the bad record ...
                self.flush_sources(whole=True)
            except BadInput as exc:  # ... unless the stamps themselves are refused
                log.warning("stamps before the bad record dropped: %s", exc)
            raise
        self.flush_sources(whole=True)

    def _check_time(self, t: float, more: float, where: Callable[[], str] | None,
                    flag: str | None = None) -> None:
        """Refuse painting time past :data:`MAX_PAINTING_SECONDS` (before running it)."""
        total = t + self.waited + more
        if total > MAX_PAINTING_SECONDS:
            raise PlayerError(
                f"painting time {total:g} s (session time {t:g} s + waits {self.waited:g} s"
                f"{f' + {more:g} s' if more else ''}) is past the {MAX_PAINTING_SECONDS:g} s "
                "a session may last", where() if where else flag)

    def settle(self, seconds: float, on_step: Callable[[SessionPlayer], None] | None = None
               ) -> None:
        """Run ``seconds`` more painting time after the last record."""
        self._check_time(self.last_t, seconds, None, "--settle")
        self.waited += seconds
        self.advance_to(self.last_t, on_step)
        self.flush_sources(whole=True)


def _profile_name(args: Mapping[str, object], where: str | None) -> str:
    name = args.get("name")
    if not isinstance(name, str):
        raise PlayerError(f"profile name {name!r} must be a string (one of "
                          f"{', '.join(profile_names())})", where)
    try:
        get_profile(name)  # built-in or a user file; a bad file names its line
    except BadInput as exc:
        raise PlayerError(str(exc).removeprefix("--profile: "), where) from None
    return name


def _wait_seconds(args: Mapping[str, object], where: str | None) -> float:
    seconds = args.get("seconds", 0.0)
    if (isinstance(seconds, bool) or not isinstance(seconds, (int, float))
            or not 0.0 <= seconds <= MAX_WAIT_SECONDS):  # NaN fails the comparison
        raise PlayerError(f"wait seconds {seconds!r:.40} must be a number in [0, "
                          f"{MAX_WAIT_SECONDS:g}]", where)
    return float(seconds)


# every other handler: `station send` checks its arguments (ranges included) on a scratch
# canvas before it goes on the bus, so it exits 2 exactly where the sim would refuse it
_SCRATCH_CHECKED = frozenset({"mask", "mask_remove", "eraser", "tissue", "tilt", "diffusion",
                              "well", "undo", "redo", "hairdryer", "dry", "new_layer",
                              "clear"})
LIVE_COMMANDS = frozenset({"save", "stop"})
"""Commands only a running simulation executes (``station sim``; never logged)."""


def check_command(cmd: Command, pigments: Container[str] | None = None,
                  where: str | None = None) -> None:
    """Validate a command exactly as the player validates it when it runs it (the
    same checks of ``brush``, ``profile`` and ``wait`` arguments), and refuse one
    that nothing would execute; for ``station send``, before it goes on the bus.

    Raises :class:`PlayerError` (bad input)."""
    name = cmd.cmd
    if name in LIVE_COMMANDS:
        return
    if name not in _HANDLERS:
        what = "is not implemented yet" if cmd.known else "is unknown"
        runs = ", ".join(sorted({*_HANDLERS, *LIVE_COMMANDS}))
        raise PlayerError(f"command {name!r} {what} (one of {runs})", where)
    if name == "brush":
        BrushSettings.from_args(cmd.args, where, pigments, BrushSettings())
    elif name == "profile":
        _profile_name(cmd.args, where)
    elif name == "wait":
        _wait_seconds(cmd.args, where)
    elif name in _SCRATCH_CHECKED:  # run it on a scratch canvas: the same checks, no effect
        scratch = SessionPlayer(NumpyCanvas(16, 16), 16, 16)
        _HANDLERS[name](scratch, cmd.args, where)


def _dry(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    p.flush_sources(whole=True)
    p.backend.dry()


def _number(args: Mapping[str, object], key: str, default: float, lo: float, hi: float,
            where: str | None) -> float:
    v = args.get(key, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
            or not lo <= v <= hi:
        raise PlayerError(f"hairdryer {key} {v!r} must be a number in [{lo:g}, {hi:g}]", where)
    return float(v)


def _hairdryer(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    """Hold a hair dryer over (x, y) (canvas-normalised) for ``seconds`` of painting time
    from now (0 switches it off): ``radius`` [cells of the session's canvas],
    ``temperature`` [C] and ``airflow`` [1] of its air at the sheet."""
    x = _number(args, "x", 0.5, 0.0, 1.0, where)
    y = _number(args, "y", 0.5, 0.0, 1.0, where)
    seconds = _number(args, "seconds", 10.0, 0.0, MAX_WAIT_SECONDS, where)
    radius = _number(args, "radius", 60.0, 1.0, 2048.0, where) * p.brush_scale
    temp = _number(args, "temperature", 40.0, -10.0, 60.0, where)
    flow = _number(args, "airflow", 2.0, 0.0, 200.0, where)
    p.flush_sources(whole=True)
    p.dryer = HairDryer(cx=x * (p.width - 1), cy=y * (p.height - 1),
                        radius=max(1.0, min(radius, 2048.0)), temperature=temp, airflow=flow)
    p.dryer_until = p.counters.steps + int(round(seconds * p.rate))
    if seconds == 0:
        p.dryer = None


def _new_layer(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    p.flush_sources(whole=True)
    try:
        p.backend.new_layer()
    except BadInput as exc:
        raise PlayerError(str(exc), where) from None
    p.layer_pigments.clear()


def _clear(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    p.brush.take()  # stamps not yet simulated are cleared with the rest
    p.backend.clear()
    p.layer_pigments.clear()


def _tool_number(tool: str, args: Mapping[str, object], key: str, default: float, lo: float,
                 hi: float, where: str | None) -> float:
    v = args.get(key, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
            or not lo <= v <= hi:
        raise PlayerError(f"{tool} {key} {v!r:.40} must be a number in [{lo:g}, {hi:g}]",
                          where)
    return float(v)


def _check_keys(tool: str, args: Mapping[str, object], known: set[str], where: str | None) -> None:
    extra = sorted(set(args) - known)
    if extra:
        raise PlayerError(f"{tool}: unknown argument {extra[0]!r} (known: "
                          f"{', '.join(sorted(known))})", where)


_AT = {"x", "y", "pressure"}


def _pick_up(p: SessionPlayer, tool: str, args: Mapping[str, object], where: str | None) -> None:
    """Take ``tool`` in hand; with ``x``/``y`` (canvas-normalised) also dab once there."""
    p.flush_sources(whole=True)
    p.tool = tool
    p._dab = None
    p._tool_last = None
    if "x" in args or "y" in args:
        x = _tool_number(tool, args, "x", 0.5, 0.0, 1.0, where)
        y = _tool_number(tool, args, "y", 0.5, 0.0, 1.0, where)
        pr = _tool_number(tool, args, "pressure", 1.0, 0.0, 1.0, where)
        try:
            p._dab_at(tool, x * p.width, y * p.height, pr)
        except BadInput as exc:
            raise PlayerError(str(exc), where) from None
        p._dab = None


def _mask(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    """Masking fluid: ``size`` (diameter, cells of the session's canvas)."""
    _check_keys("mask", args, {"size"} | _AT, where)
    if "size" in args:
        p.mask_radius = _tool_number("mask", args, "size", 12, 1, 1024, where) * \
            p.brush_scale / 2.0
    _pick_up(p, "mask", args, where)


def _mask_remove(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    _check_keys("mask_remove", args, set(), where)
    p.flush_sources(whole=True)
    edit_state(p.backend, mask_tool.rub_off)


def _eraser(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    """The selective eraser: ``fields`` (list), ``fraction``, ``size`` (diameter)."""
    _check_keys("eraser", args, {"fields", "fraction", "size"} | _AT, where)
    e = p.eraser
    fields = args.get("fields", list(e.fields))
    if not isinstance(fields, list) or not all(isinstance(f, str) for f in fields):
        raise PlayerError("eraser fields must be a list of strings", where)
    frac = _tool_number("eraser", args, "fraction", e.fraction, 0.0, 1.0, where)
    size = _tool_number("eraser", args, "size", 2 * e.radius / p.brush_scale, 1, 1024, where)
    try:
        p.eraser = eraser_tool.Eraser(tuple(fields), frac, size * p.brush_scale / 2.0)
    except BadInput as exc:
        raise PlayerError(str(exc).removeprefix("eraser: "), where) from None
    _pick_up(p, "eraser", args, where)


def _tissue(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    """The textured tissue: ``kind`` (crepe, weave, flat), ``scale`` cells, ``seed``,
    ``size`` (diameter), ``absorb``."""
    _check_keys("tissue", args, {"kind", "scale", "seed", "size", "absorb"} | _AT, where)
    t = p.tissue
    kind = args.get("kind", t.kind)
    if kind not in tissue_tool.KINDS:
        raise PlayerError(f"tissue kind {kind!r:.40} must be one of "
                          f"{', '.join(tissue_tool.KINDS)}", where)
    seed = args.get("seed", t.seed)
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**32:
        raise PlayerError(f"tissue seed {seed!r:.40} must be an integer in [0, 2^32)", where)
    scale = _tool_number("tissue", args, "scale", t.scale, 1, 256, where)
    size = _tool_number("tissue", args, "size", 2 * t.radius / p.brush_scale, 1, 1024, where)
    absorb = _tool_number("tissue", args, "absorb", t.absorb, 0, 1, where)
    # a session painted at a smaller size scales the texture with it, but no finer
    # than a cell: the texture lives on the canvas grid
    new = tissue_tool.Tissue(kind, max(1.0, scale * p.brush_scale), seed, None,
                             size * p.brush_scale / 2.0, absorb)
    if (new.kind, new.scale, new.seed) != (t.kind, t.scale, t.seed):
        p._tissue_tex = None
    p.tissue = new
    _pick_up(p, "tissue", args, where)


def _tilt(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    """Tilt the canvas: ``angle`` from the horizontal [deg, 0 ... 90], ``direction`` of
    the downhill slope on the canvas [deg from +x towards +y; 90 = towards the bottom]."""
    _check_keys("tilt", args, {"angle", "direction"}, where)
    angle = _tool_number("tilt", args, "angle", 0.0, 0.0, 90.0, where)
    direction = _tool_number("tilt", args, "direction", 90.0, 0.0, 359.999, where)
    p.flush_sources(whole=True)
    p.tilt = (angle, direction)
    _apply_tilt(p)


def _apply_tilt(p: SessionPlayer) -> None:
    angle, direction = p.tilt

    def put(st: CanvasState) -> None:
        st.params = st.params.replace(tilt=angle, tilt_direction=direction)

    edit_state(p.backend, put)


def _diffusion(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    """The diffusion controller: while on, the brush writes ``pattern`` (``stripes``,
    ``rings``, ``dots``, ``checks``; ``off`` stops it) of ``period`` cells at ``angle``
    degrees with ``strength`` every ``interval`` touching samples along its strokes."""
    _check_keys("diffusion", args, {"pattern", "period", "angle", "strength", "interval",
                                    "fade"}, where)
    if "fade" in args:  # how long a written pattern takes to age back to free [s]
        fade = _tool_number("diffusion", args, "fade", 2.0, 0.0, 3600.0, where)
        p.flush_sources(whole=True)

        def put(st: CanvasState) -> None:
            st.params = st.params.replace(block_fade=fade)

        edit_state(p.backend, put)
    pattern = args.get("pattern", "stripes")
    if pattern == "off":
        p.controller = None
        return
    interval = args.get("interval", 1)
    if isinstance(interval, bool) or not isinstance(interval, int) or not 1 <= interval <= 1000:
        raise PlayerError(f"diffusion interval {interval!r:.40} must be an integer in "
                          "[1, 1000]", where)
    if pattern not in diffusion_tool.PATTERNS:
        raise PlayerError(f"diffusion pattern {pattern!r:.40} must be off or one of "
                          f"{', '.join(diffusion_tool.PATTERNS)}", where)
    period = _tool_number("diffusion", args, "period", 4.0, 2.0, 512.0, where) * p.brush_scale
    p.controller = diffusion_tool.Controller(
        pattern, max(period, 2.0), _tool_number("diffusion", args, "angle", 0.0, -360, 360, where),
        _tool_number("diffusion", args, "strength", 1.0, 0.0, 1.0, where), interval)
    p._controller_field = None
    p._controller_count = 0


def _undo(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    """Undo the newest stroke or dab (``station.sim.undo``); nothing to undo: counted."""
    _check_keys("undo", args, set(), where)
    if p.history is None or not p.history.undo():
        p.counters.skipped_commands["undo"] = p.counters.skipped_commands.get("undo", 0) + 1


def _redo(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    _check_keys("redo", args, set(), where)
    if p.history is None or not p.history.redo():
        p.counters.skipped_commands["redo"] = p.counters.skipped_commands.get("redo", 0) + 1


def _well(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    """The palette's mixing well: ``add`` a pigment (``amount`` of tube strength, ``water``,
    ``settle`` seconds of mixing), ``pick`` the mix up with the brush, or ``clear`` it."""
    _check_keys("well", args, {"add", "amount", "water", "settle", "pick", "clear"}, where)
    if p.well is None:
        prof = get_profile(p.profile)
        p.well = well_tool.MixingWell(prof.params, prof.brush.pigment_load)
    well = p.well
    if args.get("clear") is True:
        well.clear()
    name = args.get("add")
    if name is not None:
        if not isinstance(name, str):
            raise PlayerError(f"well add {name!r:.40} must be a pigment name", where)
        amount = _tool_number("well", args, "amount", 0.5, 0.0, 1.0, where)
        water = _tool_number("well", args, "water", 0.6, 0.05, 1.0, where)
        settle = _tool_number("well", args, "settle", 2.0, 0.0, 60.0, where)
        try:
            well_tool.check_room(well, name)
            well.add(name, amount, water, settle)
        except BadInput as exc:
            raise PlayerError(str(exc).removeprefix("well: ").removeprefix("pigment: "),
                              where) from None
    if args.get("pick") is True:
        mix = well.mix()
        if not mix:  # a state, not a malformed command (like undo with nothing to undo)
            p.counters.skipped_commands["well"] = p.counters.skipped_commands.get("well", 0) + 1
            if "well-empty" not in p._warned:
                p._warned.add("well-empty")
                log.warning("%sthe well is empty: nothing to pick up (skipped)",
                            f"{where}: " if where else "")
            return
        b = p.brush.settings
        p._use(BrushSettings(b.kind, b.size, b.water, mix))
        p.tool = None


_HANDLERS: dict[str, Callable[[SessionPlayer, Mapping[str, object], str | None], None]] = {
    "well": _well,
    "undo": _undo,
    "redo": _redo,
    "diffusion": _diffusion,
    "tilt": _tilt,
    "mask": _mask,
    "mask_remove": _mask_remove,
    "eraser": _eraser,
    "tissue": _tissue,
    "brush": SessionPlayer._brush,
    "profile": SessionPlayer._profile,
    "wait": SessionPlayer._wait,
    "dry": _dry,
    "hairdryer": _hairdryer,
    "new_layer": _new_layer,
    "clear": _clear,
}


def brush_model(profile: Profile) -> BrushModel:
    """The round-brush model of a profile: its per-stamp water and pigment, its v_max.

    ``pigment_load`` is the pigment of a full stamp of tube-strength paint (brush amount
    1); there is no gain on top of it.
    """
    b = profile.brush
    return BrushModel(water_scale=b.water, pigment_scale=b.pigment_load,
                      v_max=profile.params.v_max)


def brush_defaults(profile: Profile) -> BrushSettings:
    """The brush a profile starts with: its radius, full water, its default pigment at the
    profile's nominal amount."""
    b = profile.brush
    return BrushSettings(size=2.0 * b.radius, water=1.0, pigment={b.pigment: b.amount})


def add_sources(backend: CanvasBackend, src: Sources) -> None:
    """Give brush sources to a backend (region arrays; see ``brush.Sources``)."""
    backend.add_sources(src.dw, src.dp, src.dvx, src.dvy, y0=src.y0, x0=src.x0)
