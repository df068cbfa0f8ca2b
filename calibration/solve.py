"""One model fitted to one point set: affine or homography, with or without parallax.

Everything is fitted in Hartley-normalised coordinates (:class:`Normalised`):
affine by linear least squares, homography by the normalised DLT, then both
refined by Levenberg–Marquardt on the canvas-space error
(:func:`residuals_jac` gives residuals and their Jacobian); parallax starts
from the linear fit's residuals.  :func:`fit_mapping` refuses what cannot
determine the model; :func:`quiet_fit` is for the robust search's subsets,
which may be degenerate.  Choosing points and models is :mod:`station.calibration.fit`'s job.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from station.calibration.errors import DegeneratePoints
from station.calibration.geometry import (
    Array,
    hartley,
    homogeneous,
    jacobian,
    normalise_matrix,
    planarity,
    project,
)
from station.calibration.pointset import (
    COLLINEAR_TOL,
    COND_MAX,
    Mapping,
    PointSet,
    check_points,
    dlt_matrix,
)


@dataclass(frozen=True)
class Normalised:
    """A point set in Hartley-normalised coordinates: ``td``/``tc`` the device and canvas
    normalising matrices, ``dn``/``cn`` the normalised points, ``tn`` tan(tilt)."""

    td: Array
    tc: Array
    dn: Array
    cn: Array
    tn: Array

    @classmethod
    def of(cls, points: PointSet) -> Normalised:
        td, tc = hartley(points.device), hartley(points.canvas)
        dn = (homogeneous(points.device) @ td.T)[:, :2]
        cn = (homogeneous(points.canvas) @ tc.T)[:, :2]
        return cls(td, tc, dn, cn, points.tan_tilt)


def _affine_ls(dn: Array, cn: Array) -> tuple[Array, float]:
    """Least-squares affine in normalised coordinates; (3×3, condition number)."""
    design = homogeneous(dn)
    sol, _res, _rank, sv = np.linalg.lstsq(design, cn, rcond=None)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
    m = np.eye(3)
    m[:2, :] = sol.T
    return m, cond


def _dlt(dn: Array, cn: Array) -> tuple[Array, float]:
    a = dlt_matrix(dn, cn)
    _u, s, vt = np.linalg.svd(a)
    h = vt[-1].reshape(3, 3)
    cond = float(s[0] / s[-2]) if s[-2] > 0 else math.inf
    if abs(h[2, 2]) < 1e-8 * float(np.abs(h).max()):
        raise DegeneratePoints("the homography sends the centre of the points to infinity")
    return h / h[2, 2], cond


def _unpack(model: str, theta: Array) -> tuple[Array, Array]:
    m = np.eye(3)
    if model == "affine":
        m[:2, :] = theta[:6].reshape(2, 3)
        rest = theta[6:]
    else:
        m.flat[:8] = theta[:8]
        rest = theta[8:]
    par = rest[:2] if len(rest) else np.zeros(2)
    return m, par


def pack(model: str, m: Array, par: Array | None) -> Array:
    core = m[:2, :].ravel() if model == "affine" else (m / m[2, 2]).flat[:8]
    return np.concatenate([core, par]) if par is not None else np.array(core)


def residuals_jac(
    model: str, theta: Array, dn: Array, cn: Array, tn: Array, parallax: bool
) -> tuple[Array, Array]:
    """Residuals ``(2n,)`` = mapped - target and their Jacobian ``(2n, p)``."""
    m, par = _unpack(model, theta)
    pts = dn + par * tn if parallax else dn
    x, y = pts[:, 0], pts[:, 1]
    h = homogeneous(pts) @ m.T
    w = h[:, 2]
    u, v = h[:, 0] / w, h[:, 1] / w
    n = len(dn)
    iw = 1.0 / w
    # d/d(m11, m12, m13, m21, m22, m23)
    du = [x * iw, y * iw, iw, 0 * x, 0 * x, 0 * x]
    dv = [0 * x, 0 * x, 0 * x, x * iw, y * iw, iw]
    if model == "homography":
        du += [-u * x * iw, -u * y * iw]
        dv += [-v * x * iw, -v * y * iw]
    if parallax:
        # chain rule through the corrected point: d(u,v)/d(x,y) · d(x,y)/d(hx,hy)
        dux = (m[0, 0] - u * m[2, 0]) * iw
        duy = (m[0, 1] - u * m[2, 1]) * iw
        dvx = (m[1, 0] - v * m[2, 0]) * iw
        dvy = (m[1, 1] - v * m[2, 1]) * iw
        du += [dux * tn[:, 0], duy * tn[:, 1]]
        dv += [dvx * tn[:, 0], dvy * tn[:, 1]]
    jac = np.empty((2 * n, len(du)))
    for k, (a, b) in enumerate(zip(du, dv, strict=True)):
        jac[0::2, k] = a
        jac[1::2, k] = b
    res = np.empty(2 * n)
    res[0::2] = u - cn[:, 0]
    res[1::2] = v - cn[:, 1]
    return res, jac


def _parallax_init(model: str, m: Array, nz: Normalised) -> Array:
    """Linear estimate of (hx, hy) with the plain mapping held fixed."""
    jac = jacobian(m, nz.dn)  # (n, 2, 2)
    resid = nz.cn - project(m, nz.dn)
    design = np.zeros((2 * len(nz.dn), 2))
    design[0::2, 0] = jac[:, 0, 0] * nz.tn[:, 0]
    design[0::2, 1] = jac[:, 0, 1] * nz.tn[:, 1]
    design[1::2, 0] = jac[:, 1, 0] * nz.tn[:, 0]
    design[1::2, 1] = jac[:, 1, 1] * nz.tn[:, 1]
    sol, *_ = np.linalg.lstsq(design, resid.ravel(), rcond=None)
    return np.asarray(sol, dtype=np.float64)


def _fit_normalised(
    model: str, nz: Normalised, parallax: bool, refine: bool = True, quick: bool = False
) -> tuple[Array, Array, float]:
    """(matrix_n, parallax_n, condition) fitted in normalised coordinates."""
    if model == "affine":
        m, cond = _affine_ls(nz.dn, nz.cn)
    else:
        m, cond = _dlt(nz.dn, nz.cn)
    if cond > COND_MAX:
        raise DegeneratePoints(
            f"the point set is ill-conditioned for a {model} fit (condition {cond:.2e})"
        )
    par = np.zeros(2)
    if parallax:
        par = _parallax_init(model, m, nz)
    if (model == "homography" and refine) or parallax:
        theta = _refine(model, nz, parallax, pack(model, m, par if parallax else None), quick)
        m, p2 = _unpack(model, theta)
        if parallax:
            par = p2
            _check_parallax_conditioning(model, theta, nz)
    return m, par, cond


def _refine(model: str, nz: Normalised, parallax: bool, theta0: Array,
            quick: bool = False) -> Array:
    """Minimise the canvas-space error from ``theta0`` (Levenberg–Marquardt, MINPACK).

    ``quick``: to 1e-9 relative and at most 12 evaluations, enough to rank a minimal
    subset in the robust search (whose winner is refitted in full); at 1e-14 the
    search spent ~240 evaluations a subset, 35 s of a 22-tap session's fit."""

    def fun(th: Array) -> Array:
        return residuals_jac(model, th, nz.dn, nz.cn, nz.tn, parallax)[0]

    def jac(th: Array) -> Array:
        return residuals_jac(model, th, nz.dn, nz.cn, nz.tn, parallax)[1]

    # A start that sends a point to infinity (a degenerate minimal subset of the
    # robust search) has nothing to refine; the caller judges the mapping.  A trial
    # step reaching w = 0 gives MINPACK a non-finite cost: rejected, step shortened.
    with np.errstate(all="ignore"):
        if not np.isfinite(fun(theta0)).all():
            return np.asarray(theta0, dtype=np.float64)
        tol = 1e-9 if quick else 1e-14
        sol = least_squares(fun, theta0, jac=jac, method="lm", xtol=tol, ftol=tol, gtol=tol,
                            max_nfev=12 if quick else None)
    return np.asarray(sol.x, dtype=np.float64)


