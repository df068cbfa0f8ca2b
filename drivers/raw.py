"""Raw pen samples in device units: what parsers produce and the normaliser consumes.

Parsers (HID report parsers, Wacom protocol parsers, the evdev frame
assembler) are pure functions from bytes or event frames to :class:`RawSample`;
the normaliser turns those into :class:`station.events.PenSample` using the
device's :class:`AxisRanges`.  Nothing here touches hardware.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from station.events import Tool


@dataclass(frozen=True, slots=True)
class Axis:
    """One axis of a device.

    Attributes:
        minimum: smallest logical value the device reports.
        maximum: largest logical value the device reports.
        resolution: units per millimetre (x, y, distance) or per degree (tilt,
            rotation); ``None`` where the device does not say.
    """

    minimum: int
    maximum: int
    resolution: float | None = None

    @property
    def span(self) -> int:
        return self.maximum - self.minimum


@dataclass(frozen=True, slots=True)
class AxisRanges:
    """The axes a pen device reports; absent axes are ``None``."""

    x: Axis
    y: Axis
    pressure: Axis | None = None
    tilt_x: Axis | None = None
    tilt_y: Axis | None = None
    distance: Axis | None = None
    rotation: Axis | None = None
    wheel: Axis | None = None

    @property
    def has_resolution(self) -> bool:
        """True when x and y can be mapped to millimetres."""
        return bool(self.x.resolution) and bool(self.y.resolution)


class RawSample(NamedTuple):
    """One parsed pen state in device units (before normalisation).

    A named tuple, not a frozen dataclass: parsers build one per report, and a
    frozen dataclass's ``__init__`` (one ``object.__setattr__`` per field) cost
    about 0.9 µs of a 3 µs Intuos report; a tuple is built in a fraction of that
    and is just as immutable.

    Attributes:
        time: transport timestamp in seconds (monotonic or trace time), never
            synthesised from a fixed period.
        proximity: the tool is in range.
        tip: the device's own tip-switch state (the normaliser may override by
            pressure hysteresis); ``None`` when the device has no tip bit.
        x: device units.
        y: device units.
        pressure: device units (0 .. pressure max), ``None`` if not reported.
        tilt_x: device units (see :class:`AxisRanges`), ``None`` if not reported.
        tilt_y: device units, ``None`` if not reported.
        distance: device units (larger = farther), ``None`` if not reported.
        rotation: device units (Art Pen / twist), ``None`` if not reported.
        wheel: device units (airbrush wheel), ``None`` if not reported.
        buttons: bit set of :class:`station.events.Button`.
        tool: tool type, ``None`` when the report does not say (keep the last one).
        serial: tool serial number, ``None`` if unknown.
        tool_id: device tool id (Wacom), ``None`` if unknown.
        eraser: the eraser end or invert bit is active.
        valid: False for reports that carry state but no coordinates (Wacom
            "in range, no valid data", proximity-out).
    """

    time: float
    proximity: bool
    x: int = 0
    y: int = 0
    tip: bool | None = None
    pressure: int | None = None
    tilt_x: int | None = None
    tilt_y: int | None = None
    distance: int | None = None
    rotation: int | None = None
    wheel: int | None = None
    buttons: int = 0
    tool: Tool | None = None
    serial: int | None = None
    tool_id: int | None = None
    eraser: bool = False
    valid: bool = True
