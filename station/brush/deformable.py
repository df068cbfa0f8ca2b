"""The deformable brush: pen samples → spines → tuft → footprints → paint (issue 11).

Pen mapping (§7):

* position: the pen point is where the handle's axis meets the canvas;
* pressure ``p`` → the ferrule's height over the canvas,
  ``z = L · (1 - REACH - press_depth · p)`` (``L`` the tuft length in cells):
  at the lightest touch the straight tip just reaches the paper, harder
  pressure lowers the handle and the spines bend and spread;
* tilt → the handle's orientation (:func:`~station.brush.spine.handle_frame`);
* rotation (Art Pen) → twist of the handle about its axis (a flat brush's
  width turns with it).

A pen sample is a *frame* when it is due (``TuftModel.frame_interval``: every
sample of a pen at ≤ 250 Hz, every fourth of a 1 kHz one): the spines find
their equilibrium (warm started) and the tuft is deformed; its footprint is
rasterised when a stamp first needs it.  Along the path of the samples the
last frame's footprint is stamped at a spacing of a fraction of its size
(shifted by whole cells), each stamp giving only what the previous one did not
cover, so the bristle marks run along the stroke.  Where the tuft presses, the
ink a loaded tuft holds wets the paper's tooth (``TuftModel.ink_reach``):
without it a tuft of a few cells touches only the tooth's hills.  The paint
comes from the :class:`~station.brush.reservoir.Reservoir`; where the
footprint passes over wet paint, pick-up requests are queued for the player,
which applies them to the canvas arrays before the next step.

Running dry (docs/brush.md): the tuft holds ink by its volume; the paper draws
it in ``∝ √(contact time)``; below ``film_fill`` the ink splits into locks of
bristles with their own shares (the rasteriser, numba or GL, tells each cell
which bristle touches it; one without a ``tags`` argument leaves the tuft one
body), and the dry bristles skim the tooth from hill to hill along the
motion, so a draining stroke breaks into streaks along itself.

Plasticity: while the brush is wet and touching, each spine's rest angles
drift toward its current angles (``plasticity · fill`` per frame); lifted,
they relax back to the shape's rest (``recovery`` per frame).

Everything is deterministic (evaluation budget, seeded tuft): a session
replays to the same pixels.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from station.brush.footprint import (
    FootprintMaps,
    prune_spurs,
    rasterise,
    segments,
    shifted_union,
    toothed_rim,
    union_max,
    weight,
)
from station.brush.geometry import BrushShape, Tuft, get_shape
from station.brush.reservoir import Reservoir
from station.brush.solver import (
    SolverCounters,
    SpineSolver,
    SpineState,
    bend_behind,
    has_straight,
)
from station.brush.sources import (
    Footprint,
    Sources,
    Stamp,
    StampPreview,
    StampQueue,
    Taken,
    painting_steps,
)
from station.brush.spine import handle_frame
from station.brush.stamp import (
    MIN_VELOCITY_DT,
    NO_PRESSURE_TOOLS,
    BrushModel,
    BrushSettings,
    paper_maps,
)
from station.brush.tuft_model import PickupRequest
from station.brush.tuft_model import TuftModel as TuftModel
from station.errors import BadInput
from station.events import PenSample, Tool

REACH = 0.03
"""How far below the plane the straight tip would reach at the lightest touch
(tuft lengths): the bristles touch as soon as the pen does."""

DOWN_MOVE = 0.25
"""How far [cells] the pen must move from where a one-spine tuft touched down for the
tuft to buckle behind that motion."""
DOWN_WAIT = 0.25
"""How long [session s] a one-spine tuft's touch-down waits for the pen to move before
it buckles its own way (a brush pressed and held)."""


SLIDE = 0.5
"""Cells between the points of the path a tuft slides over between two stamps."""


@dataclass(slots=True)
class _Stroke:
    x: float
    y: float
    t: float
    vx: float = 0.0
    vy: float = 0.0
    to_next: float = 0.0
    previous: Footprint | None = None
    # the last solved frame: where the pen was, when, the bristles (cells) and,
    # once a stamp needed them, their maps
    fx: float = 0.0
    fy: float = 0.0
    ft: float = 0.0
    bristles: np.ndarray | None = None
    maps: FootprintMaps | None = None
    # a one-spine tuft's touch-down (and any tuft's on a pen without a barrel sensor)
    # waits for the pen's first move (sample, pressure): the tuft then buckles behind
    # the motion (see DeformableBrush._touch_down), a flat's width across it
    down: tuple[PenSample, float] | None = None
    twist: float = 0.0  # degrees added to the pen's barrel rotation for this stroke
    turn: float = 0.0  # degrees the hand is turned about the vertical (pull_broadside)
    # shifts of a frame's maps the tuft slid over since the last stamp (DeformableBrush._slide)
    slid: list[tuple[FootprintMaps, int, int]] = field(default_factory=list)
    slid_cells: set[tuple[int, int]] = field(default_factory=set)  # the pen cells noted


def _takes_tags(fn: Callable[..., FootprintMaps]) -> bool:
    """Whether a rasteriser accepts per-segment ``tags`` (the numba and GL ones do; a
    host's own may not, and then the tuft dries as one body)."""
    try:
        return "tags" in inspect.signature(fn).parameters
    except (TypeError, ValueError):  # a builtin without a signature
        return False


def pull_broadside(tilt_x: float, tilt_y: float, dx: float, dy: float
                   ) -> tuple[float, float]:
    """``(turn, twist)`` [degrees] for a flat or a fan on a pen without a barrel sensor,
    from the stroke's first move ``(dx, dy)``: a painter sets a flat down with its width
    across the pull and its handle trailing the tip (leaning the way it moves), as
    Krita's and Rebelle's flat brushes take the drawing angle. A stylus's lean says
    how the hand holds the pen, not how it would turn a brush, so the hand is turned
    about the vertical (``turn``, added to the tilt's azimuth for the whole stroke)
    until the lean points along the move, and the handle twisted (``twist``) so that
    its X, the width, lies across it: both edges on the paper. Upright, only the twist.
    The width then stays as set (a turning stroke thins, as a real flat's does)."""
    along = math.degrees(math.atan2(dy, dx))
    turn = along - math.degrees(math.atan2(tilt_y, tilt_x)) if (tilt_x or tilt_y) else 0.0
    return turn, along + 90.0


def turned_tilt(tilt_x: float, tilt_y: float, turn: float) -> tuple[float, float]:
    """The tilt vector turned ``turn`` degrees about the vertical."""
    if turn == 0.0:
        return tilt_x, tilt_y
    c, s = math.cos(math.radians(turn)), math.sin(math.radians(turn))
    return c * tilt_x - s * tilt_y, s * tilt_x + c * tilt_y


class DeformableBrush:
    """Spine-driven brush of one :class:`BrushShape` (same interface as ``RoundBrush``).

    The shape is ``settings.kind``'s unless ``shape`` is given (tests, a shape file).
    """

    def __init__(self, width: int, height: int, settings: BrushSettings, model: BrushModel,
                 paper: np.ndarray, time_scale: float = 1.0, tuft: TuftModel | None = None,
                 time_budget_s: float | None = None,
                 rasteriser: Callable[..., FootprintMaps] | None = None,
                 counters: SolverCounters | None = None,
                 shape: BrushShape | None = None) -> None:
        if width < 1 or height < 1:
            raise BadInput(f"canvas {width}x{height} has no cells")
        if paper.shape != (height, width):
            raise BadInput("paper height does not match the canvas")
        self.width, self.height = width, height
        self.model = model
        self.tuft_model = tuft or TuftModel()
        self.paper = np.ascontiguousarray(paper, np.float32)
        self._edge = paper_maps(self.paper)[1]  # the tooth over a couple of cells, [-1, 1]
        self.time_scale = time_scale
        self.solver_budget = time_budget_s
        # numba by default: the same bytes on every machine (replays); a live station
        # with a GL context may pass ``GLFootprint().rasterise`` (same maps to 1e-5)
        self.rasterise: Callable[..., FootprintMaps] = rasteriser or rasterise
        self.solver_counters = counters if counters is not None else SolverCounters()
        self.settings = settings
        self.shape: BrushShape = shape if shape is not None else get_shape(settings.kind)
        self._build()
        self.reservoir = Reservoir(self._capacity())
        self.reservoir.load(settings.water, settings.pigment, model.water_scale,
                            model.pigment_scale)
        self._strokes: dict[str, _Stroke] = {}
        self._pending = StampQueue()
        # the simulation's step clock, as RoundBrush.clock: spreads each stamp over the
        # steps around its time
        self.clock: tuple[float, float] | None = None
        self.pickups: list[PickupRequest] = []
        self.stamps = 0
        self.samples = 0
        self.eraser_samples = 0
        self.strokes = 0
        self.frames = 0
        self.last_maps: FootprintMaps | None = None

    # -- setup ---------------------------------------------------------------------
    def _build(self) -> None:
        shape = self.shape
        self.tuft = Tuft(shape)
        self.solver = SpineSolver(shape.friction, time_budget_s=self.solver_budget,
                                  counters=self.solver_counters)
        self.specs = shape.spine_specs()
        self.spines = [SpineState.at_rest(s) for s in self.specs]
        self.offsets = shape.spine_offsets()

    @property
    def tuft_length(self) -> float:
        """Tuft length in cells."""
        return self.settings.size * self.shape.length

    def _capacity(self) -> float:
        """The liquid the tuft's body holds: ``capacity`` full-stamp water layers
        (``water_scale``) per cell³ of a body as wide as the footprint and as long as
        the tuft.  A volume: a brush twice the size lays a stroke twice as many of its
        widths long (docs/brush.md, "Running dry")."""
        r = 0.5 * self.settings.size
        return self.shape.capacity * math.pi * r * r * self.tuft_length * self.model.water_scale

    def set(self, settings: BrushSettings) -> None:
        """A ``brush`` command: dip the brush (refill) and take the new shape or size."""
        if settings.kind != self.settings.kind or settings.size != self.settings.size:
            self._strokes.clear()
        if settings.kind != self.settings.kind:
            self.shape = get_shape(settings.kind)
            self._build()
        self.settings = settings
        self.reservoir.capacity = self._capacity()
        self.reservoir.load(settings.water, settings.pigment, self.model.water_scale,
                            self.model.pigment_scale)

    # -- checkpoints -------------------------------------------------------------
    def snapshot(self) -> dict[str, Any]:
        """What the brush carries from one stroke to the next, JSON-able (the live sim's
        autosave keeps it, so a recovery paints on exactly): the reservoir's contents and
        books, and each spine's rest angles as plasticity left them. Taken between
        strokes: a stroke in progress is not part of it (the autosave waits for the pen
        to lift)."""
        r = self.reservoir
        return {"frames": self.frames,
                "reservoir": {"capacity": r.capacity, "volume": r.volume, "mass": dict(r.mass),
                              "loaded": dict(r.loaded), "washed": dict(r.washed),
                              "deposited": dict(r.deposited), "picked": dict(r.picked)},
                "rest": [st.rest.tolist() for st in self.spines]}

    def restore(self, snap: Mapping[str, Any]) -> None:
        """Take back a :meth:`snapshot` of a brush of the same kind and size
        (``ValueError`` when it does not fit; the brush is then unchanged)."""
        rest = [np.asarray(r, np.float64) for r in snap["rest"]]
        if len(rest) != len(self.spines) or any(
                a.shape != st.rest.shape or not np.isfinite(a).all()
                for a, st in zip(rest, self.spines, strict=False)):
            raise ValueError("the brush state does not fit this brush's spines")
        res = snap["reservoir"]
        books = {k: {str(n): float(v) for n, v in res[k].items()}
                 for k in ("mass", "loaded", "washed", "deposited", "picked")}
        capacity, volume = float(res["capacity"]), float(res["volume"])
        numbers = [capacity, volume, *(v for d in books.values() for v in d.values())]
        if not all(math.isfinite(v) for v in numbers) or volume < 0 or capacity < 0:
            raise ValueError("the brush state has a bad reservoir")
        frames = int(snap["frames"])
        self._strokes.clear()
        for st, a in zip(self.spines, rest, strict=True):
            st.rest = a.astype(st.rest.dtype)
            st.x = st.rest.copy()  # lifted: in air the rest pose is the equilibrium
            st.pos = st.contact = st.root = None
        r = self.reservoir
        r.capacity, r.volume = capacity, volume
        r.mass, r.loaded, r.washed = books["mass"], books["loaded"], books["washed"]
        r.deposited, r.picked = books["deposited"], books["picked"]
        self.frames = frames

    @property
    def drawing(self) -> bool:
        """A stroke is in progress (some device's pen is down)."""
        return bool(self._strokes)

    def end_strokes(self) -> None:
        self._strokes.clear()
        self._relax_all()

    # -- frames --------------------------------------------------------------------
    def pose(self, x: float, y: float, pressure: float, tilt_x: float, tilt_y: float,
             rotation: float) -> tuple[np.ndarray, np.ndarray]:
        """Spine roots (K, 3) in tuft units and the handle frame for a pen state (cells)."""
        L = self.tuft_length
        handle = handle_frame(tilt_x, tilt_y, rotation)
        z = 1.0 - REACH - self.shape.press_depth * pressure
        up = handle[:, 2]
        centre = np.array([x / L, y / L, 0.0]) + (z / up[2]) * up
        roots = centre[None, :] + self.offsets[:, None] * handle[:, 0][None, :]
        return roots, handle

    def frame(self, x: float, y: float, pressure: float, tilt_x: float = 0.0,
              tilt_y: float = 0.0, rotation: float = 0.0) -> np.ndarray:
        """Solve the spines for a pen state; the deformed bristles (B, S, 3) in cells."""
        roots, handle = self.pose(x, y, pressure, tilt_x, tilt_y, rotation)
        for st, root in zip(self.spines, roots, strict=True):
            self.solver.solve(st, root, handle)
        self._plasticity()
        self.frames += 1
        return self.tuft.deform(self.tuft.lattice(self.spines, roots, handle)) * self.tuft_length

    def footprint(self, bristles: np.ndarray) -> FootprintMaps:
        """Rasterise deformed bristles (cells) into cover and depth maps."""
        L = self.tuft_length
        radius = max(self.tuft_model.min_bristle_radius, 0.5 * self.shape.bristle_width * L)
        segs = segments(bristles)
        if _takes_tags(self.rasterise):  # each cell learns which bristle touches it
            tags = np.repeat(self.tuft.retention, bristles.shape[1] - 1)
            return self.rasterise(segs, radius, tags=tags)
        return self.rasterise(segs, radius)

    def _plasticity(self) -> None:
        shape = self.shape
        fill = self.reservoir.fill
        for st, spec in zip(self.spines, self.specs, strict=True):
            touching = st.contact is not None and bool(st.contact.any())
            if touching:
                st.rest += shape.plasticity * fill * (st.x - st.rest)
            else:
                st.rest += shape.recovery * (np.asarray(spec.rest) - st.rest)

    def _relax_all(self) -> None:
        """Lift: spines straighten (static equilibrium in air is the rest pose)."""
        for st, spec in zip(self.spines, self.specs, strict=True):
            st.rest += self.shape.recovery * (np.asarray(spec.rest) - st.rest)
            st.x = st.rest.copy()
            st.pos = None
            st.contact = None

    # -- input ---------------------------------------------------------------------
    def feed(self, sample: PenSample) -> int:
        """Apply one pen sample; returns the number of stamps it produced."""
        key = sample.device
        if sample.tool is Tool.ERASER:
            self.eraser_samples += 1
            if self._strokes.pop(key, None) is not None:
                self._relax_all()
            return 0
        if not (sample.touching and sample.proximity):
            ended = self._strokes.pop(key, None)
            made = 0
            if ended is not None:
                if ended.down is not None:  # a dab: the tuft set down and lifted
                    made = self._touch_down(ended, *ended.down)
                self._relax_all()
            return made
        self.samples += 1
        p = sample.pressure
        if p == 0.0 and sample.tool in NO_PRESSURE_TOOLS:
            p = self.model.default_pressure
        x, y = sample.x * self.width, sample.y * self.height
        stroke = self._strokes.get(key)
        if stroke is None:
            self.strokes += 1
            stroke = _Stroke(x, y, sample.t)
            self._strokes[key] = stroke
            if (len(self.spines) == 1 or has_straight(self.specs)
                    or sample.rotation is None):
                # pressed, felt (haptics) and set (plasticity) at once; stamped when
                # the pen's first move says which way the tuft bends (and, on a pen
                # without a barrel sensor, which way a flat's width lies)
                stroke.down = (sample, p)
                self._solve(stroke, x, y, p, sample)
                return 0
            return self._touch_down(stroke, sample, p)
        made = 0
        if stroke.down is not None:
            down, pd = stroke.down
            dx, dy = x - stroke.x, y - stroke.y
            moved = math.hypot(dx, dy) >= DOWN_MOVE
            if not moved and sample.t - down.t < DOWN_WAIT:
                if self._due(stroke, x, y, sample.t):
                    self._solve(stroke, x, y, p, sample)
                return 0  # still where it touched: the tuft's way is not known yet
            stroke.down = None
            if moved and len(self.spines) == 1:
                stroke.twist = math.degrees(math.atan2(dy, dx))
                st = self.spines[0]  # buckle afresh, behind the motion
                st.x, st.pos, st.contact = st.rest.copy(), None, None
            elif moved:  # a flat or a fan: its spines set down bending behind the motion
                if down.rotation is None:
                    stroke.turn, stroke.twist = pull_broadside(down.tilt_x, down.tilt_y,
                                                               dx, dy)
                bend_behind(self.spines, self.specs,
                            handle_frame(*turned_tilt(down.tilt_x, down.tilt_y, stroke.turn),
                                         (down.rotation or 0.0) + stroke.twist), dx, dy)
            made = self._touch_down(stroke, down, pd)
        if self._due(stroke, x, y, sample.t):
            self._solve(stroke, x, y, p, sample)
        # the footprint belongs to the last solved frame, solved at (fx, fy); a stamp
        # on the path shifts it by whole cells ((ex, ey): the pen now, seen from there)
        ex, ey = x - stroke.fx, y - stroke.fy
        dx, dy = x - stroke.x, y - stroke.y
        dist = math.hypot(dx, dy)
        dt = sample.t - stroke.t
        if dt >= MIN_VELOCITY_DT:  # (stamp.py says why)
            stroke.vx, stroke.vy = dx / dt, dy / dt
        elif dist == 0.0:
            stroke.vx = stroke.vy = 0.0
        pos = stroke.to_next
        step = 0.0
        # the tuft slides over the cells between stamps (every SLIDE cells of the
        # segment, with this sample's frame); the next stamp takes them in
        slid = 0.0

        def shift(back: float) -> tuple[int, int]:
            """The frame's shift for a point ``back`` cells behind the sample's."""
            return (-int(round(dy * back / dist - ey)), -int(round(dx * back / dist - ex)))

        def path(a0: float, a1: float) -> list[tuple[tuple[int, int], tuple[int, int]]]:
            """The pen's cells from ``a0`` to ``a1`` cells along this segment, each with
            the frame's shift that lays the tuft there."""
            return [((int(round(stroke.y + dy * a / dist)), int(round(stroke.x + dx * a / dist))),
                     shift(dist - a)) for a in np.arange(a0, a1, SLIDE)]

        while pos <= dist and dist > 0.0:
            back = dist - pos  # along the path back from the sample's point
            maps = self._maps(stroke)
            step = step or self._spacing(maps)
            at = shift(back)
            self._slide(stroke, maps, path(slid, pos - 1e-9))
            self._stamp(stroke, maps, at[0], at[1],
                        stroke.t + (sample.t - stroke.t) * (pos / dist))
            slid = pos + SLIDE
            made += 1
            pos += step
        if dist > 0.0:
            stroke.to_next = pos - dist
            if self.reservoir.fill >= self.tuft_model.film_fill:
                self._slide(stroke, self._maps(stroke), path(slid, dist + 1e-9))
        stroke.x, stroke.y, stroke.t = x, y, sample.t
        return made

    def _slide(self, s: _Stroke, maps: FootprintMaps,
               cells: list[tuple[tuple[int, int], tuple[int, int]]]) -> None:
        """Note where the tuft slid since the last stamp: for each pen cell of ``cells``
        not yet noted, the shift of ``maps`` (this sample's frame) that lays it there. One
        entry a pen cell, the first frame that passed it: a stamp comes every spacing (a
        few cells), so a slow pen with a frame every sample adds nothing new per frame.
        A draining tuft's are not used (:meth:`_stamp`)."""
        if self.reservoir.fill < self.tuft_model.film_fill:
            return
        for cell, sh in cells:
            if cell not in s.slid_cells:
                s.slid_cells.add(cell)
                s.slid.append((maps, sh[0], sh[1]))

    def _touch_down(self, stroke: _Stroke, sample: PenSample, p: float) -> int:
        """The stroke's first frame and stamp, at ``sample`` (its first).

        A tuft pressed straight down buckles one way or the other; a round one's way is
        the solver's symmetry breaker (along the handle's X axis), and a stroke that
        starts any other way drew a hook where the tuft swung round behind the pen. A
        painter's brush is set down moving and bends behind the motion, so a one-spine
        tuft waits for the pen's first move and turns its handle's X axis along it
        (``twist``); a dab lifted where it touched keeps the default."""
        x, y = sample.x * self.width, sample.y * self.height
        self._solve(stroke, x, y, p, sample)
        maps = self._maps(stroke)
        self._stamp(stroke, maps, 0, 0, sample.t)
        stroke.to_next = self._spacing(maps)
        return 1

    def _due(self, s: _Stroke, x: float, y: float, t: float) -> bool:
        """Does this sample need its own spine solve?  Yes when ``frame_interval`` has
        passed since the last one (every sample of a pen at ≤ 250 Hz), when the clock
        went back, or when the pen left the last solved pose by ``frame_reach`` tuft
        lengths; a 1 kHz pen's samples in between move the last tuft along their path."""
        tm = self.tuft_model
        dt = t - s.ft
        if dt >= tm.frame_interval - 1e-9 or dt < 0.0:
            return True
        return math.hypot(x - s.fx, y - s.fy) >= tm.frame_reach * self.tuft_length

    def _solve(self, s: _Stroke, x: float, y: float, p: float, sample: PenSample) -> None:
        s.bristles = self.frame(x, y, p, *turned_tilt(sample.tilt_x, sample.tilt_y, s.turn),
                                (sample.rotation or 0.0) + s.twist)
        s.fx, s.fy, s.ft = x, y, sample.t
        s.maps = None

    def _maps(self, s: _Stroke) -> FootprintMaps:
        """The last solved frame's footprint, rasterised when a stamp first needs it."""
        if s.maps is None:
            assert s.bristles is not None  # every stroke starts with a solve
            s.maps = self.footprint(s.bristles)
            self.last_maps = s.maps
        return s.maps

    def _contact(self, s: _Stroke, maps: FootprintMaps) -> float:
        """Share of a saturating transfer a cell gets while the tuft passes over it.

        The paper drinks from the touching tuft like a capillary, ``∝ √t``
        (Lucas-Washburn); by ``contact_time`` the fibres under the tuft are soaked to
        the film a loaded brush lays.  A cell is under the tuft for the footprint's
        length along the motion over the speed (session seconds)."""
        speed = math.hypot(s.vx, s.vy)
        h, w = maps.cover.shape
        if speed <= 0.0 or self.tuft_model.contact_time <= 0.0:
            return 1.0
        along = (abs(s.vx) * w + abs(s.vy) * h) / speed
        return min(1.0, math.sqrt(along / speed / self.tuft_model.contact_time))

    def _spacing(self, maps: FootprintMaps) -> float:
        h, w = maps.cover.shape
        out: float = max(1.0, self.tuft_model.spacing * 0.5 * max(h, w, 1))
        return out

    def _contact_weight(self, s: _Stroke, maps: FootprintMaps, dy: int, dx: int
                        ) -> tuple[int, int, np.ndarray]:
        """:func:`~station.brush.footprint.weight` of ``maps`` shifted ``(dy, dx)`` on
        the paper, for the tuft's fill now."""
        tm = self.tuft_model
        fill = self.reservoir.fill
        deepest = max(0.0, float(maps.depth.max(initial=0.0)))
        lift: float | np.ndarray
        bead: float | np.ndarray
        if maps.tag is None:
            # the bristles lifted as the tuft dries; the ink a loaded tuft holds wets
            # the tooth below them (cells)
            lift = tm.dry_lift * (1.0 - fill) ** 2 * deepest
            bead = tm.ink_reach * tm.wetness(fill)
        else:
            # the same per bristle, from its own fill: above film_fill the tuft's ink
            # is one body and every bristle has the same share; as it drains below,
            # the liquid splits into locks and the bristle touching each cell (the
            # lowest) keeps ``retention`` times the tuft's share at pendular_fill, so
            # the bristles lose their ink lock by lock and each leaves a streak along
            # the stroke where it stops giving paint
            own = np.minimum(1.0, fill * np.nan_to_num(maps.tag, nan=1.0) ** tm.split(fill))
            lift = tm.dry_lift * (1.0 - own) ** 2 * deepest
            bead = tm.ink_reach * tm.wetness_map(own)
        speed = math.hypot(s.vx, s.vy)
        drag = (s.vx / speed, s.vy / speed) if speed > 0.0 else None
        return weight(maps, self.paper, tm.tooth, tm.ramp, dy, dx, lift, bead, drag=drag,
                      sink=tm.sink, skim=tm.skim)

    def _stamp(self, s: _Stroke, maps: FootprintMaps, dy: int, dx: int, t: float = 0.0
               ) -> None:
        """One stamp of ``maps`` shifted ``(dy, dx)``, with the cells the tuft slid over
        since the previous stamp (``s.slid``: every ``SLIDE`` cells of the pen's path,
        each with the frame of its sample): a hair that touches all along wets a streak,
        not a row of dots a stamp spacing apart; one skimming the tooth still misses the
        valleys it skims."""
        tm = self.tuft_model
        fill = self.reservoir.fill
        groups: dict[int, tuple[FootprintMaps, list[tuple[int, int]]]] = {
            id(maps): (maps, [(dy, dx)])}
        if fill >= tm.film_fill:
            # a loaded tuft's ink is one body sliding on the paper; a draining one's hairs
            # skip over the tooth from stamp to stamp and leave its broken dry end. Each
            # frame's shifts are merged first and met against the paper once.
            for frame, sy, sx in s.slid:
                got = groups.setdefault(id(frame), (frame, []))[1]
                if (sy, sx) not in got:
                    got.append((sy, sx))
        s.slid.clear()
        s.slid_cells.clear()
        parts = [self._contact_weight(s, shifted_union(frame, shifts), 0, 0)
                 for frame, shifts in groups.values()]
        y0, x0, wt = union_max(parts)
        if fill >= tm.film_fill:
            # a loaded tuft's liquid meets the paper along the tooth (its bristles alone,
            # a draining tuft's, touch by the paper's height already), as the round
            # brush's rim
            y0, x0, wt = toothed_rim(y0, x0, wt, self._edge, self.model.tooth_edge)
            # a loaded tuft's water is one body: a lone hair tip's drop joins its
            # neighbours' (surface tension) instead of wetting a one-cell whisker; a
            # draining tuft splits into locks and keeps its hair streaks
            wt = prune_spurs(wt)
        self.stamps += 1
        if wt.size == 0:
            s.previous = None
            return
        eff = wt.astype(np.float64)
        fp = Footprint(y0, x0, eff)
        fresh = fp.without(s.previous)
        s.previous = fp
        dw, dp = self.reservoir.deposit(fresh.cover * self._contact(s, maps),
                                        self.model.water_scale)
        if self.shape.pickup > 0.0 and fresh.cover.any():
            # like the deposit, only the cells the footprint newly covers: a brush
            # sliding over its own wet trail would otherwise soak it back up at
            # every stamp and never run dry
            self.pickups.append(PickupRequest(fresh.y0, fresh.x0,
                                              fresh.cover.astype(np.float32)))
        m = self.model
        scale = m.velocity_gain / self.time_scale if self.time_scale > 0 else 0.0
        vx, vy = s.vx * scale, s.vy * scale
        speed = math.hypot(vx, vy)
        if speed > m.v_max:
            vx, vy = vx * m.v_max / speed, vy * m.v_max / speed
        cover = fresh.cover
        # Stamp carries per-cell amounts as cover × scalar; ours vary per cell, so
        # the amounts ride in the cover array and the scalars are 1.
        tau = painting_steps(t, self.clock)
        self._pending.add(Stamp(Footprint(y0, x0, dw), 1.0, {}, 0.0, 0.0, tau))
        for name, arr in dp.items():
            self._pending.add(Stamp(Footprint(y0, x0, arr), 0.0, {name: 1.0}, 0.0, 0.0, tau))
        if vx or vy:
            self._pending.add(Stamp(Footprint(y0, x0, cover), 0.0, {}, vx, vy, tau))

    # -- output --------------------------------------------------------------------
    def take(self, step: int | None = None) -> Sources | None:
        """As :meth:`RoundBrush.take <station.brush.stamp.RoundBrush.take>`."""
        return self._pending.take(step)

    def take_shares(self, step: int | None = None) -> Taken:
        """As :meth:`RoundBrush.take_shares <station.brush.stamp.RoundBrush.take_shares>`."""
        return self._pending.take_shares(step)

    def take_pickups(self) -> list[PickupRequest]:
        out, self.pickups = self.pickups, []
        return out

    def peek(self) -> Sources | None:
        """The sources :meth:`take` would return, left pending (a live view's preview)."""
        return self._pending.peek()

    @property
    def pending(self) -> int:
        return len(self._pending)

    def pending_box(self, since: int = 0) -> tuple[slice, slice] | None:
        """As :meth:`RoundBrush.pending_box` (the live preview's new cells)."""
        return self._pending.box(since)

    def preview(self, since: int = 0) -> StampPreview | None:
        """As :meth:`RoundBrush.preview`."""
        return self._pending.preview(since)
