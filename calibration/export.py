"""Export to and import from libinput's calibration matrix and tslib's ``pointercal``.

libinput
    ``LIBINPUT_CALIBRATION_MATRIX`` holds the first two rows ``a b c d e f``
    of a 3×3 matrix (last row 0 0 1) from device-normalised to
    screen-normalised coordinates.  We write the udev rule property line
    ``ENV{LIBINPUT_CALIBRATION_MATRIX}="a b c d e f"`` and read that, the hwdb
    form ``LIBINPUT_CALIBRATION_MATRIX=a b c d e f`` or the six bare numbers.
    Numbers are written with Python's shortest round-trip repr, so the float64
    matrix survives export → import bit for bit, and a line survives import →
    export character for character (for lines we wrote).

tslib ``pointercal``
    Seven integers ``a b c d e f s`` then ``xres yres``: screen pixel
    ``x = (c + a·X + b·Y) / s``, ``y = (f + d·X + e·Y) / s`` from raw device
    units ``X, Y``, with ``s = 65536``.  Integers cannot hold every float, so a
    float calibration is quantised once on export (each coefficient to the
    nearest 1/65536; the pixel error this causes is at most
    ``0.5·(1 + |X| + |Y|)/65536`` px).  "Exact" for tslib means exact in its
    own representation: import → export gives back the same seven (nine)
    integers, and export → import → export is a fixed point.

Only affine mappings without parallax, with the whole canvas as output, can
be exported; anything else raises :class:`ExportError` saying why.
"""

from __future__ import annotations

import math
import re

import numpy as np
from station.calibration.area import AreaSettings, DeviceGeometry
from station.calibration.errors import CalibrationFileError, ExportError
from station.calibration.model import Calibration, DeviceId, FitInfo

TSLIB_SCALE = 65536
LIBINPUT_PROPERTY = "LIBINPUT_CALIBRATION_MATRIX"


def _exportable_matrix(cal: Calibration, target: str) -> np.ndarray:
    m = cal.matrix
    if cal.fit.parallax != (0.0, 0.0):
        raise ExportError(f"{target} has no parallax correction; this calibration needs one")
    if m[2, 0] != 0.0 or m[2, 1] != 0.0 or m[2, 2] != 1.0:
        raise ExportError(
            f"{target} takes an affine matrix; this calibration is projective "
            "(refit with --model affine to export)"
        )
    return m


MIN_SPAN = 0.05  # of the screen: a tablet mapped to less is a matrix in device units
NORMALISED_REACH = (-1.0, 2.0)
"""Where a normalised matrix may send the tablet's corners: the screen is [0, 1]; a
tablet area larger than the screen reaches a little past it, never to 815.7."""


def check_normalised(m: np.ndarray, target: str) -> None:
    """Refuse a matrix that is not device-normalised → screen-normalised (what libinput
    and tslib take): one whose corners land far off the screen was fitted to pixels."""
    lo, hi = NORMALISED_REACH
    xs, ys = [], []
    for cx, cy in ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)):
        x = m[0, 0] * cx + m[0, 1] * cy + m[0, 2]
        y = m[1, 0] * cx + m[1, 1] * cy + m[1, 2]
        xs.append(x)
        ys.append(y)
        if not (lo <= x <= hi and lo <= y <= hi):
            raise ExportError(
                f"{target} expects a normalised 3x3 matrix (the tablet's corners land in "
                f"about [0, 1]); this one sends corner ({cx:g}, {cy:g}) to ({x:.4g}, "
                f"{y:.4g}): were the fit's canvas coordinates pixels? (refit with --units "
                "px --canvas WxH)")
    span = min(max(xs) - min(xs), max(ys) - min(ys))
    if span < MIN_SPAN:
        raise ExportError(
            f"{target} expects a normalised 3x3 matrix; this one sends the whole tablet to "
            f"a spot {span:.3g} wide: were the fit's device coordinates in device units? "
            "(refit with --device-max XMAX,YMAX)")


def to_libinput(cal: Calibration) -> tuple[float, float, float, float, float, float]:
    """The six numbers of ``LIBINPUT_CALIBRATION_MATRIX`` (device-normalised → canvas)."""
    m = _exportable_matrix(cal, "libinput")
    check_normalised(m, "libinput")
    return tuple(float(v) for v in m[:2, :].ravel())  # type: ignore[return-value]


def _num(v: float) -> str:
    if v == 0.0:
        return "0"  # also turns -0.0 into 0
    if v == int(v) and abs(v) < 1e15:
        return str(int(v))
    return repr(float(v))


def libinput_line(cal: Calibration) -> str:
    """The udev rule property line."""
    nums = " ".join(_num(v) for v in to_libinput(cal))
    return f'ENV{{{LIBINPUT_PROPERTY}}}="{nums}"'


_LIBINPUT_RE = re.compile(
    r'^\s*(?:ENV\{\s*' + LIBINPUT_PROPERTY + r'\s*\}\s*=\s*"([^"]*)"'
    r"|" + LIBINPUT_PROPERTY + r"\s*=\s*(.*?)"
    r"|([-+0-9.eE\s]+))\s*,?\s*$"
)


