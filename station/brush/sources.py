"""What a brush hands the canvas: stamps, their summed sources, and the queue that spreads
each stamp's deposit over the simulation steps by the time it was laid (issue 21 item 8).

A step ``j`` covers painting time ``[j, j + 1)`` (in steps); the sources a step receives are
added at its start.  A stamp laid at ``tau = j + f`` therefore arrives ``f`` of a step early
if it all lands before step ``j``: on a fast stroke every step's stretch of stroke would be
laid at once, and the wet front would stand still for a whole step at the end of each
stretch, leaving an arc or a scallop there, one per step.  The queue splits the deposit as a
linear interpolation in time between the two step starts around ``tau``: ``1 - f`` before
step ``j`` and ``f`` before step ``j + 1`` (:func:`due_share`), so along a stroke the front
moves on every step as a ramp, not a jump.  The share is a function of the stamp's painting
time and the step index alone, never of when the host happens to flush, so a live session
and a replay of its log give the same sources step by step.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class Footprint:
    """Cell coverage in ``[0, 1]`` placed at row ``y0``, column ``x0`` of the canvas.

    1 is a cell wholly under the brush, 0 a cell outside; a soft-edged
    footprint has fractions on its rim (an anti-aliased disc).
    """

    y0: int
    x0: int
    cover: np.ndarray  # float64 (h, w)

    @property
    def y1(self) -> int:
        out: int = self.y0 + self.cover.shape[0]
        return out

    @property
    def x1(self) -> int:
        out: int = self.x0 + self.cover.shape[1]
        return out

    @property
    def mask(self) -> np.ndarray:
        """Cells touched at all (bool)."""
        return self.cover > 0.0

    @property
    def cells(self) -> int:
        return int(self.mask.sum())

    @property
    def area(self) -> float:
        """Covered area in cells (sum of the coverage)."""
        return float(self.cover.sum())

    def without(self, other: Footprint | None) -> Footprint:
        """This footprint minus what ``other`` already covered (seed figure 5.5).

        Per cell ``max(0, cover - other.cover)``: a cell the previous stamp
        covered fully gets nothing, a rim cell gets only the coverage it gains.
        Along a stroke a cell's coverage rises then falls, so the increments
        add up to its largest coverage: each cell is filled once.
        """
        if other is None:
            return self
        ya, yb = max(self.y0, other.y0), min(self.y1, other.y1)
        xa, xb = max(self.x0, other.x0), min(self.x1, other.x1)
        if ya >= yb or xa >= xb:
            return self
        cover = self.cover.copy()
        mine = cover[ya - self.y0:yb - self.y0, xa - self.x0:xb - self.x0]
        theirs = other.cover[ya - other.y0:yb - other.y0, xa - other.x0:xb - other.x0]
        np.maximum(mine - theirs, 0.0, out=mine)
        return Footprint(self.y0, self.x0, cover)


@dataclass(frozen=True, slots=True)
class Stamp:
    """One application of the footprint: its new cells and what they receive.

    ``water`` and ``pigment`` are per-cell amounts; ``vx, vy`` the velocity
    source in cells per unit of simulation time.  ``tau`` is the painting time the
    stamp was laid at, in steps (step ``j`` runs over ``[j, j + 1)``); ``-inf``: all of
    it goes in before the next step (a brush without a clock).
    """

    cells: Footprint
    water: float
    pigment: Mapping[str, float]
    vx: float
    vy: float
    tau: float = -math.inf


@dataclass(slots=True)
class Sources:
    """Brush sources restricted to a bounding box, ready for ``add_sources``.

    Arrays are float32 of shape ``(h, w)`` placed at row ``y0``, column ``x0``
    of the canvas; :meth:`full` expands them to the whole canvas.
    """

    y0: int
    x0: int
    dw: np.ndarray
    dp: dict[str, np.ndarray]
    dvx: np.ndarray
    dvy: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        return self.dw.shape

    @property
    def region(self) -> tuple[slice, slice]:
        h, w = self.dw.shape
        return (slice(self.y0, self.y0 + h), slice(self.x0, self.x0 + w))

    def full(self, width: int, height: int) -> Sources:
        """The same sources as whole-canvas arrays (for backends without regions)."""
        def grow(a: np.ndarray) -> np.ndarray:
            out = np.zeros((height, width), dtype=np.float32)
            out[self.region] = a
            return out

        return Sources(0, 0, grow(self.dw), {k: grow(v) for k, v in self.dp.items()},
                       grow(self.dvx), grow(self.dvy))


def stamps_box(stamps: Iterable[Stamp]) -> tuple[slice, slice] | None:
    """Canvas cells (rows, columns) the stamps cover together; ``None`` if none."""
    used = [s for s in stamps if s.cells.mask.size]
    if not used:
        return None
    return (slice(min(s.cells.y0 for s in used), max(s.cells.y1 for s in used)),
            slice(min(s.cells.x0 for s in used), max(s.cells.x1 for s in used)))


def _counts(s: Stamp, k: float) -> bool:
    """Whether stamp ``s`` at share ``k`` adds anything to a sum (:func:`accumulate`)."""
    return k > 0.0 and bool(s.cells.mask.size) and bool(s.cells.mask.any())


class _Sum:
    """A float64 sum of stamps over the box ``[y0, y1) x [x0, x1)``, held in arrays of
    ``capacity`` (a larger box, so a growing box rarely copies).  Each cell adds its
    stamps' terms in the order they are added, as :func:`accumulate` does, so the sum is
    bitwise what :func:`accumulate` gives for the same stamps and shares (a cell outside a
    stamp's footprint is not touched by it, here and there)."""

    def __init__(self, y0: int, x0: int, y1: int, x1: int, margin: int = 0) -> None:
        self.y0, self.x0, self.y1, self.x1 = y0, x0, y1, x1
        self._alloc(y0 - margin, x0 - margin, y1 + margin, x1 + margin)

    def _alloc(self, cy0: int, cx0: int, cy1: int, cx1: int) -> None:
        self.cy0, self.cx0 = cy0, cx0
        shape = (cy1 - cy0, cx1 - cx0)
        self.dw = np.zeros(shape, dtype=np.float64)
        self.dvx = np.zeros(shape, dtype=np.float64)
        self.dvy = np.zeros(shape, dtype=np.float64)
        self.dp: dict[str, np.ndarray] = {}

    def _grow(self, fp: Footprint) -> None:
        """Make room for ``fp``: the arrays are copied into larger zero ones (exact)."""
        cy1 = self.cy0 + self.dw.shape[0]
        cx1 = self.cx0 + self.dw.shape[1]
        if fp.y0 >= self.cy0 and fp.x0 >= self.cx0 and fp.y1 <= cy1 and fp.x1 <= cx1:
            return
        # a margin of half the box each side: a stroke that moves on copies O(log) times
        my = max(16, (max(cy1, fp.y1) - min(self.cy0, fp.y0)) // 2)
        mx = max(16, (max(cx1, fp.x1) - min(self.cx0, fp.x0)) // 2)
        ny0 = min(self.cy0, fp.y0 - my) if fp.y0 < self.cy0 else self.cy0
        nx0 = min(self.cx0, fp.x0 - mx) if fp.x0 < self.cx0 else self.cx0
        ny1 = max(cy1, fp.y1 + my) if fp.y1 > cy1 else cy1
        nx1 = max(cx1, fp.x1 + mx) if fp.x1 > cx1 else cx1
        old = (self.cy0, self.cx0, self.dw, self.dvx, self.dvy, self.dp)
        self._alloc(ny0, nx0, ny1, nx1)
        oy, ox, dw, dvx, dvy, dp = old
        sl = (slice(oy - ny0, oy - ny0 + dw.shape[0]), slice(ox - nx0, ox - nx0 + dw.shape[1]))
        self.dw[sl] = dw
        self.dvx[sl] = dvx
        self.dvy[sl] = dvy
        for name, a in dp.items():
            self.dp[name] = np.zeros_like(self.dw)
            self.dp[name][sl] = a

    def add(self, s: Stamp, k: float) -> None:
        """Add ``k`` of stamp ``s`` (one that :func:`_counts`)."""
        fp = s.cells
        self._grow(fp)
        self.y0, self.x0 = min(self.y0, fp.y0), min(self.x0, fp.x0)
        self.y1, self.x1 = max(self.y1, fp.y1), max(self.x1, fp.x1)
        sl = (slice(fp.y0 - self.cy0, fp.y1 - self.cy0), slice(fp.x0 - self.cx0, fp.x1 - self.cx0))
        m = fp.cover
        self.dw[sl] += m * (s.water * k)
        self.dvx[sl] += m * (s.vx * k)
        self.dvy[sl] += m * (s.vy * k)
        for name, amount in s.pigment.items():
            if amount <= 0.0:
                continue
            if name not in self.dp:
                self.dp[name] = np.zeros_like(self.dw)
            self.dp[name][sl] += m * (amount * k)

    def sources(self) -> Sources:
        """The sum over its box, as float32 :class:`Sources`."""
        sl = (slice(self.y0 - self.cy0, self.y1 - self.cy0),
              slice(self.x0 - self.cx0, self.x1 - self.cx0))
        f32 = np.float32
        return Sources(self.y0, self.x0, self.dw[sl].astype(f32),
                       {k: v[sl].astype(f32) for k, v in self.dp.items()},
                       self.dvx[sl].astype(f32), self.dvy[sl].astype(f32))


def _sum(stamps: Iterable[Stamp], shares: Sequence[float] | None) -> _Sum | None:
    pairs = [(s, 1.0 if shares is None else shares[i]) for i, s in enumerate(stamps)]
    pairs = [(s, k) for s, k in pairs if _counts(s, k)]
    if not pairs:
        return None
    total = _Sum(min(s.cells.y0 for s, _ in pairs), min(s.cells.x0 for s, _ in pairs),
                 max(s.cells.y1 for s, _ in pairs), max(s.cells.x1 for s, _ in pairs))
    for s, k in pairs:
        total.add(s, k)
    return total


def accumulate(stamps: Iterable[Stamp], shares: Sequence[float] | None = None
               ) -> Sources | None:
    """Sum stamps into one bounding-box :class:`Sources` (``None`` if nothing).

    Along a stroke each stamp holds only what its predecessor did not cover;
    a stroke that comes back over itself re-wets, so overlapping stamps add.
    ``shares``: the part of each stamp to sum (all of each when ``None``).
    """
    total = _sum(stamps, shares)
    return None if total is None else total.sources()


@dataclass(frozen=True)
class Taken:
    """Stamps a step took from a :class:`StampQueue` and the part of each it took, not yet
    summed: the stamps are immutable and the lists the queue's no more, so the sum
    (:meth:`sources`) may run while the queue takes new stamps."""

    stamps: list[Stamp]
    shares: list[float]

    def sources(self) -> Sources | None:
        """The sum (:func:`accumulate`), ``None`` if nothing is due."""
        return accumulate(self.stamps, self.shares)


@dataclass(frozen=True)
class StampPreview:
    """What a live view shows of the stamps a brush made since the last step (the
    kiosk draws them over the simulated canvas until a step takes them)."""

    sources: Sources  # every pending stamp's water and pigment, summed (as take() sums)
    count: int  # pending stamps
    # canvas cells (rows, columns) covered by the stamps from the asked ``since``-th on;
    # ``None`` if those are all masked or there are none
    new_cells: tuple[slice, slice] | None


def preview_of(pending: list[Stamp], since: int, shares: Sequence[float] | None = None
               ) -> StampPreview | None:
    """:class:`StampPreview` of ``pending`` (``None``: nothing to show)."""
    src = accumulate(list(pending), shares)
    if src is None:
        return None
    return StampPreview(src, len(pending), stamps_box(pending[since:]))


def due_share(tau: float, step: int) -> float:
    """The part of a stamp laid at painting time ``tau`` [steps] due in the canvas before
    step ``step`` runs: 0 before the step that follows it, ``1 - f`` before step ``j``
    for ``tau = j + f``, all of it from step ``j + 1`` on."""
    return min(1.0, max(0.0, step + 1.0 - tau))


def painting_steps(t: float, clock: tuple[float, float] | None) -> float:
    """Session time ``t`` [s] in painting steps, by ``clock = (rate [steps/s], waited [s])``
    (``-inf`` without a clock: due at the next step)."""
    if clock is None:
        return -math.inf
    rate, waited = clock
    return (t + waited) * rate


class StampQueue:
    """A brush's stamps not yet (wholly) in the canvas, and how much of each is.

    The pending stamps' sum (what :meth:`peek` and :meth:`preview` show, asked every frame
    by a live view) is kept as a running sum: a new stamp adds its own cells to it, and only
    a :meth:`take` (a step, which changes the shares left) has it summed again, once, on the
    next ask.  While the sim lags behind the pen thousands of stamps can be pending, and
    summing them all again for each new stamp cost up to 60 ms a frame.  Between takes the
    running sum adds each new stamp last, as :func:`accumulate` does, so it is bitwise the
    sum of everything left."""

    def __init__(self) -> None:
        self.stamps: list[Stamp] = []
        self.given: list[float] = []  # the part of each already handed out
        self._left: _Sum | None = None  # the running sum of what is left (when valid)
        self._valid = True  # False after a take: summed again on the next ask
        self._shown: Sources | None = None  # _left as Sources, until the next change

    def __len__(self) -> int:
        return len(self.stamps)

    def add(self, stamp: Stamp) -> None:
        self.stamps.append(stamp)
        self.given.append(0.0)
        if self._valid and _counts(stamp, 1.0 - 0.0):
            if self._left is None:
                fp = stamp.cells
                self._left = _Sum(fp.y0, fp.x0, fp.y1, fp.x1, margin=16)
            self._left.add(stamp, 1.0 - 0.0)
            self._shown = None

    def _changed(self) -> None:
        self._left, self._valid, self._shown = None, False, None

    def take(self, step: int | None = None) -> Sources | None:
        """The stamps' sources due before step ``step`` (see :func:`due_share`) that were
        not handed out yet, summed; ``None``: everything left (a command that needs the
        canvas whole, the session's end)."""
        return self.take_shares(step).sources()

    def take_shares(self, step: int | None = None) -> Taken:
        """:meth:`take` without the sum: the stamps and the share of each now due, summed
        by :meth:`Taken.sources` when the caller likes (the kiosk sums with its lock
        released; the queue goes on taking stamps meanwhile)."""
        if step is None:
            left = [1.0 - g for g in self.given]
            stamps = self.stamps
            self.stamps, self.given = [], []
            self._left, self._valid, self._shown = None, True, None
            return Taken(stamps, left)
        now: list[float] = []
        keep: list[Stamp] = []
        kept: list[float] = []
        for s, g in zip(self.stamps, self.given, strict=True):
            due = due_share(s.tau, step)
            now.append(max(0.0, due - g))
            if due < 1.0:
                keep.append(s)
                kept.append(max(due, g))
        stamps = self.stamps
        if any(k > 0.0 for k in now):  # else nothing left changed: the sum holds
            self._changed()
        self.stamps, self.given = keep, kept
        return Taken(stamps, now)

    def _left_sources(self) -> Sources | None:
        """Everything left, summed (:func:`accumulate`'s bits), from the running sum."""
        if not self._valid:
            self._left = _sum(self.stamps, [1.0 - g for g in self.given])
            self._valid, self._shown = True, None
        if self._shown is None and self._left is not None:
            src = self._left.sources()
            # shared by every ask until the next change: no caller may write into it
            for a in (src.dw, src.dvx, src.dvy, *src.dp.values()):
                a.flags.writeable = False
            self._shown = src
        return self._shown

    def peek(self) -> Sources | None:
        """Everything left, summed, left pending (a live view's preview)."""
        return self._left_sources()

    def box(self, since: int = 0) -> tuple[slice, slice] | None:
        return stamps_box(self.stamps[since:])

    def preview(self, since: int = 0) -> StampPreview | None:
        src = self._left_sources()
        if src is None:
            return None
        return StampPreview(src, len(self.stamps), stamps_box(self.stamps[since:]))