def _check_parallax_conditioning(model: str, theta: Array, nz: Normalised) -> None:
    _r, j = residuals_jac(model, theta, nz.dn, nz.cn, nz.tn, True)
    s = np.linalg.svd(j / np.maximum(np.linalg.norm(j, axis=0), 1e-300), compute_uv=False)
    if s[-1] < 1e-6 * s[0]:
        raise DegeneratePoints(
            "parallax and mapping cannot be told apart with these taps (tilt is tied to "
            "position); tap the same targets with the pen leaning different ways"
        )


def _denormalise(model: str, nz: Normalised, m: Array, par: Array) -> Mapping:
    matrix = normalise_matrix(np.linalg.inv(nz.tc) @ m @ nz.td)
    if model == "affine":
        matrix[2, :] = (0.0, 0.0, 1.0)  # exactly affine, not 1e-17 off
    scale = nz.td[0, 0]
    return Mapping(model, matrix, (float(par[0] / scale), float(par[1] / scale)))


def fit_mapping(
    points: PointSet, model: str = "affine", parallax: bool = False, refine: bool = True
) -> tuple[Mapping, float]:
    """Least-squares fit of ``model`` to all points; ``(mapping, condition)``."""
    check_points(points, model, parallax)
    nz = Normalised.of(points)
    m, par, cond = _fit_normalised(model, nz, parallax, refine)
    return _denormalise(model, nz, m, par), cond


def fit_affine(points: PointSet) -> Mapping:
    """Affine least squares (≥ 3 non-collinear points)."""
    return fit_mapping(points, "affine")[0]


def fit_homography(points: PointSet, refine: bool = True) -> Mapping:
    """Normalised DLT (≥ 4 points, no three collinear), refined by LM when ``refine``."""
    return fit_mapping(points, "homography", refine=refine)[0]


def quiet_fit(points: PointSet, model: str, parallax: bool, quick: bool = False
              ) -> Mapping | None:
    """Fit without raising on degeneracy (subsets of a valid set may be degenerate);
    ``quick``: a looser refinement, for ranking subsets (see :func:`_refine`)."""
    try:
        with np.errstate(all="ignore"):
            nz = Normalised.of(points)
            if min(planarity(points.device), planarity(points.canvas)) < COLLINEAR_TOL:
                return None
            m, par, _cond = _fit_normalised(model, nz, parallax, quick=quick)
            mapping = _denormalise(model, nz, m, par)
    except (DegeneratePoints, np.linalg.LinAlgError, FloatingPointError, ZeroDivisionError):
        return None
    if not np.isfinite(mapping.matrix).all():
        return None
    return mapping

