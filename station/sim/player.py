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
from typing import Any, NamedTuple

import numpy as np

from station.answer import ReadKeys
from station.arttools import diffusion as diffusion_tool
from station.arttools import eraser as eraser_tool
from station.arttools import mask as mask_tool
from station.arttools import tissue as tissue_tool
from station.arttools import well as well_tool
from station.backends.numpy_canvas import NumpyCanvas
from station.backends.protocol import CanvasBackend, edit_state
from station.brush.bead import FRESH_SAT, BeadRequest, bead_sources, fresh_phase_box
from station.brush.deformable import DeformableBrush
from station.brush.reservoir import pickup
from station.brush.solver import SolverCounters
from station.brush.sources import Sources, Taken
from station.brush.stamp import STAMP_KIND, BrushModel, BrushSettings, RoundBrush
from station.canvas.paper import make_paper
from station.canvas.params import Profile, SimParams
from station.canvas.profiles import get_profile, profile_names
from station.canvas.removal import HairDryer, StateSurface, blow
from station.canvas.state import DEFAULT_SLOTS, CanvasState
from station.canvas.stencils import gaussian_taps
from station.errors import BadInput
from station.events import Command, PenSample, Tool
from station.sim.tool_commands import (
    MAX_WAIT_SECONDS,
    TOOL_HANDLERS,
    PlayerError,
    apply_tilt,
)
from station.sim.undo import UndoHistory

log = logging.getLogger(__name__)

MAX_SKIPPED_NAMES = 64  # distinct unknown command names counted (and warned) by name

MAX_PAINTING_SECONDS = 86400.0
"""Longest painting time a replayed session may reach (session time + waits +
``--settle``): one day.  A record past it (``t`` = 1e12 would mean simulating
for millennia) is refused as bad input instead of running "forever"."""
MAX_RATE = 1000.0
"""Most simulation steps per second of painting time a replay may ask for."""


class PaperWater(NamedTuple):
    """What a bead needs to know of the canvas (:mod:`station.brush.bead`): the fluid water
    height ``w`` [height], the mask, ``w_max``, whether the profile's damp paper draws
    fresh water, the saturation from which paper counts as damp, how far [cells] the
    flow-outward blur reads the wet-area mask, and the capillary water ``wc``, the paper
    height ``h`` and the profile's capacities ``c_min``, ``c_max`` the saturation comes
    from (:meth:`saturation`)."""

    w: np.ndarray
    mask: np.ndarray
    w_max: float
    damp: bool
    damp_sat: float
    blur_reach: int
    wc: np.ndarray
    h: np.ndarray
    c_min: float
    c_max: float

    def saturation(self, y0: int, y1: int, x0: int, x1: int) -> np.ndarray:
        """The capillary layer's saturation ``min(wc / c, 1)`` in the cells ``[y0, y1) x
        [x0, x1)``, in an array of the canvas's shape whose other cells are 0: a
        bead reads its reach only (:func:`~station.brush.bead.fresh_phase_box` holds it),
        and the whole 1920×1080 canvas's took 25-110 ms a touch-down.  Cell by cell the
        same float32 operations as over the whole canvas: the same bits."""
        out = np.zeros(self.wc.shape, np.float32)  # (calloc: untouched pages cost nothing)
        h = self.h[y0:y1, x0:x1]
        cap = np.float32(self.c_min) + h * np.float32(self.c_max - self.c_min)
        out[y0:y1, x0:x1] = np.minimum(self.wc[y0:y1, x0:x1] / np.maximum(
            cap, np.float32(1e-6)), np.float32(1.0))
        return out


def _paper_water(w: np.ndarray, mask: np.ndarray, wc: np.ndarray, h: np.ndarray,
                 prm: SimParams) -> PaperWater:
    """:class:`PaperWater` from a canvas's arrays and parameters. Damp paper draws a bead
    only where the profile has both damp paper's suction (``damp_ease``) and a wet-area
    memory to start a fresh phase in (``wet_hold``)."""
    reach = len(gaussian_taps(prm.wet_blur)) // 2 if prm.flow_outward > 0 else 0
    return PaperWater(w, mask, float(prm.w_max), prm.damp_ease > 0 and prm.wet_hold > 0,
                      float(prm.damp_sat), reach, wc, h, prm.c_min, prm.c_max)


