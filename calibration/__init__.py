"""Calibration: device space → canvas, pressure and tilt (issue 5).

Installs as ``station.calibration``.  Modules:

* :mod:`~station.calibration.pointset` — point sets, mappings, refusal of degenerate sets;
* :mod:`~station.calibration.fit` — affine / homography fits, parallax,
  misclick detection, leave-one-out error (the solver: SciPy's ``least_squares``);
* :mod:`~station.calibration.points` — the points CSV;
* :mod:`~station.calibration.area` — active area, rotation, left-handed,
  aspect lock, output rectangle, composed into one matrix;
* :mod:`~station.calibration.pressure` — tip threshold/maximum, Bézier curve, tilt offset;
* :mod:`~station.calibration.model` — :class:`Calibration` and its ``apply``;
* :mod:`~station.calibration.files` — the per-device JSON file, schema, store;
* :mod:`~station.calibration.export` — libinput matrix and tslib pointercal;
* :mod:`~station.calibration.taps` — taps found in recorded sessions;
* :mod:`~station.calibration.session`, :mod:`~station.calibration.sources` and
  :mod:`~station.calibration.interactive` — the ``station calibrate`` window: its logic
  (targets, on-the-spot misclick rejection), its pen sources (mock devices included)
  and its drawing.
"""

from station.calibration.errors import (
    CalibrationError,
    CalibrationFileError,
    DegeneratePoints,
    DeviceMismatch,
    ExportError,
    OutsideArea,
)
from station.calibration.files import CalibrationStore, load_for_device, read_file, write_file
from station.calibration.fit import FitReport, Mapping, PointSet, fit_points
from station.calibration.model import Calibration, DeviceId, FitInfo

__all__ = [
    "Calibration",
    "CalibrationError",
    "CalibrationFileError",
    "CalibrationStore",
    "DegeneratePoints",
    "DeviceId",
    "DeviceMismatch",
    "ExportError",
    "FitInfo",
    "FitReport",
    "Mapping",
    "OutsideArea",
    "PointSet",
    "fit_points",
    "load_for_device",
    "read_file",
    "write_file",
]
