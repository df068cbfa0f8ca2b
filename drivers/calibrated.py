"""Which calibration a driver applies: the seam between drivers and ``station.calibration``.

``--calibration auto`` (the default of ``station driver``) looks up the
device's file by vid/pid (``~/.config/station/calibration/`` or
``$STATION_CONFIG_DIR/calibration``); ``none`` publishes device-normalised
samples; a path loads that file.  The returned :class:`CalibrationStore` is
the normaliser's ``transform`` hook: a bad file never replaces a good
calibration, and with ``auto`` a corrupt or mismatched file is reported and
the driver runs uncalibrated rather than painting with a wrong mapping.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

from station.calibration.errors import CalibrationError
from station.calibration.files import CalibrationStore, find_for_device
from station.calibration.model import DeviceId

from station.events import PenSample

log = logging.getLogger(__name__)


@dataclass
class CalibrationChoice:
    """The hook to apply (``None``: device-normalised) and a line saying what it is."""

    store: CalibrationStore | None
    description: str

    @property
    def transform(self) -> Callable[[PenSample], PenSample] | None:
        return None if self.store is None else self.store.apply


def choose_calibration(spec: str, vid: int, pid: int) -> CalibrationChoice:
    """Resolve ``auto`` | ``none`` | PATH for the device ``vid:pid``.

    An explicit PATH that is corrupt or belongs to another device raises a
    :class:`station.calibration.errors.CalibrationError` (exit 2).
    """
    if spec == "none":
        return CalibrationChoice(None, "none (device-normalised)")
    store = CalibrationStore(DeviceId(vid, pid))
    if spec != "auto":
        store.load(spec)
        return CalibrationChoice(store, f"file {spec}")
    path = find_for_device(vid, pid)
    if path is None:
        return CalibrationChoice(None, f"none found for {vid:04x}:{pid:04x} (device-normalised)")
    try:
        store.load(path)
    except CalibrationError as exc:
        log.error("calibration refused, publishing device-normalised samples: %s", exc)
        return CalibrationChoice(None, f"refused: {exc}")
    return CalibrationChoice(store, f"file {path}")
