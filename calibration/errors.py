"""Typed errors of the calibration layer.

Everything a user can get wrong (a malformed points file, a collinear point
set, a calibration file for another device) is a :class:`CalibrationError`,
a :class:`station.errors.BadInput`: the CLI prints one line and exits 2.
"""

from __future__ import annotations

from station.errors import BadInput, EventError


class CalibrationError(BadInput):
    """Calibration input is malformed or cannot determine a mapping."""


class DegeneratePoints(CalibrationError):
    """The point set cannot determine the model (collinear, duplicates, too few, NaN)."""


class CalibrationFileError(CalibrationError):
    """A calibration file is corrupt, of another format/version, or fails the schema."""


class DeviceMismatch(CalibrationFileError):
    """A calibration file belongs to another device (vid/pid/serial differ)."""


class ExportError(CalibrationError):
    """A calibration cannot be expressed in the requested foreign format."""


class OutsideArea(EventError):
    """A sample fell outside the active area and the area drops such samples.

    An :class:`station.errors.EventError`, so the drivers' normaliser counts and
    drops it when :meth:`Calibration.apply` is its ``transform`` hook.
    """
