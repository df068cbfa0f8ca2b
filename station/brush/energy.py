"""The energy of one spine and its canvas constraints (dissertation §7.3.2–7.3.3).

``E(x) = Σ_m k_m/2 ((θ_m-θ0_m)² + (φ_m-φ0_m)²) + Σ_{j∈C} μN_j (1-η_j) |d_j|``

* Angular springs: the dissertation's ``k/2 (β-β0)²`` with the bend ``β =
  acos(cosθ cosφ)`` (eq. 7.2).  We spring the two angles separately: to second
  order ``β² = θ² + φ²``, and unlike ``acos`` the sum has a regular gradient at
  the straight pose, where SQP starts and ends most of its steps.
* Anisotropic Coulomb friction (eq. 7.6–7.7) on the joints in contact ``C``:
  ``d_j`` is the drag of joint ``j`` over the canvas (its position projected on
  the plane minus its anchor, where it touched down or lay last frame),
  ``η = Cη max(0, u·d/|d|)^k`` with ``u`` the *pull* direction (toward the
  joint's parent, last frame): dragging a bristle behind the handle is easy,
  pushing or dragging it sideways is not.  ``|d|`` is smoothed to
  ``sqrt(|d|²+ε²) - ε`` so the energy is C¹ at rest (the dissertation squares
  the length for the same reason).
* Constraints (§7.3.3): every joint stays above the plane, ``z_j ≥ 0``; a
  joint in contact this frame is held on it, ``z_j = 0``, so it drags instead
  of jumping off to escape its friction.

Everything is numba-compiled and returns analytic gradients (tests compare
them with finite differences).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from station.brush.spine import chain

SMOOTH = 1e-4
"""ε of the smoothed drag length, tuft units."""


@numba.njit(cache=True)
def energy(x: np.ndarray, grad: np.ndarray, lengths: np.ndarray, stiffness: np.ndarray,
           rest: np.ndarray, root: np.ndarray, handle: np.ndarray, contact: np.ndarray,
           anchor: np.ndarray, pull: np.ndarray, mu_n: np.ndarray, c_eta: float,
           k_eta: float) -> float:  # pragma: no cover - compiled
    """Total energy at ``x``; writes ``∂E/∂x`` into ``grad`` when it has ``2n`` entries.

    ``contact`` (n,) 1 for joints in contact; ``anchor`` (n, 2) their drag
    origins; ``pull`` (n, 2) unit pull directions (0 for none); ``mu_n`` (n,)
    friction coefficient times normal force per joint.
    """
    n = lengths.shape[0]
    want = grad.shape[0] == 2 * n
    e = 0.0
    for a in range(2 * n):
        k = stiffness[a // 2]
        dv = x[a] - rest[a]
        e += 0.5 * k * dv * dv
        if want:
            grad[a] = k * dv
    anyc = False
    for j in range(n):
        if contact[j] > 0.0:
            anyc = True
    if not anyc:
        return e
    pos, _frames, jac = chain(x, lengths, root, handle)
    for j in range(n):
        if contact[j] <= 0.0:
            continue
        dx = pos[j, 0] - anchor[j, 0]
        dy = pos[j, 1] - anchor[j, 1]
        s = math.sqrt(dx * dx + dy * dy + SMOOTH * SMOOTH)
        ux, uy = pull[j, 0], pull[j, 1]
        c = (ux * dx + uy * dy) / s
        eta = 0.0
        deta_x = 0.0
        deta_y = 0.0
        if c > 0.0 and c_eta > 0.0:
            eta = c_eta * c**k_eta
            f = c_eta * k_eta * c ** (k_eta - 1.0)
            # ∂c/∂d = u/s - (u·d) d/s³
            ud = ux * dx + uy * dy
            deta_x = f * (ux / s - ud * dx / (s * s * s))
            deta_y = f * (uy / s - ud * dy / (s * s * s))
        length = s - SMOOTH
        e += mu_n[j] * (1.0 - eta) * length
        if want:
            gx = mu_n[j] * (-deta_x * length + (1.0 - eta) * dx / s)
            gy = mu_n[j] * (-deta_y * length + (1.0 - eta) * dy / s)
            for a in range(2 * n):
                grad[a] += gx * jac[j, 0, a] + gy * jac[j, 1, a]
    return e


@numba.njit(cache=True)
def evaluate(x: np.ndarray, grad: np.ndarray, z: np.ndarray, zgrad: np.ndarray,
             lengths: np.ndarray, stiffness: np.ndarray, rest: np.ndarray, root: np.ndarray,
             handle: np.ndarray, contact: np.ndarray, anchor: np.ndarray, pull: np.ndarray,
             mu_n: np.ndarray, c_eta: float, k_eta: float) -> float:  # pragma: no cover
    """:func:`energy` and :func:`heights` in one call (one pass over the chain): the
    solver evaluates both at every SQP iterate, and each call back from NLopt costs
    more than the arithmetic."""
    e = energy(x, grad, lengths, stiffness, rest, root, handle, contact, anchor, pull, mu_n,
               c_eta, k_eta)
    z[:] = heights(x, zgrad, lengths, root, handle)
    return e


@numba.njit(cache=True)
def heights(x: np.ndarray, grad: np.ndarray, lengths: np.ndarray, root: np.ndarray,
            handle: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """Joint heights ``z_j`` (n,); writes ``∂z_j/∂x`` into ``grad`` (n, 2n) when sized so."""
    pos, _frames, jac = chain(x, lengths, root, handle)
    n = lengths.shape[0]
    if grad.shape[0] == n:
        for j in range(n):
            for a in range(2 * n):
                grad[j, a] = jac[j, 2, a]
    return pos[:, 2].copy()
