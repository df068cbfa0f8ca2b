"""Tablet areas composed into one 3×3 matrix (OpenTabletDriver convention).

The chain, applied to a device-normalised point ``d`` (``[0, 1]²`` of the
device's full axis ranges), is::

    M = O · F · T(½, ½) · S(1/w, 1/h) · R(−θ) · T(−cx, −cy) · S(W, H)

* ``S(W, H)``: device-normalised → physical units (mm when the resolution is
  known, else device units, which then must be square for rotations and the
  aspect lock to be right),
* ``T(−c)``, ``R(−θ)``, ``S(1/w, 1/h)``, ``T(½, ½)``: the active area (centre
  ``c``, size ``w × h``, rotation ``θ``: the area rectangle turned θ degrees
  clockwise on the tablet surface, in tablet coordinates with y down, as
  OpenTabletDriver draws it; a tablet the *user* turns 90° clockwise
  (xsetwacom ``Rotate cw``) needs θ = 270; left-handed adds 180°) →
  area-normalised ``[0, 1]²``,
* ``F``: the fitted calibration (identity for an opaque tablet),
* ``O``: the output sub-rectangle of the canvas or screen.

:class:`AreaMapper` holds the settings and rebuilds ``M`` only when one
changes (``rebuilds`` counts it).  Points whose result falls outside the
output rectangle are clipped to it or dropped, per :attr:`AreaSettings.outside`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from station.calibration.errors import CalibrationError
from station.calibration.geometry import Array, project, rotation, scaling, translation

OUTSIDE_MODES = ("clip", "drop")
AREA_UNITS = ("normalised", "device", "mm")


@dataclass(frozen=True)
class DeviceGeometry:
    """Axis ranges of a device: ``x_min..x_max`` device units, resolution in units per mm."""

    x_min: float = 0.0
    x_max: float = 1.0
    y_min: float = 0.0
    y_max: float = 1.0
    resolution_x: float | None = None
    resolution_y: float | None = None

    def __post_init__(self) -> None:
        if not (self.x_max > self.x_min and self.y_max > self.y_min):
            raise CalibrationError(f"empty device range {self}")
        for r in (self.resolution_x, self.resolution_y):
            if r is not None and not r > 0:
                raise CalibrationError(f"resolution {r} must be > 0 units per mm")

    @property
    def has_mm(self) -> bool:
        return bool(self.resolution_x) and bool(self.resolution_y)

    @property
    def units_per_mm(self) -> tuple[float, float] | None:
        if self.resolution_x and self.resolution_y:
            return (self.resolution_x, self.resolution_y)
        return None

    def size(self, units: str) -> tuple[float, float]:
        """Width and height of the whole device in ``units``."""
        w, h = self.x_max - self.x_min, self.y_max - self.y_min
        if units == "normalised":
            return (1.0, 1.0)
        if units == "device":
            return (w, h)
        if units == "mm":
            upm = self.units_per_mm
            if upm is None:
                raise CalibrationError(
                    "the device reports no resolution: its area cannot be given in mm "
                    "(give it in device units)"
                )
            return (w / upm[0], h / upm[1])
        raise CalibrationError(f"unknown area units {units!r} (one of {', '.join(AREA_UNITS)})")

    def physical_units(self) -> str:
        """The units areas are composed in: mm where known, device units otherwise."""
        return "mm" if self.has_mm else "device"


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle ``x, y`` (top-left) ``width × height``."""

    x: float = 0.0
    y: float = 0.0
    width: float = 1.0
    height: float = 1.0

    def __post_init__(self) -> None:
        if not (self.width > 0 and self.height > 0):
            raise CalibrationError(f"rectangle {self} must have a positive size")


@dataclass(frozen=True)
class Area:
    """Active area on the tablet: centre, size and rotation (OpenTabletDriver).

    ``units``: ``normalised`` (fractions of the device), ``device`` or ``mm``.
    ``rotation``: degrees, any value; 0/90/180/270 are exact.
    """

    cx: float
    cy: float
    width: float
    height: float
    rotation: float = 0.0
    units: str = "normalised"

    def __post_init__(self) -> None:
        if self.units not in AREA_UNITS:
            raise CalibrationError(f"area units {self.units!r} not one of {', '.join(AREA_UNITS)}")
        if not (self.width > 0 and self.height > 0):
            raise CalibrationError(f"area {self.width}×{self.height} must have a positive size")


