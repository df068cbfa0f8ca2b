"""A device's calibration and its application to pen samples.

:class:`Calibration` is what a calibration file holds: the device it belongs
to, the fitted mapping (device-normalised → output-normalised, with parallax),
the area settings, pressure and tilt.  :meth:`Calibration.apply` turns a
device-normalised :class:`PenSample` into a canvas-normalised one and is the
``transform`` hook of the drivers' normaliser; samples dropped outside the
area raise :class:`OutsideArea` (an ``EventError``, which the normaliser
counts and drops).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from station.calibration.area import AreaMapper, AreaSettings, DeviceGeometry
from station.calibration.errors import CalibrationError, OutsideArea
from station.calibration.geometry import Array
from station.calibration.pressure import PressureSettings, TiltSettings

from station.events import PenSample

MAX_MATRIX_ENTRY = 1e3
# A fit in raw device units has a tiny determinant: (1/44704)x(1/29603) = 7.6e-10 on an
# Intuos Pro L. 1e-11 admits tablets up to about 300,000 units a side (the largest real
# ones report under 100,000) and still refuses a matrix that squeezes the tablet to a spot.
MIN_MATRIX_DET = 1e-11


@dataclass(frozen=True)
class DeviceId:
    """Which device a calibration belongs to: USB ids and, where known, its serial."""

    vid: int
    pid: int
    serial: str | None = None
    name: str | None = None

    def __post_init__(self) -> None:
        for label, v in (("vid", self.vid), ("pid", self.pid)):
            if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= 0xFFFF:
                raise CalibrationError(f"{label} {v!r} must be an integer 0..0xffff")

    @property
    def key(self) -> str:
        """File stem: ``056a-00fa`` or ``056a-00fa-SERIAL`` (serial made file-safe)."""
        base = f"{self.vid:04x}-{self.pid:04x}"
        if self.serial:
            safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in self.serial)
            return f"{base}-{safe}"
        return base

    def matches(self, other: DeviceId) -> bool:
        """Same vid/pid; serials must agree where both are known."""
        if (self.vid, self.pid) != (other.vid, other.pid):
            return False
        return not (self.serial and other.serial and self.serial != other.serial)

    def describe(self) -> str:
        s = f"{self.vid:04x}:{self.pid:04x}"
        return f"{s} serial {self.serial}" if self.serial else s


@dataclass(frozen=True)
class FitInfo:
    """The fitted part of a calibration.

    Attributes:
        model: ``identity``, ``affine`` or ``homography``.
        matrix: 3×3, area-normalised (device-normalised with the default area)
            → output-normalised.
        parallax: ``(hx, hy)`` in device-normalised units per unit ``tan(tilt)``.
        rms, max, loo_rms: canvas-normalised residuals of the fit (None if unknown).
        points: number of points used (inliers).
    """

    model: str = "identity"
    matrix: tuple[tuple[float, ...], ...] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    parallax: tuple[float, float] = (0.0, 0.0)
    rms: float | None = None
    max: float | None = None
    loo_rms: float | None = None
    points: int = 0

    def __post_init__(self) -> None:
        m = np.asarray(self.matrix, dtype=np.float64)
        if m.shape != (3, 3) or not np.isfinite(m).all():
            raise CalibrationError("a calibration matrix must be 3×3 finite numbers")
        # Area-normalised: a real calibration maps the unit square to about the unit
        # square (entries near 0..1, its area within a few times).  Beyond these bounds
        # every sample lands on the canvas's edge (1e308 puts them all at (1, 1)).
        if np.abs(m).max() > MAX_MATRIX_ENTRY:
            raise CalibrationError(f"a calibration matrix entry is {np.abs(m).max():.3g}: "
                                   f"absurd (at most {MAX_MATRIX_ENTRY:g} in size)")
        det = float(np.linalg.det(m))
        if abs(det) < MIN_MATRIX_DET:
            raise CalibrationError(f"the calibration matrix is singular (determinant "
                                   f"{det:.3g}: it squeezes the tablet to nothing)")
        object.__setattr__(self, "matrix", tuple(tuple(float(v) for v in row) for row in m))
        if not all(math.isfinite(v) for v in self.parallax):
            raise CalibrationError("parallax must be finite")
        object.__setattr__(self, "parallax", (float(self.parallax[0]), float(self.parallax[1])))

    @property
    def array(self) -> Array:
        return np.array(self.matrix, dtype=np.float64)


@dataclass
class Calibration:
    """Everything needed to turn a device's samples into canvas samples."""

    device: DeviceId
    geometry: DeviceGeometry = field(default_factory=DeviceGeometry)
    fit: FitInfo = field(default_factory=FitInfo)
    area: AreaSettings = field(default_factory=AreaSettings)
    pressure: PressureSettings = field(default_factory=PressureSettings)
    tilt: TiltSettings = field(default_factory=TiltSettings)
    created: str | None = None
    notes: str | None = None
    _mapper: AreaMapper = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        self._mapper = AreaMapper(self.area, self.geometry, self.fit.array)

    def _sync(self) -> AreaMapper:
        # Settings may be replaced on the dataclass; the mapper rebuilds only on a change.
        m = self._mapper
        if m.settings != self.area:
            m.set(**{f: getattr(self.area, f) for f in self.area.__dataclass_fields__})
        m.set_geometry(self.geometry)
        m.set_fit(self.fit.array)
        return m

    @property
    def matrix(self) -> Array:
        """The composed device-normalised → canvas-normalised 3×3 matrix."""
        return self._sync().matrix

    @property
    def mapper(self) -> AreaMapper:
        return self._sync()

    def with_(self, **changes: Any) -> Calibration:
        return replace(self, **changes)

    def map_points(self, device: Array, tilt_deg: Array | None = None) -> tuple[Array, Array]:
        """Canvas points and inside mask for ``(n, 2)`` device-normalised points."""
        pts = np.asarray(device, dtype=np.float64).reshape(-1, 2)
        if tilt_deg is not None and self.fit.parallax != (0.0, 0.0):
            pts = pts + np.asarray(self.fit.parallax) * np.tan(np.radians(tilt_deg))
        return self._sync().map(pts)

    def apply(self, sample: PenSample) -> PenSample:
        """A device-normalised sample → canvas-normalised, with pressure and tilt calibrated.

        Order: tilt offset; parallax (by the corrected tilt); the composed
        matrix; clip (or raise :class:`OutsideArea` to drop); pressure
        threshold → maximum → curve (``touching`` ends below the threshold).
        """
        tx, ty = self.tilt.correct(sample.tilt_x, sample.tilt_y)
        canvas, inside = self.map_points(np.array([[sample.x, sample.y]]), np.array([[tx, ty]]))
        if not inside[0] and self.area.outside == "drop":
            raise OutsideArea(f"({sample.x:.4f}, {sample.y:.4f}) outside the active area")
        pressure, touching = self.pressure.shape(sample.pressure, sample.touching)
        return sample.with_(
            x=float(canvas[0, 0]), y=float(canvas[0, 1]), tilt_x=tx, tilt_y=ty,
            pressure=pressure, touching=touching,
        )

    __call__ = apply

    def apply_or_none(self, sample: PenSample) -> PenSample | None:
        """:meth:`apply`, with ``None`` for a dropped sample."""
        try:
            return self.apply(sample)
        except OutsideArea:
            return None
