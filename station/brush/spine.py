"""Bristle spines as kinematic chains (dissertation §7.3.1, Baxter et al. 2004).

A spine is a chain of ``n`` segments hanging from the ferrule.  Segment ``m``
has a length ``l_m`` and two angles relative to its parent, fixed-XYZ
``θ_m`` (about the parent's X axis) and ``φ_m`` (about its Y axis), with zero
twist: its frame is ``F_m = F_{m-1} · R_Y(φ_m) · R_X(θ_m)`` (eq. 7.1) where
``F_{-1}`` is the handle's frame.  A straight bristle points along ``-Z`` of
the handle.  ``θ = ±90°`` is the gimbal-lock pose (the segment's direction no
longer depends on ``φ``), so ``θ`` is bounded to ``±THETA_MAX``.

Coordinates (world and brush alike): ``x`` right and ``y`` down as on the
canvas, ``z`` up, the canvas plane at ``z = 0``.  Lengths are in *tuft units*
(the whole spine is 1 long): the equilibrium does not depend on the brush's
size in cells, the caller scales.

The kinematics are numba-compiled: one call gives the joint positions, the
segment frames and the Jacobian of every joint position with respect to
every angle, from the rotation-axis form ``∂p_j/∂α_m = a_m × (p_j - s_m)``
(``a_m`` the world axis of angle ``α_m``, ``s_m`` the start of segment ``m``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

THETA_MAX = math.radians(80.0)
"""Bound on |θ|: ten degrees short of the gimbal-lock pose."""
PHI_MAX = math.radians(170.0)


@dataclass(frozen=True, slots=True)
class SpineSpec:
    """The mechanical make-up of one spine (tuft units; energies per unit tuft).

    Attributes:
        lengths: segment lengths root → tip, summing to 1, decreasing toward the tip.
        stiffness: angular spring constant per joint root → tip (energy per rad²),
            decreasing toward the tip (the ferrule packs the bristles tightly).
        rest: rest angles ``(θ_0, φ_0, θ_1, φ_1, …)`` in radians (0 = straight).
    """

    lengths: tuple[float, ...]
    stiffness: tuple[float, ...]
    rest: tuple[float, ...]

    @property
    def n(self) -> int:
        return len(self.lengths)

    @classmethod
    def tapered(cls, n: int = 4, taper: float = 0.7, stiffness: float = 1.0,
                soften: float = 0.6, splay: tuple[float, float] = (0.0, 0.0)) -> SpineSpec:
        """``n`` segments whose lengths fall by ``taper`` and stiffness by ``soften``
        per segment toward the tip; ``splay`` = rest ``(θ, φ)`` of the root joint
        in radians (a flat brush's outer spines lean outward)."""
        if n < 1:
            raise ValueError("a spine needs at least one segment")
        raw = np.array([taper**i for i in range(n)])
        lengths = tuple(float(v) for v in raw / raw.sum())
        stiff = tuple(float(stiffness * soften**i) for i in range(n))
        rest = [0.0] * (2 * n)
        rest[0], rest[1] = splay
        return cls(lengths, stiff, tuple(rest))

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return (np.asarray(self.lengths, np.float64), np.asarray(self.stiffness, np.float64),
                np.asarray(self.rest, np.float64))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        hi = np.tile([THETA_MAX, PHI_MAX], self.n)
        return -hi, hi


@numba.njit(cache=True)
def rot(theta: float, phi: float) -> np.ndarray:  # pragma: no cover - compiled
    """``R_Y(φ) R_X(θ)`` (eq. 7.1)."""
    ct, st = math.cos(theta), math.sin(theta)
    cp, sp = math.cos(phi), math.sin(phi)
    r = np.empty((3, 3))
    r[0, 0], r[0, 1], r[0, 2] = cp, sp * st, sp * ct
    r[1, 0], r[1, 1], r[1, 2] = 0.0, ct, -st
    r[2, 0], r[2, 1], r[2, 2] = -sp, cp * st, cp * ct
    return r


@numba.njit(cache=True)
def _mul3(a: np.ndarray, b: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    # numba's ``@`` needs SciPy's BLAS; a 3×3 product is cheaper written out anyway
    r = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            r[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]
    return r


@numba.njit(cache=True)
def chain(x: np.ndarray, lengths: np.ndarray, root: np.ndarray, handle: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """Joint positions ``(n, 3)``, segment frames ``(n, 3, 3)`` and the Jacobian
    ``(n, 3, 2n)`` of the joints (segment ends) for angles ``x``."""
    n = lengths.shape[0]
    pos = np.empty((n, 3))
    frames = np.empty((n, 3, 3))
    axes = np.empty((2 * n, 3))
    starts = np.empty((n, 3))
    parent = handle.copy()
    start = root.copy()
    for m in range(n):
        th, ph = x[2 * m], x[2 * m + 1]
        cp, sp = math.cos(ph), math.sin(ph)
        # world axes of θ_m (parent X after R_Y(φ)) and φ_m (parent Y)
        for k in range(3):
            axes[2 * m, k] = parent[k, 0] * cp - parent[k, 2] * sp
            axes[2 * m + 1, k] = parent[k, 1]
        f = _mul3(parent, rot(th, ph))
        frames[m] = f
        starts[m] = start
        for k in range(3):
            pos[m, k] = start[k] - lengths[m] * f[k, 2]
        start = pos[m].copy()
        parent = f
    jac = np.zeros((n, 3, 2 * n))
    for a in range(2 * n):
        m = a // 2
        ax = axes[a]
        for j in range(m, n):
            r0 = pos[j, 0] - starts[m, 0]
            r1 = pos[j, 1] - starts[m, 1]
            r2 = pos[j, 2] - starts[m, 2]
            jac[j, 0, a] = ax[1] * r2 - ax[2] * r1
            jac[j, 1, a] = ax[2] * r0 - ax[0] * r2
            jac[j, 2, a] = ax[0] * r1 - ax[1] * r0
    return pos, frames, jac


def handle_frame(tilt_x: float, tilt_y: float, twist: float, max_tilt: float = 60.0
                 ) -> np.ndarray:
    """The handle's frame (columns = its X, Y, Z axes in world coordinates).

    ``tilt_x, tilt_y`` are the pen's tilt in degrees (positive x: the top leans
    right, positive y: toward the user, i.e. +y on the canvas), combined as a
    vector and limited to ``max_tilt``; the tuft (−Z) then points away from
    the lean.  ``twist`` (degrees, the Art Pen's barrel rotation) turns the
    brush about its own axis: it sets which way a flat brush's width lies.
    """
    mag = min(max_tilt, math.hypot(tilt_x, tilt_y))
    az = math.atan2(tilt_y, tilt_x) if mag > 0.0 else 0.0
    a = math.radians(mag)
    # rotate about the horizontal axis perpendicular to the lean so that -Z tips away
    ux, uy = math.cos(az), math.sin(az)
    axis = np.array([-uy, ux, 0.0])
    c, s = math.cos(a), math.sin(a)
    kx = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]],
                   [-axis[1], axis[0], 0.0]])
    lean = np.eye(3) + s * kx + (1.0 - c) * (kx @ kx)
    t = math.radians(twist)
    ct, st = math.cos(t), math.sin(t)
    spin = np.array([[ct, -st, 0.0], [st, ct, 0.0], [0.0, 0.0, 1.0]])
    return np.ascontiguousarray(lean @ spin)
