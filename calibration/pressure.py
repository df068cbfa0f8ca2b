"""Pressure and tilt calibration.

* Tip threshold and maximum from two short recordings: the user presses as
  lightly as they still want to paint, then as hard as they comfortably will.
* A pressure curve as a cubic Bézier through (0,0), (x1,y1), (x2,y2), (1,1)
  (libinput / xf86-input-wacom convention; x1, x2 in [0, 1] keep x(t)
  monotonic so the curve is a function), fitted to target responses.
* Tilt offset: the mean tilt reported while the pen is held upright.

:class:`PressureSettings` (threshold, maximum, curve) is what a calibration
file holds; it shapes samples through :class:`station.pressure.PressureShaping`,
the station's one pressure shaping, which the drivers' normaliser uses for a
curve of its own too (``station driver --pressure-curve`` without a
calibration).  ``station driver`` gives a device one shaping
(:func:`station.drivers.calibrated.settle_pressure`).

Pressures here are device-normalised fractions ``[0, 1]`` (what the
normaliser publishes); tilts are degrees.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares
from station.calibration.errors import CalibrationError
from station.calibration.geometry import Array

from station.pressure import LINEAR, PressureShaping


def _bezier(t: Array, a: float, b: float) -> Array:
    """One coordinate of the cubic Bézier with end points 0 and 1."""
    s = 1.0 - t
    return 3.0 * s * s * t * a + 3.0 * s * t * t * b + t**3


def bezier_eval(curve: Sequence[float] | Array, x: Array | float) -> Array:
    """``y`` of the pressure curve at input ``x`` (clamped to [0, 1]).

    Solves ``x(t) = x`` by bisection (40 halvings: 1e-12 in t), vectorised;
    x(t) is monotonic for x1, x2 in [0, 1].
    """
    x1, y1, x2, y2 = (float(v) for v in curve)
    xs = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    lo = np.zeros_like(xs)
    hi = np.ones_like(xs)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        below = _bezier(mid, x1, x2) < xs
        lo = np.where(below, mid, lo)
        hi = np.where(below, hi, mid)
    return np.clip(_bezier(0.5 * (lo + hi), y1, y2), 0.0, 1.0)


def check_curve(curve: Sequence[float]) -> tuple[float, float, float, float]:
    if len(curve) != 4:
        raise CalibrationError(f"a pressure curve has 4 numbers x1,y1,x2,y2, got {len(curve)}")
    vals = tuple(float(v) for v in curve)
    if not all(math.isfinite(v) and 0.0 <= v <= 1.0 for v in vals):
        raise CalibrationError(f"pressure curve {vals} must lie in [0, 1]")
    return vals  # type: ignore[return-value]


def fit_curve(
    inputs: Sequence[float], targets: Sequence[float]
) -> tuple[float, float, float, float]:
    """Bézier control points whose curve best maps ``inputs`` to ``targets``.

    Least squares on the output over (x1, y1, x2, y2) with SciPy's trust-region
    reflective solver (Levenberg–Marquardt needs at least as many targets as
    parameters; two or three targets are allowed), parameterised through a
    logistic so they stay inside [0, 1], started from a small grid (the problem
    is not convex).
    """
    xs = np.asarray(inputs, dtype=np.float64)
    ys = np.asarray(targets, dtype=np.float64)
    if xs.shape != ys.shape or xs.ndim != 1:
        raise CalibrationError("pressure inputs and targets must be two lists of equal length")
    if len(xs) < 2:
        raise CalibrationError(f"{len(xs)} pressure target(s): need at least 2")
    if not (np.isfinite(xs).all() and np.isfinite(ys).all()):
        raise CalibrationError("pressure targets hold NaN or infinite values")
    if xs.min() < 0 or xs.max() > 1 or ys.min() < 0 or ys.max() > 1:
        raise CalibrationError("pressure inputs and targets must lie in [0, 1]")

    def unpack(z: Array) -> Array:
        return 1.0 / (1.0 + np.exp(-np.clip(z, -30, 30)))

    def fun(z: Array) -> Array:
        return bezier_eval(unpack(z), xs) - ys

    best: tuple[float, Array] | None = None
    for a in (0.2, 0.5, 0.8):
        for b in (0.2, 0.5, 0.8):
            z0 = np.log(np.array([a, b, 1 - b, 1 - a]) / (1 - np.array([a, b, 1 - b, 1 - a])))
            sol = least_squares(fun, z0, jac="3-point", method="trf", xtol=1e-12, ftol=1e-12,
                                gtol=1e-12, max_nfev=600)
            cost = float(sol.fun @ sol.fun)
            if best is None or cost < best[0]:
                best = (cost, np.asarray(sol.x))
    assert best is not None  # the grid is never empty
    p = unpack(best[1])
    return (float(p[0]), float(p[1]), float(p[2]), float(p[3]))


@dataclass(frozen=True)
class PressureSettings:
    """Tip threshold, maximum and curve.

    ``threshold``: raw fraction below which the pen does not paint; ``maximum``:
    raw fraction that gives full pressure; between them the pressure is
    rescaled to [0, 1] and passed through ``curve``.
    """

    threshold: float = 0.0
    maximum: float = 1.0
    curve: tuple[float, float, float, float] = LINEAR
    _shaping: PressureShaping = field(default_factory=PressureShaping, init=False, repr=False,
                                      compare=False)

    def __post_init__(self) -> None:
        if not (0.0 <= self.threshold < self.maximum <= 1.0):
            raise CalibrationError(
                f"pressure threshold {self.threshold} and maximum {self.maximum} must satisfy "
                "0 <= threshold < maximum <= 1"
            )
        object.__setattr__(self, "curve", check_curve(self.curve))
        object.__setattr__(self, "_shaping",
                           PressureShaping(self.threshold, self.maximum, self.curve))

    def shape(self, pressure: float, touching: bool) -> tuple[float, bool]:
        """One sample's pressure and contact, shaped (:class:`station.pressure.PressureShaping`)."""
        return self._shaping(pressure, touching)

    def map(self, raw: Array | float) -> Array:
        """Calibrated pressure of raw fractions (0 below the threshold)."""
        p = (np.asarray(raw, dtype=np.float64) - self.threshold) / (self.maximum - self.threshold)
        p = np.clip(p, 0.0, 1.0)
        return p if self.curve == LINEAR else bezier_eval(self.curve, p)

    def map_one(self, raw: float) -> float:
        return float(self.map(np.array([raw]))[0])


