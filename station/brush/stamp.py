"""The simple round brush of the dissertation's chapter 5 (issue 3 §6).

A pen stroke becomes a sequence of *stamps*: a circular (elliptical when the
pen is tilted) footprint placed at positions interpolated between pen samples,
spaced a fraction of the radius apart along the path.  Every stamp deposits
water, pigment and a velocity into the cells of its footprint **except** what
the previous stamp already covered (seed figure 5.5), so a stroke fills each
cell it passes over once, however fast the pen moves and however many samples
the device reports: the water put down is proportional to the covered area,
not to the number of samples.

Units and mapping (all decisions written down here):

* Positions: pen ``x, y`` in ``[0, 1]`` map to cell coordinates ``x·W, y·H``;
  cell ``(i, j)`` (row, column) has its centre at ``(j + 0.5, i + 0.5)``.
  The footprint is cell coverage: 1 inside, a one-cell linear ramp on the rim
  (anti-aliased; ``soft_edge=False`` gives the seed's all-or-nothing map of
  the cells whose centres lie inside).  Masking subtracts the previous
  stamp's coverage, so a cell's deposits add up to its largest coverage.
* Radius: ``size`` is the footprint *diameter* in cells at full pressure.
  ``r(p) = size/2 · (r_min + (1 - r_min) · p^radius_gamma)`` for pressure ``p``,
  never below half a cell.
* Load: ``load(p) = load_min + (1 - load_min) · p``.  A stamp adds
  ``water · load · water_scale`` of water height to each of its cells and
  ``amount_k · load · pigment_scale`` of pigment ``k`` (fraction of cell area).
  ``load_min`` is 1: a loaded tuft leaves the same film wherever its hairs touch,
  pressure spreads them (the radius) but does not thin the paint they leave.  With
  ``load_min`` 0.5 the light touch-down of every stroke (a pen sets down at a third of
  its pressure) laid a fifth less water and paint than the stroke's body, and the
  stroke dried with a pale head (issue 21 item 3).
* Velocity: the pen velocity (cells per session second), converted to cells
  per unit of simulation time with ``time_scale`` (simulation time units per
  session second = steps per second × dt), times ``velocity_gain``, clamped to
  ``v_max``; written into every cell of the stamp, times its coverage.
* Tilt: a tilted pen flattens the tuft, so the footprint stretches along the
  tilt direction by ``1 + tilt_stretch · sin(tilt)`` (tilt = magnitude of the
  tilt vector in degrees, the two tilt angles combined as a vector).
* Tools: every tool paints while touching except the eraser, which lifts
  nothing yet (the selective eraser is a later tool): its samples end the
  current stroke and are counted in :attr:`RoundBrush.eraser_samples`.

Everything is pure NumPy in float64 with float32 results, restricted to the
bounding box of the stamps, and deterministic.
"""

from __future__ import annotations

import math
from collections.abc import Container, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from station.brush.bead import BeadRequest
from station.brush.geometry import known_shapes
from station.brush.sources import Footprint as Footprint
from station.brush.sources import Sources as Sources
from station.brush.sources import Stamp as Stamp
from station.brush.sources import StampPreview as StampPreview
from station.brush.sources import StampQueue, Taken, painting_steps
from station.errors import BadInput
from station.events import PenSample, Tool

STAMP_KIND = "round"
# Shortest gap between two samples that gives the pen a velocity [s] (5 kHz, above any
# tablet's report rate). A live sim logs each sample at the time of the step that applied
# it, so a sim that fell behind logs a run of samples at one time and the next one a few
# microseconds later, in the next step's slot: a velocity from that gap was thousands of
# cells a second, and a lift there swept the longest taper the brush has.
MIN_VELOCITY_DT = 2e-4
"""The round stamp brush of chapter 5 (the mouse's brush, and every log made before
the deformable brushes): the kind of the ``brush`` command's default."""


def brush_kinds() -> tuple[str, ...]:
    """``round`` (this module) and the deformable shapes (``station/data/brushes`` and
    any registered with :func:`station.brush.geometry.register_shape`)."""
    return (STAMP_KIND, *known_shapes())