def parse_libinput(text: str, device: DeviceId, where: str = "<libinput>") -> Calibration:
    """A calibration from a ``LIBINPUT_CALIBRATION_MATRIX`` line (or its six numbers)."""
    line = next((ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")),
                "")
    match = _LIBINPUT_RE.match(line)
    if not match:
        raise CalibrationFileError(
            f"not a {LIBINPUT_PROPERTY} line (expected ENV{{{LIBINPUT_PROPERTY}}}=\"a b c d e f\")",
            where,
        )
    body = next(g for g in match.groups() if g is not None)
    parts = body.replace(",", " ").split()
    if len(parts) != 6:
        raise CalibrationFileError(f"{LIBINPUT_PROPERTY} needs 6 numbers, got {len(parts)}", where)
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        raise CalibrationFileError(
            f"{LIBINPUT_PROPERTY} numbers {body!r} do not parse", where
        ) from None
    if not all(math.isfinite(v) for v in vals):
        raise CalibrationFileError(f"{LIBINPUT_PROPERTY} holds NaN or infinity", where)
    matrix = (tuple(vals[0:3]), tuple(vals[3:6]), (0.0, 0.0, 1.0))
    try:
        fit = FitInfo(model="affine", matrix=matrix)
    except Exception as exc:  # singular: CalibrationError
        raise CalibrationFileError(str(exc), where) from None
    return Calibration(device=device, fit=fit, notes="imported from libinput")


def to_tslib(cal: Calibration, xres: int, yres: int) -> tuple[int, ...]:
    """The nine integers ``a b c d e f s xres yres`` of a tslib ``pointercal``."""
    if xres < 1 or yres < 1:
        raise ExportError(f"screen size {xres}×{yres} must be positive")
    m = _exportable_matrix(cal, "tslib")
    g = cal.geometry
    w, h = g.x_max - g.x_min, g.y_max - g.y_min
    out: list[int] = []
    for row, res in ((m[0], xres), (m[1], yres)):
        k = TSLIB_SCALE * res
        a = row[0] * k / w
        b = row[1] * k / h
        c = (row[2] - row[0] * g.x_min / w - row[1] * g.y_min / h) * k
        out += [int(round(a)), int(round(b)), int(round(c))]
    if any(abs(v) >= 2**31 for v in out):
        raise ExportError("the calibration overflows tslib's 32-bit coefficients")
    return (*out, TSLIB_SCALE, int(xres), int(yres))


def tslib_line(cal: Calibration, xres: int, yres: int) -> str:
    return " ".join(str(v) for v in to_tslib(cal, xres, yres))


def parse_tslib(
    text: str,
    device: DeviceId,
    geometry: DeviceGeometry,
    where: str = "<pointercal>",
    xres: int | None = None,
    yres: int | None = None,
) -> Calibration:
    """A calibration from a ``pointercal`` line.

    Seven integers need ``xres``/``yres`` from the caller; nine carry them; a
    tenth (rotation) must be 0.  The result remembers the screen size in
    ``area.output_pixels`` so that :func:`to_tslib` can write the line back.
    """
    tokens = text.split()
    if len(tokens) not in (7, 9, 10):
        raise CalibrationFileError(
            f"a pointercal line has 7, 9 or 10 integers, got {len(tokens)}", where
        )
    try:
        ints = [int(t) for t in tokens]
    except ValueError:
        raise CalibrationFileError(f"pointercal values {text.strip()!r} are not integers",
                                   where) from None
    if any(not -(1 << 31) <= v < 1 << 31 for v in ints):  # tslib reads C ints
        raise CalibrationFileError("pointercal values must fit 32-bit integers", where)
    if len(ints) >= 9:
        xres, yres = ints[7], ints[8]
    if len(ints) == 10 and ints[9] != 0:
        raise CalibrationFileError(f"pointercal rotation {ints[9]} is not supported (only 0)",
                                   where)
    if xres is None or yres is None:
        raise CalibrationFileError("a 7-number pointercal needs the screen size (xres yres)",
                                   where)
    if xres < 1 or yres < 1:
        raise CalibrationFileError(f"pointercal screen size {xres}×{yres} is not positive", where)
    a, b, c, d, e, f, s = ints[:7]
    if s == 0:
        raise CalibrationFileError("pointercal divider is 0", where)
    w, h = geometry.x_max - geometry.x_min, geometry.y_max - geometry.y_min
    rows = []
    for (p, q, r), res in (((a, b, c), xres), ((d, e, f), yres)):
        k = s * res
        rows.append((p * w / k, q * h / k, (r + p * geometry.x_min + q * geometry.y_min) / k))
    try:
        fit = FitInfo(model="affine", matrix=(rows[0], rows[1], (0.0, 0.0, 1.0)))
    except Exception as exc:
        raise CalibrationFileError(str(exc), where) from None

    return Calibration(
        device=device, geometry=geometry, fit=fit,
        area=AreaSettings(output_pixels=(xres, yres)), notes="imported from tslib pointercal",
    )
