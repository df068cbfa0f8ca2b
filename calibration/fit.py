"""Fitting a device → canvas mapping from calibration points.

Models (all 3×3 matrices acting on ``(x, y, 1)``):

* ``affine``: 6 parameters, linear least squares, needs ≥ 3 non-collinear points.
* ``homography``: 8 parameters, normalised DLT then Levenberg–Marquardt on the
  geometric error, needs ≥ 4 points in general position.
* either with ``parallax``: 2 more parameters ``(hx, hy)`` in device units per
  unit ``tan(tilt)``; the sensed point is moved by ``(hx·tan(tilt_x), hy·tan(tilt_y))``
  before mapping (screen tablets: the nib sits above the sensor).

The error minimised and reported is the *canvas-space* distance between where
the mapped tap lands and the target: the error the user sees.  All fitting
happens in Hartley-normalised coordinates, so device units (0..95840) and
normalised units (0..1) are equally well conditioned.  Point sets that cannot
determine the model are refused with :class:`DegeneratePoints` naming why and
which rows.

Robust fitting (misclicks): least trimmed squares over minimal subsets
(exhaustive when few, else seeded random), then iterative re-classification of
every point by its leverage-corrected studentised residual against the 99.9 %
quantile of ``2·F(2, dof)`` (chi-square when the noise is known); see
:func:`fit_points`.  Point sets and their validation live in
:mod:`station.calibration.pointset`; fitting one model to one point set in
:mod:`station.calibration.solve` (the non-linear refinement is SciPy's
Levenberg–Marquardt, ``least_squares(method="lm")``, MINPACK).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
from station.calibration.errors import DegeneratePoints
from station.calibration.geometry import (
    CHI2_2_0999,
    Array,
    jacobian,
    normalise_matrix,
    spread,
)
from station.calibration.pointset import (
    COLLINEAR_TOL,
    COND_MAX,
    DUPLICATE_TOL,
    MIN_POINTS,
    MIN_TILT_SPREAD,
    MODELS,
    N_PARAMS,
    Mapping,
    PointSet,
    check_points,
)
from station.calibration.solve import (
    Normalised,
    fit_affine,
    fit_homography,
    fit_mapping,
    pack,
    quiet_fit,
    residuals_jac,
)

__all__ = [
    "CHI2_2_0999", "COLLINEAR_TOL", "COND_MAX", "DUPLICATE_TOL", "MIN_POINTS",
    "MIN_TILT_SPREAD", "MODELS", "N_PARAMS", "FitReport", "Mapping", "PointSet",
    "check_points", "fit_affine", "fit_homography", "fit_mapping", "fit_points",
    "leave_one_out", "outlier_limit", "residuals", "residuals_mm",
]  # fmt: skip

MAX_SUBSETS = 400  # minimal subsets tried by the robust search


@dataclass
class FitReport:
    """Everything ``station calibrate --fit`` prints (canvas units unless ``_mm``)."""

    mapping: Mapping
    rms: float
    max: float
    residuals: Array  # (n, 2) target - mapped, every row (outliers too)
    inliers: list[int]
    outliers: list[int]
    sigma: float  # per-axis noise estimated from the inliers
    threshold: float  # residual norm above which a point is an outlier
    loo_rms: float | None
    loo_max: float | None
    loo_errors: list[float | None]
    condition: float
    residuals_mm: Array | None = None
    parallax_mm: tuple[float, float] | None = None
    candidates: dict[str, dict[str, object]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    ambiguous: dict[int, list[int]] = field(default_factory=dict)  # outlier -> equal suspects

    @property
    def model(self) -> str:
        return self.mapping.model

    def to_json(self, labels: Sequence[str] = ()) -> dict[str, object]:
        norms = np.linalg.norm(self.residuals, axis=1)
        residuals: list[dict[str, object]] = [
            {"row": i, "dx": float(r[0]), "dy": float(r[1]), "norm": float(n),
             "loo": self.loo_errors[i], "outlier": i in self.outliers}
            for i, (r, n) in enumerate(zip(self.residuals, norms, strict=True))
        ]
        out: dict[str, object] = {
            "model": self.model,
            "matrix": _clean(self.mapping.matrix.tolist()),
            "rms": self.rms,
            "max": self.max,
            "outliers": self.outliers,
            "inliers": self.inliers,
            "n_points": int(len(norms)),
            "sigma": self.sigma,
            "outlier_threshold": self.threshold,
            "loo_rms": self.loo_rms,
            "loo_max": self.loo_max,
            "residuals": residuals,
            "condition": self.condition,
        }
        if labels:
            out["outlier_where"] = [labels[i] for i in self.outliers]
        if self.residuals_mm is not None:
            mm = np.linalg.norm(self.residuals_mm, axis=1)
            inl = mm[self.inliers] if self.inliers else mm
            out["rms_mm"] = float(np.sqrt(np.mean(inl**2)))
            out["max_mm"] = float(inl.max())
            for rec, v in zip(residuals, mm, strict=True):
                rec["norm_mm"] = float(v)
        if self.mapping.parallax != (0.0, 0.0) or self.parallax_mm is not None:
            par: dict[str, object] = {
                "x": self.mapping.parallax[0],
                "y": self.mapping.parallax[1],
                "units": "device units per tan(tilt)",
            }
            if self.parallax_mm is not None:
                par["x_mm"], par["y_mm"] = self.parallax_mm
            out["parallax"] = par
        if self.ambiguous:
            out["ambiguous_outliers"] = {str(k): v for k, v in self.ambiguous.items()}
        if self.candidates:
            out["candidates"] = self.candidates
        if self.notes:
            out["notes"] = self.notes
        return out


def _clean(matrix: list[list[float]]) -> list[list[float]]:
    return [[0.0 if v == 0 else float(v) for v in row] for row in matrix]



# ---------------------------------------------------------------------------
# Residuals, leave-one-out, robust fitting, model choice


def residuals(mapping: Mapping, points: PointSet) -> Array:
    """``(n, 2)`` canvas residuals: target minus mapped tap."""
    tilt = points.tilt if mapping.parallax != (0.0, 0.0) else None
    return points.canvas - mapping.map(points.device, tilt)


def residuals_mm(
    mapping: Mapping, points: PointSet, res: Array, units_per_mm: tuple[float, float]
) -> Array:
    """Canvas residuals carried back to the tablet surface, in millimetres.

    The residual vector at each point is mapped through the inverse Jacobian of
    the mapping (canvas → device units) and divided by the resolution.
    """
    dev = mapping.corrected_device(points.device, points.tilt)
    jac = jacobian(mapping.matrix, dev)
    dev_res = np.linalg.solve(jac, res[:, :, None])[:, :, 0]
    return dev_res / np.asarray(units_per_mm, dtype=np.float64)


def leave_one_out(
    points: PointSet, model: str, parallax: bool = False, rows: Sequence[int] | None = None
) -> list[float | None]:
    """Prediction error of each point by a fit of all the others (None: not determinable).

    This is the error a user will see at a place where no target was tapped,
    a fairer figure than the in-sample RMS (which a flexible model shrinks).
    """
    rows = list(range(len(points))) if rows is None else list(rows)
    out: list[float | None] = [None] * len(points)
    need = MIN_POINTS[model] + (1 if parallax else 0)
    if len(rows) - 1 < need:
        return out
    for i in rows:
        others = [k for k in rows if k != i]
        mapping = quiet_fit(points.subset(others), model, parallax)
        if mapping is None:
            continue
        err = residuals(mapping, points.subset([i]))[0]
        out[i] = float(np.hypot(err[0], err[1]))
    return out


def _lts_start(
    points: PointSet, model: str, parallax: bool, seed: int
) -> tuple[list[int], str | None]:
    """Least-trimmed-squares over minimal subsets; returns the h best rows."""
    n = len(points)
    k = MIN_POINTS[model] + (1 if parallax else 0)
    h = (n + k + 1) // 2
    if h >= n:
        return list(range(n)), (
            f"{n} points leave no redundancy to detect misclicks with a {model} model "
            f"(needs ≥ {k + 2})"
        )
    total = math.comb(n, k)
    if total <= MAX_SUBSETS:
        subsets: Iterable[Sequence[int]] = itertools.combinations(range(n), k)
    else:
        rng = np.random.default_rng(seed)
        subsets = (
            sorted(rng.choice(n, size=k, replace=False).tolist()) for _ in range(MAX_SUBSETS)
        )
    best: tuple[float, list[int]] | None = None
    for sub in subsets:
        mapping = quiet_fit(points.subset(list(sub)), model, parallax, quick=True)
        if mapping is None:
            continue
        with np.errstate(all="ignore"):  # a subset's map may send a far point to infinity
            e2 = (residuals(mapping, points) ** 2).sum(axis=1)
        e2 = np.where(np.isfinite(e2), e2, np.inf)
        order = np.argsort(e2, kind="stable")
        score = float(e2[order[:h]].sum())
        if best is None or score < best[0]:
            best = (score, sorted(order[:h].tolist()))
    if best is None:
        return list(range(n)), "no non-degenerate subset for the robust search"
    return best[1], None


def _studentised(
    points: PointSet, mapping: Mapping, parallax: bool, inliers: list[int], floor: float,
    known: float | None = None,
) -> tuple[float, Array, float]:
    """Noise estimate and squared studentised residual of every point.

    Works in Hartley-normalised coordinates of the whole set.  With ``J`` the
    Jacobian of the inliers' residuals and ``P_i = J_i (JᵀJ)⁻¹ J_iᵀ`` the
    (2×2) leverage of point ``i``, an inlier's residual has covariance
    ``σ²(I − P_i)`` and an excluded point's prediction error ``σ²(I + P_i)``;
    the returned distances are ``r_iᵀ C_i⁻¹ r_i / σ²`` (chi-square, 2 dof, for
    points that fit).  ``σ² = |r_in|² / (2m − p)``, floored at ``floor``
    (canvas units), or exactly ``known`` when the noise is known.  Returns (sigma in
    canvas units, distances, their outlier limit).
    """
    model = mapping.model
    nz = Normalised.of(points)
    m_n = normalise_matrix(nz.tc @ mapping.matrix @ np.linalg.inv(nz.td))
    par_n = np.asarray(mapping.parallax) * nz.td[0, 0]
    theta = pack(model, m_n, par_n if parallax else None)
    r, j = residuals_jac(model, theta, nz.dn, nz.cn, nz.tn, parallax)
    r2, j3 = r.reshape(-1, 2), j.reshape(len(points), 2, -1)
    scale = nz.tc[0, 0]
    j_in = j3[inliers].reshape(-1, j.shape[1])
    dof = j_in.shape[0] - j.shape[1]
    ssr = float((r2[inliers] ** 2).sum())
    estimated = math.sqrt(ssr / dof) if dof > 0 else 0.0
    if known is not None:
        sigma_n, limit = known * scale, outlier_limit(None)
    else:
        sigma_n = max(estimated, floor * scale)
        # sigma estimated from dof residuals is itself uncertain: the studentised distance
        # / 2 follows F(2, dof), not chi2_2 / 2; the floor counts as known noise.
        limit = outlier_limit(dof if estimated > floor * scale else None)
    cov = np.linalg.pinv(j_in.T @ j_in)
    lev = np.einsum("nap,pq,nbq->nab", j3, cov, j3)  # (n, 2, 2)
    sign = np.full(len(points), 1.0)
    sign[inliers] = -1.0
    c = np.eye(2)[None] + sign[:, None, None] * lev + 1e-9 * np.eye(2)[None]
    dist2 = np.einsum("na,nab,nb->n", r2, np.linalg.inv(c), r2) / sigma_n**2
    return sigma_n / scale, dist2, limit


def outlier_limit(dof: int | None, p: float = 0.999) -> float:
    """Bound on a squared studentised 2-D residual that a good point stays under
    with probability ``p``: ``2·F(2, dof)`` quantile, ``chi2_2`` when sigma is known.

    F(2, ν) has CDF ``1 - (1 + 2x/ν)^(-ν/2)``, so its quantile is closed-form.
    """
    if dof is None:
        return -2.0 * math.log(1.0 - p)
    return 2.0 * (dof / 2.0) * ((1.0 - p) ** (-2.0 / dof) - 1.0)


def fit_points(
    points: PointSet,
    model: str = "affine",
    parallax: bool = False,
    robust: bool = True,
    min_sigma: float | None = None,
    units_per_mm: tuple[float, float] | None = None,
    seed: int = 0,
    noise: float | None = None,
) -> FitReport:
    """Fit, find misclicks, and report residuals and the leave-one-out error.

    ``model`` is ``affine``, ``homography`` or ``auto`` (the model with the
    smaller leave-one-out RMS; homography only when it beats affine by 10 %,
    since a flexible model that does not predict better is just fitting noise).

    Misclicks (``robust``): a least-trimmed-squares start over minimal subsets,
    then every point is re-classified by its leverage-corrected studentised
    residual (:func:`_studentised`) against the 99.9 % quantile of
    ``2·F(2, dof)``, sigma being the per-axis noise estimated from the inliers'
    residual sum of squares over their degrees of freedom, floored at
    ``min_sigma`` (default 1e-4 of the target spread, so that exact synthetic
    data does not make every rounding error an outlier).  With ``noise`` (a
    known per-axis tap noise, canvas units) sigma is that and the limit the
    chi-square one (3.72 sigma): the only way to find misclicks in a 5-point
    affine calibration, whose 4 spare equations leave too few degrees of
    freedom to estimate the noise.  The loop stops when the inlier set no
    longer changes.
    """
    if model == "auto":
        return _fit_auto(points, parallax, robust, min_sigma, units_per_mm, seed, noise)
    check_points(points, model, parallax)
    floor = min_sigma if min_sigma is not None else 1e-4 * spread(points.canvas)
    fit = _classify(points, model, parallax, robust, floor, noise, seed)
    return _report(points, model, parallax, fit, floor, noise, units_per_mm)


@dataclass
class _Classified:
    """Where the misclick search ended: the inliers, their fit and the noise."""

    inliers: list[int]
    mapping: Mapping
    condition: float
    sigma: float  # per-axis noise, canvas units
    limit: float  # outlier limit of the squared studentised distance
    notes: list[str]


def _classify(points: PointSet, model: str, parallax: bool, robust: bool, floor: float,
              noise: float | None, seed: int) -> _Classified:
    """The inliers (all points unless ``robust``): the LTS start, then re-classified
    by studentised residual until the set no longer changes (see :func:`fit_points`)."""
    n = len(points)
    notes: list[str] = []
    inliers = list(range(n))
    if robust:
        inliers, note = _lts_start(points, model, parallax, seed)
        if note:
            notes.append(note)
    mapping, cond = fit_mapping(points.subset(inliers), model, parallax)
    sigma, dist2, limit = _studentised(points, mapping, parallax, inliers, floor, noise)
    if robust and len(inliers) < n and noise is None:
        # The LTS set is the h best of n points: its residuals are a truncated sample
        # and underestimate the noise.  For chi2_2 (exponential, mean 2) truncated at
        # its alpha quantile q, E[X | X <= q] = 2 - q (1 - alpha) / alpha.
        alpha = len(inliers) / n
        q = -2.0 * math.log(1.0 - alpha)
        kappa = (2.0 - q * (1.0 - alpha) / alpha) / 2.0
        dist2 = dist2 * kappa
    need = MIN_POINTS[model] + (1 if parallax else 0)
    for _ in range(20):
        if not robust or notes:
            break
        new = sorted(np.flatnonzero(dist2 <= limit).tolist())
        if new == inliers or len(new) < need:
            break
        try:
            mapping, cond = fit_mapping(points.subset(new), model, parallax)
        except DegeneratePoints:
            break
        inliers = new
        sigma, dist2, limit = _studentised(points, mapping, parallax, inliers, floor, noise)
    return _Classified(inliers, mapping, cond, sigma, limit, notes)


def _report(points: PointSet, model: str, parallax: bool, fit: _Classified, floor: float,
            noise: float | None, units_per_mm: tuple[float, float] | None) -> FitReport:
    """Residuals, misclicks that cannot be told apart, leave-one-out error (and mm)."""
    n = len(points)
    inliers, mapping, limit, sigma = fit.inliers, fit.mapping, fit.limit, fit.sigma
    notes = list(fit.notes)
    threshold = math.sqrt(limit) * sigma
    res = residuals(mapping, points)
    e = np.hypot(res[:, 0], res[:, 1])
    outliers = [i for i in range(n) if i not in set(inliers)]
    ambiguous = _ambiguous_outliers(points, model, parallax, inliers, outliers, floor, noise,
                                    limit)
    for i, others in ambiguous.items():
        notes.append(
            f"the misclick at {points.labels[i]} cannot be told from one at "
            + " or ".join(points.labels[j] for j in others)
            + " with this target layout: tap those targets again (or use 9 points)"
        )
    loo = leave_one_out(points, model, parallax, inliers)
    loo_vals = [v for v in loo if v is not None]
    report = FitReport(
        mapping=mapping,
        rms=float(np.sqrt(np.mean(e[inliers] ** 2))),
        max=float(e[inliers].max()),
        residuals=res,
        inliers=inliers,
        outliers=outliers,
        sigma=sigma,
        threshold=threshold,
        loo_rms=float(np.sqrt(np.mean(np.square(loo_vals)))) if loo_vals else None,
        loo_max=float(max(loo_vals)) if loo_vals else None,
        loo_errors=loo,
        condition=fit.condition,
        notes=notes,
        ambiguous={i: list(v) for i, v in ambiguous.items()},
    )
    if units_per_mm is not None:
        report.residuals_mm = residuals_mm(mapping, points, res, units_per_mm)
        report.parallax_mm = (
            mapping.parallax[0] / units_per_mm[0],
            mapping.parallax[1] / units_per_mm[1],
        )
    return report


def _ambiguous_outliers(
    points: PointSet, model: str, parallax: bool, inliers: list[int], outliers: list[int],
    floor: float, noise: float | None, limit: float,
) -> dict[int, list[int]]:
    """Outliers that another point could equally well be blamed for.

    Some layouts cannot locate a misclick: with the 5-point layout (corners and
    centre) and an affine map, a slip at one corner breaks the same two
    constraints as the opposite slip at the diagonally opposite corner.  For
    each outlier ``i`` and inlier ``j``: if the fit with ``i`` restored and
    ``j`` removed keeps every kept point within the limit, ``j`` is an equally
    good culprit.
    """
    out: dict[int, list[int]] = {}
    for i in outliers:
        for j in inliers:
            swap = sorted([k for k in inliers if k != j] + [i])
            alt = quiet_fit(points.subset(swap), model, parallax)
            if alt is None:
                continue
            with np.errstate(all="ignore"):
                _s, d2, lim = _studentised(points, alt, parallax, swap, floor, noise)
            if np.isfinite(d2[swap]).all() and (d2[swap] <= lim).all() and d2[j] > lim:
                out.setdefault(i, []).append(j)
    return out


def _aicc(report: FitReport, parallax: bool) -> float | None:
    """Corrected Akaike criterion of a fit over its inliers (reported beside the
    leave-one-out error; ``None`` when the points leave too few degrees of freedom)."""
    n2 = 2 * len(report.inliers)
    p = N_PARAMS[report.model] + (2 if parallax else 0)
    ssr = float((report.residuals[report.inliers] ** 2).sum())
    if n2 - p - 1 <= 0 or ssr <= 0:
        return None
    return n2 * math.log(ssr / n2) + 2 * p + 2 * p * (p + 1) / (n2 - p - 1)


def _fit_auto(
    points: PointSet,
    parallax: bool,
    robust: bool,
    min_sigma: float | None,
    units_per_mm: tuple[float, float] | None,
    seed: int,
    noise: float | None,
) -> FitReport:
    affine = fit_points(points, "affine", parallax, robust, min_sigma, units_per_mm, seed, noise)
    candidates: dict[str, dict[str, object]] = {
        "affine": {"rms": affine.rms, "loo_rms": affine.loo_rms, "outliers": affine.outliers,
                   "aicc": _aicc(affine, parallax)}
    }
    chosen = affine
    reason = "affine: too few points to judge a homography by leave-one-out"
    try:
        homog = fit_points(
            points, "homography", parallax, robust, min_sigma, units_per_mm, seed, noise
        )
    except DegeneratePoints as exc:
        candidates["homography"] = {"refused": str(exc)}
        homog = None
    if homog is not None:
        candidates["homography"] = {
            "rms": homog.rms, "loo_rms": homog.loo_rms, "outliers": homog.outliers,
            "aicc": _aicc(homog, parallax),
        }
        if homog.loo_rms is not None and affine.loo_rms is not None:
            if homog.loo_rms < 0.9 * affine.loo_rms:
                chosen = homog
                reason = (
                    f"homography: leave-one-out RMS {homog.loo_rms:.3g} < 0.9 × affine's "
                    f"{affine.loo_rms:.3g}"
                )
            else:
                reason = (
                    f"affine: homography's leave-one-out RMS {homog.loo_rms:.3g} is not 10 % "
                    f"below affine's {affine.loo_rms:.3g}"
                )
    chosen.candidates = candidates
    chosen.notes = [*chosen.notes, f"auto chose {reason}"]
    return chosen

