"""Which calibration a driver applies: the seam between drivers and ``station.calibration``.

``--calibration auto`` (the default of ``station driver``) looks up the
device's file by vid/pid (``~/.config/station/calibration/`` or
``$STATION_CONFIG_DIR/calibration``); ``none`` publishes device-normalised
samples; a path loads that file.  The returned :class:`CalibrationStore` is
the normaliser's ``transform`` hook: a bad file never replaces a good
calibration, and with ``auto`` a corrupt or mismatched file is reported and
the driver runs uncalibrated rather than painting with a wrong mapping.

:func:`settle_pressure` gives a device one pressure curve and one threshold,
shaped by one piece of code (:class:`station.pressure.PressureShaping`) in one
stage: the calibration when one is in force, else the normaliser.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from station.drivers.normalise import NormaliserConfig

from station.events import PenSample
from station.pressure import PressureShaping

if TYPE_CHECKING:
    from station.calibration.files import CalibrationStore

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
    # Per-command start-up: the calibration package loads SciPy (~0.4 s of CPU), which a
    # driver run with --calibration none never needs.
    from station.calibration.errors import CalibrationError
    from station.calibration.files import CalibrationStore, find_for_device
    from station.calibration.model import DeviceId

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


@dataclass(frozen=True)
class PressureInForce:
    """The pressure shaping a device's samples get, and where it came from.

    Attributes:
        shaping: threshold, maximum and curve (pressure fractions).
        applied_by: ``"calibration"`` (the transform), ``"normaliser"`` (a curve
            given to the driver, no calibration) or ``"none"`` (samples keep the
            device-normalised pressure).
        source: where the settings come from, in words.
    """

    shaping: PressureShaping
    applied_by: str
    source: str

    def record(self) -> dict[str, object]:
        """As JSON: the session-log header's and the status's ``pressure``."""
        return {**self.shaping.record(), "applied_by": self.applied_by, "from": self.source}

    def before_transform(self) -> PressureInForce:
        """What samples get before the calibration (``--raw-jsonl``): only a curve
        the normaliser applies."""
        if self.applied_by == "normaliser":
            return self
        return PressureInForce(PressureShaping(), "none", "none (device-normalised)")


def settle_pressure(choice: CalibrationChoice,
                    config: NormaliserConfig) -> tuple[NormaliserConfig, PressureInForce]:
    """One curve and one threshold for the device: the calibration's, with the
    driver's own curve (``config.pressure_curve``, ``--pressure-curve``) in place of
    the file's curve when it has one; without a calibration the normaliser shapes
    with the driver's curve.  Returns the normaliser config to use (its curve
    removed where the calibration applies it) and what is in force."""
    curve = config.pressure_curve
    store = choice.store
    current = None if store is None else store.current
    if store is None or current is None:
        if curve is None:
            return config, PressureInForce(PressureShaping(), "none", "none (linear)")
        return config, PressureInForce(PressureShaping(curve=curve), "normaliser",
                                       "--pressure-curve")
    store.set_curve(curve)
    settings = current.pressure
    source = f"calibration {choice.description}"
    if curve is not None:
        source += ", curve from --pressure-curve"
        log.info("pressure curve %s replaces the calibration's %s", list(curve),
                 list(settings.curve))
    shaping = PressureShaping(settings.threshold, settings.maximum,
                              settings.curve if curve is None else curve)
    return dataclasses.replace(config, pressure_curve=None), PressureInForce(
        shaping, "calibration", source)