@dataclass(frozen=True)
class StepTake:
    """What step ``index`` took (:meth:`SessionPlayer.take_step`) for
    :meth:`SessionPlayer.apply_step`: the backend to step, the stamps and their shares
    (not yet summed), the beads due, the hair dryer blowing this step (``None``: none)
    and the step's ``dt`` [simulation time]."""

    index: int
    backend: CanvasBackend
    stamps: Taken
    beads: list[BeadRequest]
    dryer: HairDryer | None
    dt: float


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
        spread over the two steps around its time: :mod:`station.brush.sources`), and the
        beads of the touch-downs before it (:meth:`release_beads`):
        :meth:`take_step`, :meth:`apply_step`, :meth:`end_step`."""
        self.apply_step(self.take_step())
        self.end_step()

    def take_step(self) -> StepTake:
        """The first part of a step: what it takes from the brush (the deformable brush's
        pick-ups, which write the canvas, the stamps' shares due, the beads due) and the
        hair dryer's turn.  Everything that reads or changes the brush or the player is
        here; :meth:`apply_step` touches only the canvas and what this returns, so a host
        may run it while new pen samples feed the brush (the kiosk: its lock released),
        as long as those samples belong to the next step (their stamps and beads are
        taken by its :meth:`take_step`, as in a replay that applies them after this
        step)."""
        k = self.counters.steps
        self._pickups()
        stamps = self.brush.take_shares(k)
        beads = self.brush.take_beads(k) if isinstance(self.brush, RoundBrush) else []
        dryer = self.dryer
        if dryer is not None and k >= self.dryer_until:
            self.dryer = dryer = None
        return StepTake(k, self.backend, stamps, beads, dryer, self.dt)

    def apply_step(self, take: StepTake,
                   refused: Callable[[BadInput], None] | None = None) -> None:
        """The rest of the step :meth:`take_step` began, on the canvas alone: the stamps
        summed and added, the beads run out, the dryer, the kernel.  ``refused``: what to
        do with the stamps the canvas refuses (:class:`BadInput`; raised when ``None``),
        the step goes on."""
        backend = take.backend
        src = take.stamps.sources()
        if src is not None:
            try:
                add_sources(backend, src)
            except BadInput as exc:
                if refused is None:
                    raise
                refused(exc)
        self._run_beads(take.beads, backend)
        dryer = take.dryer
        if dryer is not None:
            edit_state(backend, lambda st: blow(st, dryer, take.dt))
        backend.step()

    def end_step(self) -> None:
        """A step over: counted (a record applied from now on is after it)."""
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
        self._pickups()
        src = self.brush.take(None if whole else self.counters.steps)
        if src is not None:
            add_sources(self.backend, src)
        if whole:
            self.release_beads()

    def _pickups(self) -> None:
        """A deformable brush's pick-ups queued since the last flush, lifted from the
        canvas (see :meth:`flush_sources`)."""
        if isinstance(self.brush, DeformableBrush):
            requests = self.brush.take_pickups()
            state = getattr(self.backend, "live_state", None)
            if requests and state is None:
                self.pickups_skipped += len(requests)
            elif requests and state is not None:
                for r in requests:
                    pickup(StateSurface(state), self.brush.reservoir, r.weight, r.y0, r.x0,
                           self.brush.shape.pickup)

    def release_beads(self, step: int | None = None) -> None:
        """The beads of the round brush's touch-downs run out into the standing water under
        them, or into damp paper (:mod:`station.brush.bead`). Called once a step with the
        step's index (the beads due before it: their stamps' first shares are in), after the
        step's stamps, and with ``None`` (all) at a whole flush; never from a live preview's
        flush, so live and replay agree. A bead run out into damp paper starts a fresh wet
        phase: the damp wash's faded wet-area memory around it is dropped
        (:meth:`_fresh_wet_phase`)."""
        if isinstance(self.brush, RoundBrush):
            self._run_beads(self.brush.take_beads(step), self.backend)

    def _run_beads(self, beads: list[BeadRequest], backend: CanvasBackend) -> None:
        """The beads taken (:meth:`release_beads`) run out on ``backend``'s canvas."""
        for req in beads:
            got = self._paper_water(backend)
            if got is None:  # a backend that shows no state (a test double)
                continue
            src = bead_sources(req, got.w, got.mask, got.w_max)
            if src is None and got.damp:
                y0, y1, x0, x1 = fresh_phase_box(req, got.w_max, got.blur_reach,
                                                 *got.w.shape)
                sat = got.saturation(y0, y1, x0, x1)  # (bead_sources reads inside)
                src = bead_sources(req, got.w, got.mask, got.w_max, sat, got.damp_sat)
                if src is not None:
                    self._fresh_wet_phase(
                        y0, x0, sat[y0:y1, x0:x1] < np.float32(FRESH_SAT), backend)
            if src is not None:
                add_sources(backend, src)

    def _fresh_wet_phase(self, y0: int, x0: int, drier: np.ndarray,
                         backend: CanvasBackend) -> None:
        """Drop the faded wet-area memory (``wet_area < 1``: cells whose water has gone)
        where ``drier`` (a window at row ``y0``, column ``x0``) is set: Curtis 1997's
        wet-area mask belongs to a glaze, and a fresh load run out into a damp wash is a new
        one, so the flow-outward term acts at the fresh water's own edge where it meets
        paper drier than :data:`~station.brush.bead.FRESH_SAT`. Cells wet now keep 1. In
        place where the backend keeps its arrays in memory; GL rewrites that window of its
        mask texture; others take a state round trip."""
        if not drier.any():
            return
        forget = getattr(backend, "forget_wet_memory", None)
        if getattr(backend, "live_state", None) is None and forget is not None:
            forget(y0, x0, drier)
            return

        def drop(st: CanvasState) -> None:
            a = st.wet_area[y0:y0 + drier.shape[0], x0:x0 + drier.shape[1]]
            a[(a < np.float32(1.0)) & drier] = np.float32(0.0)

        edit_state(backend, drop)

    def _paper_water(self, backend: CanvasBackend) -> PaperWater | None:
        """The canvas's fluid water height, mask, ``w_max`` and, where the profile's damp
        paper draws fresh water (``damp_ease > 0`` with a wet-area memory), the capillary
        layer's saturation: the arrays themselves where the backend keeps them in memory,
        else read back (GL: two textures; other backends their whole state), at most once a
        dip (a bead is the first touch-down's)."""
        live = getattr(backend, "live_state", None)
        st: CanvasState | None = live if isinstance(live, CanvasState) else None
        if st is None:
            read = getattr(backend, "paper_water", None)
            if read is not None:
                got = read()
                if got is not None:  # a backend that answers but shows nothing: no bead
                    w, mask, wc, h = got
                    prm = getattr(backend, "params", None)
                    if isinstance(prm, SimParams):
                        return _paper_water(w, mask, wc, h, prm)
            whole = getattr(backend, "state", None)
            st = whole() if whole is not None else None
            if not isinstance(st, CanvasState):
                return None
        return _paper_water(st.w, st.mask, st.wc, st.h, st.params)

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
            skipped = self.counters.skipped_commands
            # names come from whoever publishes on the bus: a bounded set of them
            key = name if name in skipped or len(skipped) < MAX_SKIPPED_NAMES else "(other)"
            skipped[key] = skipped.get(key, 0) + 1
            if name not in self._warned and len(self._warned) < MAX_SKIPPED_NAMES:
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
            apply_tilt(self)
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


def check_sent_command(cmd: Command, pigments: Container[str] | None = None,
                       where: str | None = None) -> None:
    """:func:`check_command`, held to the stricter rule of a command someone sends and
    waits for (``station send``): a key nothing would read (``sizee=3``) is refused,
    where a session log's is ignored with a warning (interfaces.md).

    Raises :class:`PlayerError` (bad input)."""
    if cmd.cmd in LIVE_COMMANDS:
        unread = sorted(cmd.args)
    else:
        args = ReadKeys(cmd.args)
        check_command(dataclasses.replace(cmd, args=args), pigments, where)
        unread = args.unread()
    if unread:
        raise PlayerError(f"{cmd.cmd} takes no key {', '.join(map(repr, unread))} (nothing "
                          "would read it)", where)


_HANDLERS: dict[str, Callable[[SessionPlayer, Mapping[str, object], str | None], None]] = {
    **TOOL_HANDLERS,
    "brush": SessionPlayer._brush,
    "profile": SessionPlayer._profile,
    "wait": SessionPlayer._wait,
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
