"""Transport interfaces: the only layer that touches hardware.

A HID transport moves whole input reports with a timestamp taken where the
bytes arrived (``time.monotonic()`` for live devices, the recorded time for
traces); an evdev transport moves kernel events with the kernel's timestamps.
Neither parses anything.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from station.drivers.evdev.frames import EvdevCaps, EvdevState, InputEvent

from station.errors import BadInput, StationError


class TransportError(StationError):
    """A device cannot be opened or read (environment problem: exit 1)."""


class PermissionProblem(TransportError):
    """The node exists but this user may not open it; the message says how to fix it."""


class DeviceGone(TransportError):
    """The device was unplugged (ENODEV) or its stream ended."""


class EndOfStream(DeviceGone):
    """A recording or script has no more reports: a normal end."""


class DeviceSpecError(BadInput):
    """A device SPEC string is malformed or names no device (exit 2)."""


class WrongNodeKind(TransportError, BadInput):
    """A path given to a transport is not the kind of node it opens (exit 2)."""


@dataclass(frozen=True, slots=True)
class TimedReport:
    """One HID input report; ``time`` in seconds from the transport's clock."""

    time: float
    data: bytes


@dataclass(frozen=True)
class HidDeviceInfo:
    """Identity of a HID device as its transport sees it.

    Attributes:
        name: product name.
        vid, pid: USB ids.
        bus: 3 USB, 5 Bluetooth, 0x18 I2C.
        path: where it lives (``/dev/hidraw3``, a trace file, ``mock:…``).
        descriptor: the report descriptor, ``None`` where the transport cannot get it.
        phys: physical path, "" if unknown.
    """

    name: str
    vid: int
    pid: int
    bus: int = 3
    path: str = ""
    descriptor: bytes | None = None
    phys: str = ""


@runtime_checkable
class HidTransport(Protocol):
    """Moves HID reports: hidraw, hidapi, pyusb, a recording or a mock."""

    info: HidDeviceInfo

    def read(self, timeout: float | None = None) -> TimedReport | None:
        """The next report, ``None`` after ``timeout`` seconds without one.

        Raises :class:`DeviceGone` (or :class:`EndOfStream`) when no report will come.
        """
        ...

    def send_feature(self, data: bytes) -> None:
        """Send a feature report (first byte = report ID, 0 when the device has none)."""
        ...

    def close(self) -> None: ...


@runtime_checkable
class EvdevTransport(Protocol):
    """Moves evdev events: a live node or a recording."""

    caps: EvdevCaps

    def read(self, timeout: float | None = None) -> list[InputEvent]:
        """Events available within ``timeout`` seconds (may be empty); DeviceGone at the end."""
        ...

    def state(self) -> EvdevState | None:
        """The device's current state for a SYN_DROPPED resync (None: not available)."""
        ...

    def close(self) -> None: ...


def describe_bus(bus: int) -> str:
    names = {3: "usb", 5: "bluetooth", 0x18: "i2c", 0x19: "host", 6: "virtual"}
    return names.get(bus, f"bus {bus}")


def parse_query(query: str, where: str) -> Mapping[str, str]:
    """``a=1&b=x`` → dict; a key without ``=`` is ``"1"`` (a flag)."""
    out: dict[str, str] = {}
    for part in query.split("&"):
        if not part:
            continue
        key, sep, value = part.partition("=")
        if not key:
            raise DeviceSpecError(f"empty option name in {query!r}", where)
        out[key] = value if sep else "1"
    return out
