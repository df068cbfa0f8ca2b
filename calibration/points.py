"""Reading and writing calibration point files (interfaces.md).

Header ``device_x,device_y,canvas_x,canvas_y`` and optionally ``tilt_x,tilt_y``
(columns in any order, other columns ignored, ``#`` comment lines and blank
lines skipped).  Device coordinates in device units or normalised, canvas
coordinates canvas-normalised, tilt in degrees.  Every error names
``file:line``.
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Iterable
from pathlib import Path

import numpy as np
from station.calibration.errors import CalibrationError, DegeneratePoints
from station.calibration.fit import PointSet

from station import boundedio

REQUIRED = ("device_x", "device_y", "canvas_x", "canvas_y")
TILT = ("tilt_x", "tilt_y")
MAX_ABS = 1e9
"""Largest magnitude a coordinate may have: no tablet reports a billion units, and
squares of larger numbers (1e308) overflow in the fit's statistics."""


def _lines(text: str) -> Iterable[tuple[int, str]]:
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if stripped and not stripped.startswith("#"):
            yield number, line


def parse_points(text: str, name: str = "<points>") -> PointSet:
    """Parse a points CSV held in ``text``; ``name`` is used in messages."""
    rows = list(_lines(text))
    if not rows:
        raise CalibrationError("empty file: no header", f"{name}:1")
    head_no, head = rows[0]
    try:
        header = [h.strip().lower() for h in next(csv.reader([head]))]
    except csv.Error as exc:
        raise CalibrationError(f"not a CSV header ({exc})", f"{name}:{head_no}") from None
    missing = [c for c in REQUIRED if c not in header]
    if missing:
        raise CalibrationError(
            f"header lacks {', '.join(missing)} (needs {','.join(REQUIRED)}[,tilt_x,tilt_y])",
            f"{name}:{head_no}",
        )
    has_tilt = all(c in header for c in TILT)
    if any(c in header for c in TILT) and not has_tilt:
        raise CalibrationError("give both tilt_x and tilt_y or neither", f"{name}:{head_no}")
    cols = [header.index(c) for c in REQUIRED + (TILT if has_tilt else ())]
    values: list[list[float]] = []
    labels: list[str] = []
    for number, line in rows[1:]:
        where = f"{name}:{number}"
        try:
            fields = next(csv.reader([line]))
        except csv.Error as exc:  # a field past the csv module's 128 KiB limit, a NUL
            raise CalibrationError(f"not a CSV line ({exc})", where) from None
        if len(fields) < len(header):
            raise CalibrationError(
                f"{len(fields)} fields, the header has {len(header)}", where
            )
        row = []
        for c in cols:
            text_value = fields[c].strip()
            try:
                v = float(text_value)
            except ValueError:
                raise CalibrationError(
                    f"{header[c]} {text_value!r} is not a number", where
                ) from None
            if not math.isfinite(v):
                raise DegeneratePoints(f"{header[c]} is {text_value}, not a finite number", where)
            if abs(v) > MAX_ABS:
                raise CalibrationError(
                    f"{header[c]} {text_value} is out of range (at most {MAX_ABS:g} in size: "
                    "device units, canvas-normalised or degrees)", where)
            row.append(v)
        values.append(row)
        labels.append(where)
    if not values:
        raise DegeneratePoints("no points after the header", f"{name}:{head_no}")
    arr = np.array(values, dtype=np.float64)
    return PointSet(arr[:, 0:2], arr[:, 2:4], arr[:, 4:6] if has_tilt else None, tuple(labels))


def read_points(path: str | os.PathLike[str]) -> PointSet:
    """Read a points CSV file (errors name ``file:line``)."""
    p = Path(path)
    try:
        text = boundedio.read_text(p, boundedio.CAP_POINTS, str(p))
    except OSError as exc:
        raise CalibrationError(f"cannot read ({exc.strerror})", str(p)) from None
    except UnicodeDecodeError:
        raise CalibrationError("not UTF-8 text", str(p)) from None
    return parse_points(text, str(p))


def format_points(points: PointSet) -> str:
    """The CSV text of ``points`` (floats written with repr: exact round trip)."""
    out = io.StringIO()
    header = list(REQUIRED) + (list(TILT) if points.tilt is not None else [])
    out.write(",".join(header) + "\n")
    for i in range(len(points)):
        vals = [*points.device[i], *points.canvas[i]]
        if points.tilt is not None:
            vals += list(points.tilt[i])
        out.write(",".join(repr(float(v)) for v in vals) + "\n")
    return out.getvalue()


def write_points(path: str | os.PathLike[str], points: PointSet) -> None:
    Path(path).write_text(format_points(points), encoding="utf-8")
