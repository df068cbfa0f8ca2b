"""Measurements of watercolour effects on canvas fields (pure NumPy, no painting).

Each function takes fields of a painted canvas and returns numbers a painter's eye
would judge: how wide and how dark the rim of a dried stroke is, how ragged its edge,
how far a drop spread. Tests and ``station effects`` compare them with thresholds;
nothing here changes a canvas.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from station.pictures.scenarios import distance_inside


@dataclass(frozen=True)
class EdgeBand:
    """The dark band of a dried stroke.

    ring_ratio: mean deposit of each ring (1 = outermost cells of the deposit, chessboard
        distance) over the interior's mean (cells ``interior_from`` or more inside) [1];
    width: rings from the edge whose ratio is at least ``threshold`` without a gap [cells];
    ratio: mean ratio over those rings [1] (0 when width is 0).
    """

    ring_ratio: tuple[float, ...]
    width: int
    ratio: float


def edge_band(q: np.ndarray, threshold: float = 1.4, interior_from: int = 10,
              deposit: float = 1e-4) -> EdgeBand:
    """Rim of the deposit ``q`` (H, W): rings measured from the deposit's own edge."""
    region = (q > deposit).astype(np.float32)
    d = distance_inside(region)
    inner = d >= interior_from
    if not inner.any():
        return EdgeBand((), 0, 0.0)
    interior = float(q[inner].mean())
    rings = tuple(float(q[d == k].mean()) / interior for k in range(1, interior_from))
    width = 0
    for r in rings:
        if r < threshold:
            break
        width += 1
    ratio = float(np.mean(rings[:width])) if width else 0.0
    return EdgeBand(rings, width, ratio)


def edge_roughness(q: np.ndarray, cols: slice, deposit: float = 1e-4) -> float:
    """Standard deviation [cells] of the top edge row of a horizontal stroke over ``cols``.

    The edge row of a column is the first row whose deposit exceeds ``deposit``; a ruler
    edge gives 0.
    """
    sub = q[:, cols] > deposit
    has = sub.any(axis=0)
    if not has.any():
        return 0.0
    top = np.argmax(sub, axis=0)[has].astype(np.float64)
    return float(top.std())


@dataclass(frozen=True)
class Crenels:
    """How a deposit's top edge is built, column by column (the edge row of a column is its
    first row whose deposit exceeds ``deposit``).

    per_100: rectangular tabs and notches per 100 columns: runs of 1-3 columns between a
        rise and a fall of the edge (or a fall and a rise), at least one of them 2 cells or
        more (the cell grid's battlements; a real wet-on-dry edge is never stepped so);
    wall_share: the share of the edge's vertical travel taken in jumps of 2 cells or more
        between neighbouring columns (right-angle walls) [1];
    tooth: standard deviation of the edge row about its 9-column running mean [cells]:
        the fine roughness that remains (0: a ruler line, or a smooth curve).
    """

    per_100: float
    wall_share: float
    tooth: float


def crenels(q: np.ndarray, cols: slice, deposit: float = 1e-4) -> Crenels:
    """:class:`Crenels` of the top edge of the deposit ``q`` (H, W) over ``cols`` (every
    column must hold some deposit)."""
    top = np.argmax(q[:, cols] > deposit, axis=0).astype(np.int64)
    d = np.diff(top)
    ad = np.abs(d)
    idx = np.nonzero(d)[0]
    n = 0
    for a, b in itertools.pairwise(idx):
        if b - a <= 3 and max(ad[a], ad[b]) >= 2 and d[a] * d[b] < 0:
            n += 1
    travel = int(ad.sum())
    walls = int(ad[ad >= 2].sum())
    mean = np.convolve(top.astype(np.float64), np.ones(9) / 9.0, mode="valid")
    tooth = float((top[4:-4] - mean).std()) if len(mean) else 0.0
    return Crenels(100.0 * n / len(top), walls / travel if travel else 0.0, tooth)


def paper_following(q: np.ndarray, h: np.ndarray, footprint: np.ndarray,
                    deposit: float = 1e-4) -> float:
    """Mean paper height of the cells outside ``footprint`` the deposit reached, minus the
    mean paper height of the dry cells next to them [1]: > 0 when the edge crept on where
    the paper let it (high ``h``)."""
    reached = (q > deposit) & (footprint == 0)
    near = np.zeros_like(reached)
    for dy, dx in ((0, 1), (0, -1), (1, 0), (-1, 0)):
        near |= np.roll(reached | (footprint > 0), (dy, dx), axis=(0, 1))
    rim_dry = near & ~reached & (footprint == 0)
    if not reached.any() or not rim_dry.any():
        return 0.0
    return float(h[reached].mean() - h[rim_dry].mean())


