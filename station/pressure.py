"""How a pen's pressure is shaped: one threshold, one maximum, one curve.

:class:`PressureShaping` is the one piece of code that shapes a sample's
pressure.  The drivers' normaliser (a curve given to ``station driver`` without
a calibration) and a calibration (:class:`station.calibration.pressure.PressureSettings`,
what a calibration file holds) both shape through it, and ``station driver``
gives each device one shaping (:func:`station.drivers.calibrated.settle_pressure`).

Pressures are fractions ``[0, 1]`` of the device-normalised range (what the
normaliser publishes).  Pure Python, one sample at a time: it runs in every
driver process at the device's report rate.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field

Curve = tuple[float, float, float, float]
"""Bézier control points ``(x1, y1, x2, y2)`` in ``[0, 1]``."""

LINEAR: Curve = (0.0, 0.0, 1.0, 1.0)


class BezierCurve:
    """The pressure curve: cubic Bézier (0,0), (x1,y1), (x2,y2), (1,1) as y = f(x),
    tabulated once (1025 points) and evaluated by binary search and linear
    interpolation (within ~1e-5 of the exact curve, at a microsecond a sample).

    With x1, x2 in [0, 1] x(s) is monotonic, so the table is a function.
    """

    def __init__(self, x1: float, y1: float, x2: float, y2: float, points: int = 1025) -> None:
        self.control = (x1, y1, x2, y2)
        xs, ys = [], []
        for i in range(points):
            s = i / (points - 1)
            a, b, c = 3 * (1 - s) ** 2 * s, 3 * (1 - s) * s * s, s**3
            xs.append(a * x1 + b * x2 + c)
            ys.append(a * y1 + b * y2 + c)
        for i in range(1, points):  # guard against rounding making x non-monotonic
            xs[i] = max(xs[i], xs[i - 1])
        self._xs, self._ys = xs, ys

    def __call__(self, p: float) -> float:
        if p <= 0.0:
            return 0.0
        if p >= 1.0:
            return 1.0
        xs, ys = self._xs, self._ys
        i = bisect.bisect_left(xs, p)
        x0, x1 = xs[i - 1], xs[i]
        f = 0.0 if x1 == x0 else (p - x0) / (x1 - x0)
        return min(1.0, max(0.0, ys[i - 1] + f * (ys[i] - ys[i - 1])))


@dataclass(frozen=True)
class PressureShaping:
    """Threshold, maximum and curve, applied to one sample at a time.

    Attributes:
        threshold: pressure fraction below which the pen does not touch.
        maximum: pressure fraction that gives full pressure (> ``threshold``).
        curve: Bézier control points; :data:`LINEAR` = none.

    The ranges are checked by whoever holds the settings (the normaliser's config,
    a calibration file); this class only applies them.
    """

    threshold: float = 0.0
    maximum: float = 1.0
    curve: Curve = LINEAR
    _table: BezierCurve | None = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if tuple(self.curve) != LINEAR:
            object.__setattr__(self, "_table", BezierCurve(*self.curve))

    @property
    def is_identity(self) -> bool:
        """Whether shaping leaves every pressure as it is (no threshold, no curve)."""
        return self.threshold == 0.0 and self.maximum == 1.0 and self._table is None

    def __call__(self, pressure: float, touching: bool) -> tuple[float, bool]:
        """One sample's pressure and contact, shaped: below the threshold the pen does
        not touch (pressure 0); from threshold to maximum the pressure is rescaled to
        [0, 1], then passed through the curve.  The identity leaves both as they are."""
        if self.is_identity:
            return pressure, touching
        if touching and pressure < self.threshold:
            touching = False
        if not touching:
            return 0.0, False
        p = min(1.0, max(0.0, (pressure - self.threshold) / (self.maximum - self.threshold)))
        return (p if self._table is None else self._table(p)), True

    def record(self) -> dict[str, object]:
        """As JSON (status messages, session-log headers)."""
        return {"threshold": self.threshold, "maximum": self.maximum, "curve": list(self.curve)}
