"""Measurements of watercolour effects on canvas fields (pure NumPy, no painting).

Each function takes fields of a painted canvas and returns numbers a painter's eye
would judge: how wide and how dark the rim of a dried stroke is, how ragged its edge,
how far a drop spread. Tests and ``station effects`` compare them with thresholds;
nothing here changes a canvas.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from station.canvas.scenarios import distance_inside


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