@dataclass(frozen=True)
class AreaSettings:
    """What a tablet user sets.

    Attributes:
        area: the active area; ``None`` = the whole tablet.
        left_handed: tablet turned upside down (adds 180° to the rotation).
        lock_aspect: shrink the area about its centre so that its aspect ratio
            equals the output's (``output_pixels`` gives the output's shape).
        outside: ``clip`` (pin to the edge) or ``drop`` samples outside.
        output: sub-rectangle of the canvas/screen, canvas-normalised.
        output_pixels: width, height of the whole canvas/screen in pixels
            (needed for the aspect lock).
    """

    area: Area | None = None
    left_handed: bool = False
    lock_aspect: bool = False
    outside: str = "clip"
    output: Rect = field(default_factory=Rect)
    output_pixels: tuple[int, int] | None = None

    def __post_init__(self) -> None:
        if self.outside not in OUTSIDE_MODES:
            raise CalibrationError(f"outside {self.outside!r} not one of clip, drop")
        o = self.output
        if o.x < 0 or o.y < 0 or o.x + o.width > 1 + 1e-12 or o.y + o.height > 1 + 1e-12:
            raise CalibrationError(f"output rectangle {o} leaves the canvas [0, 1]²")
        if self.lock_aspect and self.output_pixels is None:
            raise CalibrationError("the aspect lock needs the output size in pixels")

    def with_(self, **changes: Any) -> AreaSettings:
        return replace(self, **changes)

    def to_json(self) -> dict[str, object]:
        out: dict[str, object] = {
            "left_handed": self.left_handed,
            "lock_aspect": self.lock_aspect,
            "outside": self.outside,
            "output": {"x": self.output.x, "y": self.output.y,
                       "width": self.output.width, "height": self.output.height},
        }
        if self.area is not None:
            a = self.area
            out["area"] = {"cx": a.cx, "cy": a.cy, "width": a.width, "height": a.height,
                           "rotation": a.rotation, "units": a.units}
        if self.output_pixels is not None:
            out["output_pixels"] = list(self.output_pixels)
        return out

    @classmethod
    def from_json(cls, rec: dict[str, Any]) -> AreaSettings:
        area = rec.get("area")
        o = rec.get("output", {})
        pixels = rec.get("output_pixels")
        return cls(
            area=Area(**area) if area else None,
            left_handed=bool(rec.get("left_handed", False)),
            lock_aspect=bool(rec.get("lock_aspect", False)),
            outside=rec.get("outside", "clip"),
            output=Rect(o.get("x", 0.0), o.get("y", 0.0), o.get("width", 1.0),
                        o.get("height", 1.0)),
            output_pixels=(int(pixels[0]), int(pixels[1])) if pixels else None,
        )


def area_matrix(settings: AreaSettings, geometry: DeviceGeometry) -> Array:
    """Device-normalised → area-normalised ``[0, 1]²`` (the part before the fit).

    The default settings (whole tablet, not left-handed, no aspect lock) give
    the identity *exactly*, so a fitted or imported matrix passes unchanged.
    """
    if settings.area is None and not settings.left_handed and not settings.lock_aspect:
        return np.eye(3)
    units = geometry.physical_units()
    size_w, size_h = geometry.size(units)
    to_phys = scaling(size_w, size_h)
    if settings.area is None:
        cx, cy, w, h, rot = size_w / 2, size_h / 2, size_w, size_h, 0.0
    else:
        a = settings.area
        sx, sy = geometry.size(a.units)
        fx, fy = size_w / sx, size_h / sy  # area units → physical units
        cx, cy, w, h, rot = a.cx * fx, a.cy * fy, a.width * fx, a.height * fy, a.rotation
    if settings.left_handed:
        rot += 180.0
    if settings.lock_aspect and settings.output_pixels is not None:
        px_w = settings.output.width * settings.output_pixels[0]
        px_h = settings.output.height * settings.output_pixels[1]
        want = px_w / px_h
        if w / h > want:
            w = h * want
        else:
            h = w / want
    return (
        translation(0.5, 0.5)
        @ scaling(1.0 / w, 1.0 / h)
        @ rotation(-rot)
        @ translation(-cx, -cy)
        @ to_phys
    )


def output_matrix(output: Rect) -> Array:
    """Output-normalised ``[0, 1]²`` → the canvas sub-rectangle."""
    return translation(output.x, output.y) @ scaling(output.width, output.height)


class AreaMapper:
    """The composed matrix of area, fit and output; rebuilt only when a setting changes.

    ``rebuilds`` counts the compositions (tests use it to show that an unchanged
    setting costs nothing per sample).
    """

    def __init__(
        self,
        settings: AreaSettings | None = None,
        geometry: DeviceGeometry | None = None,
        fit: Array | None = None,
    ) -> None:
        self._settings = settings or AreaSettings()
        self._geometry = geometry or DeviceGeometry()
        self._fit = np.eye(3) if fit is None else np.array(fit, dtype=np.float64)
        self._matrix: Array | None = None
        self.rebuilds = 0

    @property
    def settings(self) -> AreaSettings:
        return self._settings

    @property
    def geometry(self) -> DeviceGeometry:
        return self._geometry

    @property
    def fit(self) -> Array:
        return self._fit

    def set(self, **changes: Any) -> None:
        """Change settings (``area=``, ``left_handed=`` …); no rebuild if nothing differs."""
        new = replace(self._settings, **changes)
        if new != self._settings:
            self._settings = new
            self._matrix = None

    def set_geometry(self, geometry: DeviceGeometry) -> None:
        if geometry != self._geometry:
            self._geometry = geometry
            self._matrix = None

    def set_fit(self, fit: Array) -> None:
        fit = np.asarray(fit, dtype=np.float64)
        if not np.array_equal(fit, self._fit):
            self._fit = fit.copy()
            self._matrix = None

    @property
    def matrix(self) -> Array:
        """Device-normalised → canvas-normalised."""
        if self._matrix is None:
            s = self._settings
            self._matrix = output_matrix(s.output) @ self._fit @ area_matrix(s, self._geometry)
            self.rebuilds += 1
        return self._matrix

    def map(self, device: Array) -> tuple[Array, Array]:
        """Canvas points of ``(n, 2)`` device-normalised points and an inside mask.

        Outside points are clipped to the output rectangle (their mask is False
        either way; callers that drop use the mask).
        """
        pts = project(self.matrix, np.asarray(device, dtype=np.float64).reshape(-1, 2))
        o = self._settings.output
        lo = np.array([o.x, o.y])
        hi = lo + np.array([o.width, o.height])
        eps = 1e-12
        inside = ((pts >= lo - eps) & (pts <= hi + eps)).all(axis=1) & np.isfinite(pts).all(axis=1)
        clipped = np.clip(np.nan_to_num(pts, nan=0.0), lo, hi)
        return np.clip(clipped, 0.0, 1.0), inside
