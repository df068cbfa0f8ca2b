"""A small Levenberg–Marquardt least-squares solver (Marquardt's diagonal scaling)."""

from __future__ import annotations

from typing import Any

import numpy as np
from station.calibration.geometry import Array


def levenberg_marquardt(
    fun: Any, theta0: Array, max_iter: int = 200, tol: float = 1e-14
) -> tuple[Array, float]:
    """Minimise ``|r(θ)|²`` with Levenberg–Marquardt (Marquardt's diagonal scaling).

    ``fun(θ) -> (r, J)``.  Returns ``(θ, |r|²)``.  Stops when the relative
    decrease of the cost or the step is below ``tol``.
    """
    theta = np.array(theta0, dtype=np.float64)
    r, j = fun(theta)
    cost = float(r @ r)
    lam = 1e-3
    for _ in range(max_iter):
        jtj = j.T @ j
        g = j.T @ r
        diag = np.maximum(np.diag(jtj), 1e-12)
        improved = False
        for _inner in range(30):
            a = jtj + lam * np.diag(diag)
            try:
                step = -np.linalg.solve(a, g)
            except np.linalg.LinAlgError:
                lam *= 10
                continue
            cand = theta + step
            with np.errstate(all="ignore"):  # a trial step may hit w = 0; it is rejected
                r2, j2 = fun(cand)
            c2 = float(r2 @ r2)
            if np.isfinite(c2) and c2 <= cost:
                small = cost - c2 <= tol * max(cost, 1e-300) or float(
                    np.linalg.norm(step)
                ) <= tol * (1.0 + float(np.linalg.norm(theta)))
                theta, r, j, cost = cand, r2, j2, c2
                lam = max(lam / 10, 1e-12)
                improved = True
                if small:
                    return theta, cost
                break
            lam *= 10
        if not improved:
            break
    return theta, cost