NO_PRESSURE_TOOLS = frozenset({Tool.MOUSE, Tool.FINGER, Tool.LENS})
"""Tools that report no pressure: a touching sample with pressure 0 paints at
:attr:`BrushModel.default_pressure` instead of the thinnest line."""


class BrushError(BadInput):
    """A ``brush`` command has wrong settings (unknown kind or pigment, bad number)."""


@dataclass(frozen=True, slots=True)
class BrushSettings:
    """What the ``brush`` command sets (interfaces.md).

    Attributes:
        kind: ``"round"`` (the stamp brush) or a deformable shape's name
            (``round3d``, ``flat``, ``rigger``, ``fan``, ``mop``, ``calligraphy``).
        size: footprint diameter at full pressure, in cells (> 0).
        water: water load in ``[0, 1]``.
        pigment: pigment name → amount in ``[0, 1]``; empty for clear water.
    """

    kind: str = "round"
    size: float = 24.0
    water: float = 0.8
    pigment: Mapping[str, float] = field(default_factory=dict)

    def scaled(self, factor: float) -> BrushSettings:
        """The same brush with its size multiplied by ``factor`` (canvas resize)."""
        return BrushSettings(self.kind, self.size * factor, self.water, dict(self.pigment))

    def to_args(self) -> dict[str, Any]:
        return {"kind": self.kind, "size": self.size, "water": self.water,
                "pigment": dict(self.pigment)}

    @classmethod
    def from_args(
        cls,
        args: Mapping[str, object],
        where: str | None = None,
        pigments: Container[str] | None = None,
        base: BrushSettings | None = None,
    ) -> BrushSettings:
        """Validate ``brush`` command arguments.

        Missing keys keep the value of ``base`` (the current brush), so
        ``{"size": 8}`` only changes the size.  ``pigments`` holds the palette's
        names (any container with ``in``); an unknown name raises :class:`BrushError`.
        """
        base = base or cls()
        kind = args.get("kind", base.kind)
        kinds = brush_kinds()
        if not isinstance(kind, str) or kind not in kinds:
            raise BrushError(f"unknown brush kind {kind!r} (one of {', '.join(kinds)})",
                             where)
        size = _number(args.get("size", base.size), "brush size", 0.0, 4096.0, where)
        if size <= 0.0:
            raise BrushError(f"brush size {size} must be > 0 cells", where)
        water = _number(args.get("water", base.water), "brush water", 0.0, 1.0, where)
        raw = args.get("pigment", base.pigment)
        if not isinstance(raw, Mapping):
            raise BrushError(f"brush pigment must be an object {{name: amount}}, got {raw!r}",
                             where)
        pig: dict[str, float] = {}
        for name, amount in raw.items():
            if not isinstance(name, str):
                raise BrushError(f"pigment name {name!r} must be a string", where)
            if pigments is not None and name not in pigments:
                raise BrushError(f"unknown pigment {name!r}", where)
            pig[name] = _number(amount, f"amount of {name!r}", 0.0, 1.0, where)
        return cls(kind=kind, size=size, water=water, pigment=pig)


