"""Small numerically careful helpers for planar projective geometry.

Points are ``(n, 2)`` float64 arrays; matrices are ``(3, 3)`` and act on
column vectors ``(x, y, 1)``.  Nothing here knows about pens or files.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

# Chi-square quantile with 2 degrees of freedom: P(chi2_2 <= q) = p  <=>  q = -2 ln(1 - p).
# A 2-D residual of a point with isotropic Gaussian noise sigma exceeds
# sqrt(q) * sigma with probability 1 - p.
CHI2_2_0999 = -2.0 * math.log(1.0 - 0.999)  # 13.8155...
CHI2_2_MEDIAN = 2.0 * math.log(2.0)  # median of chi2_2: 1.3863


def as_points(values: object, name: str = "points") -> Array:
    """``values`` as a float64 ``(n, 2)`` array (no finiteness check here)."""
    arr = np.asarray(values, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"{name} must have shape (n, 2), got {arr.shape}")
    return arr


def homogeneous(points: Array) -> Array:
    """``(n, 3)`` homogeneous coordinates ``(x, y, 1)``."""
    return np.column_stack([points, np.ones(len(points))])


def project(matrix: Array, points: Array) -> Array:
    """Apply a 3×3 projective matrix to ``(n, 2)`` points (divides by w)."""
    h = homogeneous(points) @ matrix.T
    w = h[:, 2:3]
    return h[:, :2] / w


def normalise_matrix(matrix: Array) -> Array:
    """Scale a homogeneous matrix so that ``m[2, 2] == 1`` (when it is not ~0)."""
    m = np.asarray(matrix, dtype=np.float64)
    if abs(m[2, 2]) > 1e-12 * float(np.abs(m).max()):
        return m / m[2, 2]
    return m / float(np.linalg.norm(m))


def hartley(points: Array) -> Array:
    """Hartley's normalising similarity for ``points``.

    The returned 3×3 matrix ``T`` moves the centroid to the origin and scales
    so that the root-mean-square distance from it is sqrt(2).  Fitting in these
    coordinates keeps the DLT and least-squares systems well conditioned no
    matter whether points are in device units (0..95840) or normalised (0..1).
    A point set with zero spread gets scale 1 (callers refuse it earlier).
    """
    centre = points.mean(axis=0)
    rms = float(np.sqrt(((points - centre) ** 2).sum(axis=1).mean()))
    scale = math.sqrt(2.0) / rms if rms > 0 else 1.0
    return np.array(
        [[scale, 0.0, -scale * centre[0]], [0.0, scale, -scale * centre[1]], [0.0, 0.0, 1.0]]
    )


def spread(points: Array) -> float:
    """Root-mean-square distance of ``points`` from their centroid (same units)."""
    centre = points.mean(axis=0)
    return float(np.sqrt(((points - centre) ** 2).sum(axis=1).mean()))


def planarity(points: Array) -> float:
    """Ratio of the smaller to the larger principal spread (0 = collinear, 1 = round)."""
    centred = points - points.mean(axis=0)
    s = np.linalg.svd(centred, compute_uv=False)
    if s[0] == 0:
        return 0.0
    return float(s[1] / s[0]) if len(s) > 1 else 0.0


def jacobian(matrix: Array, points: Array) -> Array:
    """Jacobians ``(n, 2, 2)`` of the projective map at ``points`` (d output / d input)."""
    h = homogeneous(points) @ matrix.T
    w = h[:, 2]
    mapped = h[:, :2] / w[:, None]
    lin = matrix[:2, :2][None, :, :]  # (1, 2, 2)
    persp = matrix[2, :2][None, None, :]  # (1, 1, 2)
    return (lin - mapped[:, :, None] * persp) / w[:, None, None]


def rotation(degrees: float) -> Array:
    """3×3 rotation about the origin; exact for multiples of 90°."""
    q, r = divmod(float(degrees), 90.0)
    if r == 0.0:
        c, s = [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)][int(q) % 4]
    else:
        a = math.radians(degrees)
        c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def translation(tx: float, ty: float) -> Array:
    return np.array([[1.0, 0.0, tx], [0.0, 1.0, ty], [0.0, 0.0, 1.0]])


def scaling(sx: float, sy: float) -> Array:
    return np.array([[sx, 0.0, 0.0], [0.0, sy, 0.0], [0.0, 0.0, 1.0]])