def _contour_segments(f: np.ndarray, level: float) -> np.ndarray:
    """Marching-squares segments of the iso-line ``f == level`` (cell centres as grid
    points, linear interpolation along the square sides): float64 (N, 2, 2) of (y, x)."""
    a = np.pad(np.asarray(f, np.float64), 1, constant_values=-np.inf) >= level
    v = np.pad(np.asarray(f, np.float64), 1, constant_values=float(np.min(f)) - 1.0)
    segs: list[tuple[tuple[float, float], tuple[float, float]]] = []
    hh, ww = v.shape

    def cross(y0: int, x0: int, y1: int, x1: int) -> tuple[float, float]:
        f0, f1 = v[y0, x0], v[y1, x1]
        t = 0.5 if f1 == f0 else (level - f0) / (f1 - f0)
        t = min(max(t, 0.0), 1.0)
        return (y0 + t * (y1 - y0), x0 + t * (x1 - x0))

    for y in range(hh - 1):
        for x in range(ww - 1):
            tl, tr, br, bl = a[y, x], a[y, x + 1], a[y + 1, x + 1], a[y + 1, x]
            k = int(tl) | int(tr) << 1 | int(br) << 2 | int(bl) << 3
            if k in (0, 15):
                continue
            top = cross(y, x, y, x + 1)
            right = cross(y, x + 1, y + 1, x + 1)
            bottom = cross(y + 1, x, y + 1, x + 1)
            left = cross(y, x, y + 1, x)
            edges = {1: [(left, top)], 2: [(top, right)], 3: [(left, right)],
                     4: [(right, bottom)], 5: [(left, top), (right, bottom)],
                     6: [(top, bottom)], 7: [(left, bottom)], 8: [(bottom, left)],
                     9: [(top, bottom)], 10: [(top, right), (bottom, left)],
                     11: [(right, bottom)], 12: [(right, left)], 13: [(top, right)],
                     14: [(left, top)]}[k]
            segs.extend(edges)
    if not segs:
        return np.zeros((0, 2, 2))
    return np.asarray(segs, np.float64) - 1.0


def _hull_perimeter(points: np.ndarray) -> float:
    """Perimeter of the convex hull of (N, 2) points (Andrew's monotone chain)."""
    pts = sorted(set(map(tuple, np.round(points, 9).tolist())))
    if len(pts) < 3:
        return 0.0

    def turn(o: tuple[float, ...], a: tuple[float, ...], b: tuple[float, ...]) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, ...]] = []
    for p in pts:
        while len(lower) >= 2 and turn(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list[tuple[float, ...]] = []
    for p in reversed(pts):
        while len(upper) >= 2 and turn(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    hull = np.asarray(lower[:-1] + upper[:-1])
    return float(np.linalg.norm(hull - np.roll(hull, 1, axis=0), axis=1).sum())


@dataclass(frozen=True)
class Spread:
    """How a drop spread: ``area_ratio`` = area inside the iso-line over the footprint's
    area [1]; ``feather`` = iso-line length over its convex hull's perimeter [1] (1 for a
    convex blot, larger for a feathered, irregular boundary)."""

    area_ratio: float
    feather: float


def spread(q: np.ndarray, footprint: np.ndarray, level_share: float = 0.2) -> Spread:
    """The spread of the deposit ``q`` of a drop painted over ``footprint``: the iso-line
    at ``level_share`` of the mean deposit the footprint would hold had nothing moved
    (total / footprint area)."""
    area_fp = float((footprint > 0).sum())
    level = level_share * float(q.sum()) / max(area_fp, 1.0)
    inside = float((q >= level).sum())
    return Spread(inside / max(area_fp, 1.0), feather(q, level))


def feather(f: np.ndarray, level: float) -> float:
    """Length of the iso-line ``f == level`` over its convex hull's perimeter [1]: 1 for a
    convex blot, larger for a feathered, irregular boundary (0 when there is no line)."""
    segs = _contour_segments(f, level)
    if len(segs) == 0:
        return 0.0
    length = float(np.linalg.norm(segs[:, 0] - segs[:, 1], axis=1).sum())
    hull = _hull_perimeter(segs.reshape(-1, 2))
    return length / hull if hull > 0 else 0.0


def bare_share(painted: np.ndarray, reach: int = 4) -> float:
    """Share of a stroke's envelope left as bare paper [1]: the "flying white" of a dry
    brush. The envelope is ``painted`` closed over ``reach`` cells across and twice that
    along rows (a horizontal stroke) with its holes filled, so gaps between bristle marks
    count and the paper around the stroke does not; 0 for a solid stroke."""
    if not painted.any():
        return 0.0
    se = np.ones((2 * reach + 1, 4 * reach + 1), bool)
    padded = np.pad(painted, 2 * reach)
    closed = ndimage.binary_closing(padded, structure=se)[2 * reach:-2 * reach,
                                                          2 * reach:-2 * reach]
    envelope = ndimage.binary_fill_holes(closed | painted)
    return 1.0 - float(painted.sum()) / float(envelope.sum())


def edge_width(profile: np.ndarray, low: float = 0.1, high: float = 0.9) -> float:
    """Width [cells] over which a deposit profile taken across an edge (outside first)
    rises from ``low`` to ``high`` of its plateau (the median of its inner half); the
    crossings are interpolated linearly between cells. A hard wet-on-dry edge is about a
    cell; a soft wet-in-wet edge several."""
    prof = np.asarray(profile, np.float64)
    plateau = float(np.median(prof[len(prof) // 2:]))
    if plateau <= 0:
        return 0.0

    def crossing(level: float) -> float:
        v = prof / plateau
        i = int(np.argmax(v >= level))
        if i == 0:
            return 0.0
        out: float = (i - 1) + (level - v[i - 1]) / max(v[i] - v[i - 1], 1e-12)
        return out

    return crossing(high) - crossing(low)
