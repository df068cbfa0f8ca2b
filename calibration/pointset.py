"""Calibration point sets, fitted mappings, and the refusal of degenerate sets.

:class:`PointSet` holds the taps (device), their targets (canvas) and tilts;
:class:`Mapping` a fitted model; :func:`check_points` refuses a set that
cannot determine a model — NaN/inf, too few points, duplicates, collinear
sets, three of four on a line for a homography, no tilt variation for
parallax — with :class:`DegeneratePoints` naming why and which rows.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from station.calibration.errors import DegeneratePoints
from station.calibration.geometry import (
    Array,
    hartley,
    homogeneous,
    planarity,
    project,
    spread,
)

MODELS = ("affine", "homography")
MIN_POINTS = {"affine": 3, "homography": 4}
N_PARAMS = {"affine": 6, "homography": 8}

COLLINEAR_TOL = 1e-3  # smaller/larger principal spread below this: a line, not a plane
DUPLICATE_TOL = 1e-9  # relative to the spread of the set
COND_MAX = 1e10  # condition number of the normalised design matrix
MIN_TILT_SPREAD = math.tan(math.radians(3.0))  # tan(tilt) must vary this much per axis



@dataclass(frozen=True)
class PointSet:
    """Calibration points.

    Attributes:
        device: ``(n, 2)`` sensed positions, device units or device-normalised.
        canvas: ``(n, 2)`` target positions, canvas-normalised ``[0, 1]``.
        tilt: ``(n, 2)`` pen tilt in degrees at each tap, or ``None``.
        labels: one place name per row for messages (``"points.csv:4"``).
    """

    device: Array
    canvas: Array
    tilt: Array | None = None
    labels: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        dev = np.asarray(self.device, dtype=np.float64).reshape(-1, 2)
        can = np.asarray(self.canvas, dtype=np.float64).reshape(-1, 2)
        object.__setattr__(self, "device", dev)
        object.__setattr__(self, "canvas", can)
        if len(dev) != len(can):
            raise DegeneratePoints(f"{len(dev)} device points but {len(can)} targets")
        if self.tilt is not None:
            tilt = np.asarray(self.tilt, dtype=np.float64).reshape(-1, 2)
            if len(tilt) != len(dev):
                raise DegeneratePoints(f"{len(tilt)} tilts for {len(dev)} points")
            object.__setattr__(self, "tilt", tilt)
        if not self.labels:
            object.__setattr__(self, "labels", tuple(f"row {i}" for i in range(len(dev))))

    def __len__(self) -> int:
        return len(self.device)

    def subset(self, rows: Sequence[int] | Array) -> PointSet:
        idx = np.asarray(rows, dtype=int)
        return PointSet(
            self.device[idx],
            self.canvas[idx],
            None if self.tilt is None else self.tilt[idx],
            tuple(self.labels[i] for i in idx),
        )

    @property
    def tan_tilt(self) -> Array:
        """``tan`` of the tilt per axis (zeros without tilt data)."""
        if self.tilt is None:
            return np.zeros_like(self.device)
        return np.tan(np.radians(self.tilt))


@dataclass(frozen=True)
class Mapping:
    """A fitted device → canvas mapping.

    Attributes:
        model: ``"affine"`` or ``"homography"``.
        matrix: 3×3, maps device coordinates (the units of the points) to canvas.
        parallax: ``(hx, hy)`` device units per unit ``tan(tilt)``; (0, 0) = none.
    """

    model: str
    matrix: Array
    parallax: tuple[float, float] = (0.0, 0.0)

    def corrected_device(self, device: Array, tilt_deg: Array | None = None) -> Array:
        """Device points moved by the parallax offset for their tilt."""
        if tilt_deg is None or self.parallax == (0.0, 0.0):
            return device
        return device + np.asarray(self.parallax) * np.tan(np.radians(tilt_deg))

    def map(self, device: Array, tilt_deg: Array | None = None) -> Array:
        """Canvas positions of ``(n, 2)`` device points (with parallax when tilt given)."""
        pts = np.asarray(device, dtype=np.float64).reshape(-1, 2)
        return project(self.matrix, self.corrected_device(pts, tilt_deg))


# ---------------------------------------------------------------------------
# Validation


def check_points(points: PointSet, model: str, parallax: bool = False) -> None:
    """Refuse a point set that cannot determine ``model``; explain why and where."""
    if model not in MODELS:
        raise DegeneratePoints(f"unknown model {model!r} (one of {', '.join(MODELS)})")
    n = len(points)
    arrays = [("device", points.device), ("canvas", points.canvas)]
    if points.tilt is not None:
        arrays.append(("tilt", points.tilt))
    for name, arr in arrays:
        bad = np.flatnonzero(~np.isfinite(arr).all(axis=1))
        if len(bad):
            where = ", ".join(points.labels[i] for i in bad[:5])
            raise DegeneratePoints(f"{name} coordinates are NaN or infinite at {where}")
    need = MIN_POINTS[model] + (1 if parallax else 0)
    if n < need:
        extra = f" ({MIN_POINTS[model]} plus one for the parallax)" if parallax else ""
        article = "an" if model[0] in "aeiou" else "a"
        raise DegeneratePoints(
            f"{n} point{'s' if n != 1 else ''} cannot determine {article} {model} mapping: "
            f"it needs at least {need}{extra}"
        )
    _check_duplicates(points)
    for name, arr in (("device", points.device), ("canvas", points.canvas)):
        if spread(arr) == 0.0:
            raise DegeneratePoints(f"all {name} points coincide")
        flat = planarity(arr)
        if flat < COLLINEAR_TOL:
            raise DegeneratePoints(
                f"the {name} points are (nearly) collinear (spread ratio {flat:.2e} < "
                f"{COLLINEAR_TOL:g}): a line cannot determine a plane mapping; add targets "
                "off the line"
            )
    if model == "homography":
        _check_general_position(points)
    if parallax:
        _check_tilt_spread(points)


def _check_duplicates(points: PointSet) -> None:
    key = points.device if points.tilt is None else np.column_stack([points.device, points.tilt])
    scale = max(spread(points.device), 1e-300)
    order = np.lexsort(key.T[::-1])
    srt = key[order]
    gaps = np.abs(np.diff(srt, axis=0))
    gaps[:, :2] /= scale
    same = np.flatnonzero((gaps <= DUPLICATE_TOL).all(axis=1))
    if len(same):
        a, b = order[same[0]], order[same[0] + 1]
        a, b = min(a, b), max(a, b)
        raise DegeneratePoints(
            f"duplicate point: {points.labels[a]} and {points.labels[b]} have the same device "
            "position; a repeated tap adds no information (remove one)"
        )


def dlt_matrix(dn: Array, cn: Array) -> Array:
    n = len(dn)
    a = np.zeros((2 * n, 9))
    x, y = dn[:, 0], dn[:, 1]
    u, v = cn[:, 0], cn[:, 1]
    a[0::2, 0], a[0::2, 1], a[0::2, 2] = x, y, 1.0
    a[0::2, 6], a[0::2, 7], a[0::2, 8] = -u * x, -u * y, -u
    a[1::2, 3], a[1::2, 4], a[1::2, 5] = x, y, 1.0
    a[1::2, 6], a[1::2, 7], a[1::2, 8] = -v * x, -v * y, -v
    return a


def _check_general_position(points: PointSet) -> None:
    """A homography needs 4 points with no 3 collinear (on both sides)."""
    for name, arr in (("device", points.device), ("canvas", points.canvas)):
        t = hartley(arr)
        pts = (homogeneous(arr) @ t.T)[:, :2]
        # Points off the best line through all but one: if every 4-subset has three
        # on a line the DLT null space is 2-D; test the DLT directly below.
        if len(pts) == 4:
            for trio in itertools.combinations(range(4), 3):
                if planarity(pts[list(trio)]) < COLLINEAR_TOL:
                    rows = ", ".join(points.labels[i] for i in trio)
                    raise DegeneratePoints(
                        f"three of the four {name} points are collinear ({rows}): a "
                        "homography needs four points with no three on a line"
                    )
    dn = (homogeneous(points.device) @ hartley(points.device).T)[:, :2]
    cn = (homogeneous(points.canvas) @ hartley(points.canvas).T)[:, :2]
    s = np.linalg.svd(dlt_matrix(dn, cn), compute_uv=False)
    if len(s) >= 9 and s[-2] < 1e-8 * s[0]:
        raise DegeneratePoints(
            "the points do not determine a homography (too many on one line); use "
            "--model affine or add targets in general position"
        )


def _check_tilt_spread(points: PointSet) -> None:
    if points.tilt is None:
        raise DegeneratePoints(
            "parallax needs tilt_x,tilt_y columns (a tilt pass: tap targets with the pen "
            "leaning in different directions)"
        )
    tt = points.tan_tilt
    for axis, name in ((0, "tilt_x"), (1, "tilt_y")):
        span = float(tt[:, axis].max() - tt[:, axis].min())
        if span < MIN_TILT_SPREAD:
            raise DegeneratePoints(
                f"{name} hardly varies (tan spread {span:.3f} < {MIN_TILT_SPREAD:.3f}, "
                "about 3°): parallax cannot be told from an offset; tap some targets with "
                "the pen leaning left/right and toward/away"
            )