def _number(value: object, name: str, lo: float, hi: float, where: str | None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise BrushError(f"{name} must be a number, got {value!r}", where)
    try:
        v = float(value)
    except OverflowError:  # an integer of hundreds of digits
        raise BrushError(f"{name} of {len(str(value))} digits outside [{lo:g}, {hi:g}]",
                         where) from None
    if not math.isfinite(v) or not lo <= v <= hi:
        raise BrushError(f"{name} {value!r:.40} outside [{lo:g}, {hi:g}]", where)
    return v


@dataclass(frozen=True, slots=True)
class BrushModel:
    """How settings and pen state turn into amounts (see the module docstring).

    Attributes:
        r_min: radius at zero pressure as a fraction of the full radius.
        radius_gamma: exponent of the pressure → radius curve.
        load_min: load at zero pressure (fraction of the full load); 1: pressure
            changes the footprint, not the film it leaves (see the module docstring).
        water_scale: water height added per cell by a full-load stamp, cell units.
        pigment_scale: pigment (fraction of cell area) added per cell by a
            full-load stamp of amount 1.
        velocity_gain: fraction of the pen velocity given to the paint.
        v_max: largest velocity source, cells per unit of simulation time.
        spacing: stamp spacing as a fraction of the radius.
        tilt_stretch: footprint elongation per sin(tilt).
        default_pressure: pressure used for tools that report none.
        soft_edge: anti-aliased footprint rim (fractional coverage) instead of
            the seed's all-or-nothing cell map.
        tooth_edge: how far the paper's tooth moves the footprint's rim [cells]: a rim
            cell on a paper hill (normalised height +1) is reached ``tooth_edge`` cells
            beyond the circle, one in a valley that much short of it, so a stroke's edge
            follows the paper's grain instead of a ruler (0: a geometric circle).
        dry_water: water load below which a fast stroke skips over the paper [1]: the
            tuft holds too little liquid to fill the valleys between its hairs' marks.
        dry_speed: pen speed at which a brush with no water skips most, in brush
            diameters per session second (a quick drag); slower strokes skip less.
        dry_bare: the share of the stamp a fully dry, fast brush leaves bare [1].
        streak_width: correlation length of the hair clumps across the stroke [cells]:
            the dry-brush marks are streaks along the stroke, this wide.
        tail_time: how long the tuft keeps sweeping after a pen lifted while moving
            [session s]: its tail is ``speed * tail_time`` long (at most ``tail_max``
            brush radii), narrowing to the tip, so a flick ends in a taper.
        tail_max: the longest tail in brush radii.
        bead: the liquid a loaded tuft lets go where its tip touches down in standing
            water, in touch-down stamps' worth of water, at the paint's concentration
            (:mod:`station.brush.bead`; 0: none). A round brush holds several stamps of
            paint; dry paper takes one stamp's worth, a wet wash draws on the tuft.
    """

    r_min: float = 0.3
    radius_gamma: float = 1.0
    load_min: float = 1.0
    water_scale: float = 0.5
    pigment_scale: float = 0.1
    velocity_gain: float = 0.1
    v_max: float = 2.0
    spacing: float = 0.25
    tilt_stretch: float = 0.5
    default_pressure: float = 0.6
    soft_edge: bool = True
    tooth_edge: float = 1.2
    dry_water: float = 0.4
    dry_speed: float = 10.0
    dry_bare: float = 0.55
    streak_width: float = 1.2
    tail_time: float = 0.05
    tail_max: float = 4.0
    bead: float = 2.0

    def radius(self, size: float, pressure: float) -> float:
        """Footprint radius in cells for a brush of diameter ``size`` at ``pressure``."""
        frac = self.r_min + (1.0 - self.r_min) * pressure**self.radius_gamma
        out: float = max(0.5, 0.5 * size * frac)
        return out

    def load(self, pressure: float) -> float:
        return self.load_min + (1.0 - self.load_min) * pressure


def footprint(
    cx: float, cy: float, radius: float, width: int, height: int,
    stretch: float = 1.0, angle: float = 0.0, soft: bool = False,
    tooth: np.ndarray | None = None, tooth_reach: float = 0.0,
) -> Footprint:
    """The ellipse at ``(cx, cy)`` (cell units) as cell coverage.

    ``radius`` is the semi-axis across, ``radius·stretch`` the semi-axis along
    direction ``angle`` (radians, x right, y down).  Hard: cells whose centres
    lie inside get 1 (the seed's cell map).  Soft: coverage falls linearly
    from 1 to 0 over the cell straddling the rim (``clip(r - d + 1/2, 0, 1)``
    for a disc, ``d`` the centre distance), so the area is ``πr²`` without
    a staircase edge.  Clipped to the canvas; empty when outside.

    ``tooth`` (float (height, width) in [-1, 1]) moves the rim cell by cell by up to
    ``tooth_reach`` cells: the distance inside the rim becomes
    ``(1 - rho) r + tooth_reach * tooth``, so the edge runs along the paper's hills and
    valleys; the interior stays covered.
    """
    reach = radius * max(1.0, stretch) + (1.0 if soft else 0.0) + max(0.0, tooth_reach)
    x0 = max(0, int(math.floor(cx - reach)))
    x1 = min(width, int(math.ceil(cx + reach)) + 1)
    y0 = max(0, int(math.floor(cy - reach)))
    y1 = min(height, int(math.ceil(cy + reach)) + 1)
    if x0 >= x1 or y0 >= y1:
        return Footprint(0, 0, np.zeros((0, 0), dtype=np.float64))
    dx = (np.arange(x0, x1, dtype=np.float64) + 0.5 - cx)[None, :]
    dy = (np.arange(y0, y1, dtype=np.float64) + 0.5 - cy)[:, None]
    if stretch == 1.0:
        rho = np.sqrt(dx * dx + dy * dy) / radius  # centre distance in radii
    else:
        c, s = math.cos(angle), math.sin(angle)
        along = (dx * c + dy * s) / (radius * stretch)
        across = (-dx * s + dy * c) / radius
        rho = np.sqrt(along * along + across * across)
    inside = (1.0 - rho) * radius  # cells inside the rim (negative outside)
    if tooth is not None:
        inside = inside + tooth_reach * tooth[y0:y1, x0:x1]
    if soft:
        cover = np.clip(inside + 0.5, 0.0, 1.0)
    elif tooth is not None:
        cover = (inside >= 0.0).astype(np.float64)
    else:
        cover = (rho <= 1.0).astype(np.float64)
    return Footprint(y0, x0, cover)


_MAPS: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
"""The last paper's maps (paper, grain, edge): a player swapping brush kinds hands the same
height field again, and its two maps cost tens of milliseconds at 800x600."""


def paper_maps(paper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The paper's grain (height normalised to [-1, 1] over two standard deviations) and
    the edge map (the grain seen over a couple of cells, a 5x5 binomial blur, renormalised):
    the wet edge follows the tooth's bumps, not single fibre tips. float32."""
    if _MAPS and _MAPS[0][0] is paper:
        return _MAPS[0][1], _MAPS[0][2]
    h = np.asarray(paper, np.float64)
    sd = float(h.std())
    grain = np.clip((h - float(h.mean())) / (2.0 * sd), -1.0, 1.0) if sd > 0 else 0.0 * h
    g = grain
    for _ in range(2):
        g = np.pad(g, 1, mode="edge")
        g = (g[:-2] + 2.0 * g[1:-1] + g[2:]) / 4.0
        g = (g[:, :-2] + 2.0 * g[:, 1:-1] + g[:, 2:]) / 4.0
    gs = float(g.std())
    edge = np.clip((g - float(g.mean())) / (2.0 * gs), -1.0, 1.0) if gs > 0 else g
    maps = grain.astype(np.float32), edge.astype(np.float32)
    _MAPS[:] = [(paper, *maps)]
    return maps


DRY_ALONG = 3
"""Cells each way along the motion over which a dragged hair's contact with the tooth is
averaged (:meth:`RoundBrush._dry_gate`)."""


def _bilinear(a: np.ndarray, ys: np.ndarray, xs: np.ndarray) -> np.ndarray:
    """``a`` (H, W) at fractional cell positions (float64), clamped to the canvas."""
    h, w = a.shape
    ys = np.clip(ys, 0.0, h - 1.0)
    xs = np.clip(xs, 0.0, w - 1.0)
    y0 = np.minimum(ys.astype(np.int64), max(h - 2, 0))
    x0 = np.minimum(xs.astype(np.int64), max(w - 2, 0))
    y1, x1 = np.minimum(y0 + 1, h - 1), np.minimum(x0 + 1, w - 1)
    fy, fx = ys - y0, xs - x0
    top = (1.0 - fx) * a[y0, x0] + fx * a[y0, x1]
    bottom = (1.0 - fx) * a[y1, x0] + fx * a[y1, x1]
    out: np.ndarray = (1.0 - fy) * top + fy * bottom
    return out


@dataclass(slots=True)
class _Stroke:
    """The running stroke of one device."""

    x: float  # cells
    y: float
    t: float  # session seconds
    pressure: float
    tilt_x: float
    tilt_y: float
    vx: float = 0.0  # cells per session second
    vy: float = 0.0
    timed: bool = False  # vx, vy come from two samples at least MIN_VELOCITY_DT apart
    to_next: float = 0.0  # path length (cells) until the next stamp
    previous: Footprint | None = None
    streak: np.ndarray | None = None  # hair clumps across the stroke (dry brush)


class RoundBrush:
    """Turns pen samples into stamps on a ``width × height`` canvas.

    ``time_scale`` is simulation time per session second (steps per second ×
    dt), used to express the pen velocity in the simulation's units.  Feed
    samples with :meth:`feed` (in time order per device) and collect the
    pending sources with :meth:`take`.
    """

    def __init__(
        self,
        width: int,
        height: int,
        settings: BrushSettings | None = None,
        model: BrushModel | None = None,
        time_scale: float = 1.0,
        paper: np.ndarray | None = None,
    ) -> None:
        if width < 1 or height < 1:
            raise BadInput(f"canvas {width}x{height} has no cells")
        self.width, self.height = width, height
        self.settings = settings or BrushSettings()
        self.model = model or BrushModel()
        self.time_scale = time_scale
        # The paper's tooth, normalised: +1 on its hills, -1 in its valleys (about two
        # standard deviations), so the brush's response does not depend on the preset's
        # height range. None: a smooth sheet (geometric footprints, no dry-brush grain).
        self._grain: np.ndarray | None = None
        self._edge: np.ndarray | None = None
        if paper is not None:
            if paper.shape != (height, width):
                raise BadInput("paper height does not match the canvas")
            self._grain, self._edge = paper_maps(paper)
        self._strokes: dict[str, _Stroke] = {}
        self._pending = StampQueue()
        self._beads: list[BeadRequest] = []  # touch-downs whose bead the canvas decides
        # the tuft still carries the bead of its last dip (a checkpoint keeps it)
        self.bead_ready = True
        # (steps per session second, seconds waited): puts each stamp's time on the
        # simulation's step clock (see station.brush.sources); None: whole at the next step
        self.clock: tuple[float, float] | None = None
        self.stamps = 0  # stamps applied (including fully masked ones)
        self.samples = 0  # touching samples that painted
        self.eraser_samples = 0  # eraser samples (no paint yet)
        self.strokes = 0

    # -- settings ------------------------------------------------------------
    def set(self, settings: BrushSettings) -> None:
        """Change the brush (a ``brush`` command dips it: a fresh bead on its tip); a
        running stroke continues with the new paint."""
        self.settings = settings
        self.bead_ready = True

    def end_strokes(self) -> None:
        """Lift every pen (e.g. before ``dry``/``clear``): the next stamp is a fresh start."""
        self._strokes.clear()

    # -- input ---------------------------------------------------------------
    def feed(self, sample: PenSample) -> int:
        """Apply one pen sample; returns the number of stamps it produced."""
        key = sample.device
        if sample.tool is Tool.ERASER:
            self.eraser_samples += 1
            self._strokes.pop(key, None)
            return 0
        if not (sample.touching and sample.proximity):
            ended = self._strokes.pop(key, None)
            return self._tail(ended) if ended is not None else 0
        self.samples += 1
        pressure = sample.pressure
        if pressure == 0.0 and sample.tool in NO_PRESSURE_TOOLS:
            pressure = self.model.default_pressure
        x, y = sample.x * self.width, sample.y * self.height
        stroke = self._strokes.get(key)
        if stroke is None:
            self.strokes += 1
            stroke = _Stroke(x, y, sample.t, pressure, sample.tilt_x, sample.tilt_y)
            self._strokes[key] = stroke
            self._stamp(stroke, x, y, pressure, sample.tilt_x, sample.tilt_y, t=sample.t)
            return 1
        return self._segment(stroke, x, y, sample.t, pressure, sample.tilt_x, sample.tilt_y)

    def _segment(
        self, s: _Stroke, x: float, y: float, t: float, p: float, tx: float, ty: float
    ) -> int:
        dx, dy = x - s.x, y - s.y
        dist = math.hypot(dx, dy)
        dt = t - s.t
        if dt >= MIN_VELOCITY_DT:
            s.vx, s.vy = dx / dt, dy / dt
            s.timed = True
        elif dist == 0.0:
            s.vx = s.vy = 0.0
        # else: same timestamp, moved: keep the last known velocity
        made = 0
        pos = s.to_next
        p0, tx0, ty0 = s.pressure, s.tilt_x, s.tilt_y
        while pos <= dist and dist > 0.0:
            f = pos / dist
            pf = p0 + (p - p0) * f
            self._stamp(s, s.x + dx * f, s.y + dy * f, pf, tx0 + (tx - tx0) * f,
                        ty0 + (ty - ty0) * f, advance=False, t=s.t + (t - s.t) * f)
            made += 1
            pos += self._spacing(pf)
        s.to_next = pos - dist if dist > 0.0 else s.to_next
        s.x, s.y, s.t, s.pressure, s.tilt_x, s.tilt_y = x, y, t, p, tx, ty
        return made

    def _spacing(self, pressure: float) -> float:
        r = self.model.radius(self.settings.size, pressure)
        return max(0.5, self.model.spacing * r)

    def _tail(self, s: _Stroke) -> int:
        """Stamps of the tuft sweeping on after a pen lifted while moving.

        The hairs leave the paper one after the other: the tip drags on for
        ``speed * tail_time`` (at most ``tail_max`` radii of the last stamp), narrowing
        from the last stamp's radius to nothing, so a flick ends in a point whose length
        follows the speed and whose width follows the last pressure. A pen lifted at
        rest leaves its round dab.
        """
        m = self.model
        speed = math.hypot(s.vx, s.vy)
        r0 = m.radius(self.settings.size, s.pressure)
        length = min(speed * m.tail_time, m.tail_max * r0)
        if length < 1.0 or speed <= 0.0:
            return 0
        ux, uy = s.vx / speed, s.vy / speed
        made = 0
        pos = s.to_next
        while pos < length:
            f = pos / length
            r = max(0.5, r0 * (1.0 - f))
            # the last hairs carry less water but the same paint: a thin dark point
            self._stamp(s, s.x + ux * pos, s.y + uy * pos, s.pressure, s.tilt_x, s.tilt_y,
                        advance=False, radius=r, water_share=1.0 - 0.5 * f, t=s.t)
            made += 1
            pos += max(0.5, m.spacing * r)
        return made

    def _skip(self, s: _Stroke) -> float:
        """How much a stroke skips over the paper, 0 (fills it) ... 1 (driest, fastest)."""
        m = self.model
        if self._grain is None or m.dry_water <= 0.0 or m.dry_bare <= 0.0:
            return 0.0
        dry = (m.dry_water - self.settings.water) / m.dry_water
        if dry <= 0.0:
            return 0.0
        diam = max(1.0, self.settings.size)
        if s.previous is None or not s.timed:
            # touch-down, or moving on samples logged at one time (a live sim behind its
            # pen logs a run of them in one step's slot): the pen's speed is not known
            # yet; a dry tuft set down on the paper meets only its hills (a round, filled
            # blob would start every streak; the kiosk's dry strokes started solid for a
            # third of their length when the sim was busy as the pen went down)
            return math.sqrt(min(1.0, dry))
        fast = math.hypot(s.vx, s.vy) / diam / m.dry_speed if m.dry_speed > 0 else 1.0
        # the first loss of water shows most: a half-loaded tuft already skips
        return math.sqrt(min(1.0, dry)) * min(1.0, fast)

    def _streaks(self, s: _Stroke, radius: float) -> np.ndarray:
        """The stroke's hair clumps: smooth unit-variance noise across the stroke,
        sampled every quarter cell over ``[-reach, reach]`` (deterministic per stroke)."""
        reach = radius + self.model.tooth_edge + 2.0
        n = int(math.ceil(2.0 * reach * 4.0)) + 1
        if s.streak is None or len(s.streak) < n:
            rng = np.random.default_rng((self.strokes, 0x0B2157))
            sig = max(0.25, self.model.streak_width) * 4.0  # in quarter cells
            k = np.arange(-int(3 * sig), int(3 * sig) + 1, dtype=np.float64)
            g = np.exp(-0.5 * (k / sig) ** 2)
            noise = np.convolve(rng.standard_normal(n + len(k)), g, mode="same")[:n]
            sd = float(noise.std())
            s.streak = noise / sd if sd > 0 else noise
        return s.streak

    def _dry_gate(self, s: _Stroke, fp: Footprint, x: float, y: float, radius: float,
                  skip: float) -> Footprint:
        """The footprint where a skipping tuft touches: its hair clumps (streaks along the
        stroke) and the paper's hills take the paint, the valleys between stay bare; the
        share of the stamp left bare is ``dry_bare * skip``.

        A dragged hair rides over the tooth: it touches where the paper stays high over a
        few cells of its path (:data:`DRY_ALONG` each way along the motion), not cell by
        cell, so the bare paper between its marks is drawn out along the stroke; the
        paper's own hills and the clumps across the stroke take the rest.  Scored on the
        paper alone, the gaps were round holes a few cells wide (a sponge's print, not a
        dry brush's: the round brush's dry strokes measured along/across correlation 1-3
        at brush sizes 12-20, now 3-4)."""
        m = self.model
        grain = self._grain
        speed = math.hypot(s.vx, s.vy)
        if grain is None or not fp.cover.size:
            return fp
        inside = fp.cover > 0.5
        if not inside.any():
            return fp
        # across the motion; a touch-down (no motion yet) takes the hairs as lying along x
        c, sn = (s.vx / speed, s.vy / speed) if speed > 0.0 else (1.0, 0.0)
        cols = np.arange(fp.x0, fp.x1, dtype=np.float64)[None, :]
        rows = np.arange(fp.y0, fp.y1, dtype=np.float64)[:, None]
        across = -(cols + 0.5 - x) * sn + (rows + 0.5 - y) * c
        prof = self._streaks(s, radius)
        half = (len(prof) - 1) / 8.0
        clump = np.interp(across, np.linspace(-half, half, len(prof)), prof)
        here = grain[fp.y0:fp.y1, fp.x0:fp.x1].astype(np.float64)
        ys, xs = np.broadcast_arrays(rows, cols)
        along = here.copy()
        for d in range(1, DRY_ALONG + 1):
            along += _bilinear(grain, ys - d * sn, xs - d * c)
            along += _bilinear(grain, ys + d * sn, xs + d * c)
        along /= 2 * DRY_ALONG + 1
        score = 0.5 * clump + 0.45 * here + 0.8 * along
        vals = score[inside]
        bare = min(0.95, m.dry_bare * skip)
        thr = float(np.quantile(vals, bare))
        ramp = 0.15 * (float(vals.std()) or 1.0)
        gate = np.clip((score - thr) / ramp + 0.5, 0.0, 1.0)
        return Footprint(fp.y0, fp.x0, fp.cover * gate)

    def _stamp(
        self, s: _Stroke, x: float, y: float, p: float, tx: float, ty: float,
        advance: bool = True, radius: float | None = None, water_share: float = 1.0,
        t: float = 0.0,
    ) -> None:
        m = self.model
        r = m.radius(self.settings.size, p) if radius is None else radius
        tilt = min(90.0, math.hypot(tx, ty))
        stretch = 1.0 + m.tilt_stretch * math.sin(math.radians(tilt))
        angle = math.atan2(ty, tx) if tilt > 0.0 else 0.0
        tooth = None
        reach = 0.0
        if self._edge is not None and m.tooth_edge > 0.0:
            # a thin tip cannot wander farther than it is wide
            reach = m.tooth_edge * min(1.0, r / 4.0)
            tooth = self._edge
        fp = footprint(x, y, r, self.width, self.height, stretch, angle, soft=m.soft_edge,
                       tooth=tooth, tooth_reach=reach)
        skip = self._skip(s)
        thick = 1.0
        if skip > 0.0:
            full = fp.area
            fp = self._dry_gate(s, fp, x, y, r, skip)
            # the tuft's paint goes where its hairs touch: thick paint, little water
            thick = min(2.0, full / fp.area) if fp.area > 0 else 1.0
        touch_down = s.previous is None
        fresh = fp.without(s.previous)
        s.previous = fp
        if advance:
            s.to_next = self._spacing(p)
        self.stamps += 1
        load = m.load(p)
        scale = m.velocity_gain / self.time_scale if self.time_scale > 0 else 0.0
        vx, vy = s.vx * scale, s.vy * scale
        speed = math.hypot(vx, vy)
        if speed > m.v_max:
            vx, vy = vx * m.v_max / speed, vy * m.v_max / speed
        stg = self.settings
        water = stg.water * load * m.water_scale * water_share
        pigment = {k: a * load * m.pigment_scale * thick for k, a in stg.pigment.items()}
        tau = painting_steps(t, self.clock)
        self._pending.add(Stamp(cells=fresh, water=water, pigment=pigment, vx=vx, vy=vy,
                                tau=tau))
        if touch_down and self.bead_ready:
            # the first touch-down after a dip lets the bead go: into a film it runs out
            # (the canvas decides, station.brush.bead); on paper without one the stroke
            # spends it, and its stamps are all the paper takes
            self.bead_ready = False
            if m.bead > 0.0 and water > 0.0 and fresh.area > 0.0:
                self._beads.append(BeadRequest(
                    x, y, r, m.bead * water * fresh.area,
                    {k: a / water for k, a in pigment.items() if a > 0.0}, water, tau))

    # -- output --------------------------------------------------------------
    def take(self, step: int | None = None) -> Sources | None:
        """The stamps' sources due before step ``step`` (each spread over the steps around
        its time, :class:`~station.brush.sources.StampQueue`), summed; ``None``: all that
        is left. ``None`` if there is nothing."""
        return self._pending.take(step)

    def take_shares(self, step: int | None = None) -> Taken:
        """:meth:`take` not yet summed (:meth:`Taken.sources
        <station.brush.sources.Taken.sources>` sums them)."""
        return self._pending.take_shares(step)

    def peek(self) -> Sources | None:
        """All the sources still pending, left pending (a live view's preview)."""
        return self._pending.peek()

    def take_beads(self, step: int | None = None) -> list[BeadRequest]:
        """The touch-downs whose bead the canvas decides (:mod:`station.brush.bead`; the
        session player releases them): those due before step ``step`` (their stamp's
        first share goes in then), all of them when ``None``."""
        if step is None:
            beads, self._beads = self._beads, []
            return beads
        beads = [b for b in self._beads if b.due(step)]
        self._beads = [b for b in self._beads if not b.due(step)]
        return beads

    @property
    def pending(self) -> int:
        """Stamps not yet wholly in the canvas."""
        return len(self._pending)

    def pending_box(self, since: int = 0) -> tuple[slice, slice] | None:
        """Canvas cells (rows, columns) covered by the pending stamps from the
        ``since``-th on (what a live preview must redraw since it last showed ``since``
        of them); ``None`` if there are none."""
        return self._pending.box(since)

    def preview(self, since: int = 0) -> StampPreview | None:
        """The stamps not yet taken by a step, for a live view (``since``: how many of
        them it already shows; ``None``: none pending)."""
        return self._pending.preview(since)

    @property
    def drawing(self) -> bool:
        """A stroke is in progress (some device's pen is down)."""
        return bool(self._strokes)