def threshold_and_maximum(
    light: Sequence[float], hard: Sequence[float], margin: float = 0.5
) -> tuple[float, float]:
    """Tip threshold and maximum from a light press and a hard press.

    The threshold sits ``margin`` of the way from zero to the light press's
    typical (median) pressure, so the lightest intended touch paints with
    headroom against noise; the maximum is the hard press's 90th percentile,
    so that full pressure is reachable without straining.  Pressures are the
    samples *in contact* (zeros ignored).
    """
    lt = np.asarray([v for v in light if v > 0], dtype=np.float64)
    hd = np.asarray([v for v in hard if v > 0], dtype=np.float64)
    if len(lt) < 3 or len(hd) < 3:
        raise CalibrationError(
            "pressure calibration needs at least 3 touching samples of a light and a hard press"
        )
    light_level = float(np.median(lt))
    threshold = margin * light_level
    maximum = float(np.percentile(hd, 90))
    if not maximum > light_level:
        raise CalibrationError(
            f"the hard press (p90 {maximum:.3f}) is not harder than the light press "
            f"(median {light_level:.3f}): press again, harder"
        )
    return threshold, min(maximum, 1.0)


@dataclass(frozen=True)
class TiltSettings:
    """Tilt offset in degrees, subtracted from the reported tilt."""

    offset_x: float = 0.0
    offset_y: float = 0.0

    def correct(self, tilt_x: float, tilt_y: float) -> tuple[float, float]:
        return (
            min(90.0, max(-90.0, tilt_x - self.offset_x)),
            min(90.0, max(-90.0, tilt_y - self.offset_y)),
        )


def tilt_offset(samples: Sequence[tuple[float, float]]) -> TiltSettings:
    """Tilt offset from samples taken with the pen held upright (mean tilt)."""
    arr = np.asarray(samples, dtype=np.float64).reshape(-1, 2)
    if len(arr) < 3:
        raise CalibrationError("tilt offset needs at least 3 samples of the upright pen")
    if not np.isfinite(arr).all():
        raise CalibrationError("tilt samples hold NaN or infinite values")
    mean = arr.mean(axis=0)
    return TiltSettings(float(mean[0]), float(mean[1]))
