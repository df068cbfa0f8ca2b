"""What every trace reader returns: devices with their reports or events."""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from station.drivers.evdev.frames import EvdevCaps, InputEvent
from station.drivers.transport.base import HidDeviceInfo, TimedReport

from station.errors import BadInput

log = logging.getLogger(__name__)


class TraceError(BadInput):
    """A trace file is malformed; ``where`` is ``file:line``."""


def tolerate_cut(parse: Callable[[list[str], str], Trace], lines: Iterable[str],
                 name: str) -> Trace:
    """``parse(lines, name)``, except that a last line without its newline — what a
    recorder killed mid-write leaves behind — that ``parse`` refuses is dropped with a
    warning naming it, and the recording plays up to the cut.  Any other malformed
    line stays a :class:`TraceError`."""
    text = list(lines)
    try:
        return parse(text, name)
    except TraceError as exc:
        where = f"{name}:{len(text)}"
        if not text or text[-1].endswith(("\n", "\r")) or exc.where != where:
            raise
        log.warning("%s: last line cut off (the recorder stopped mid-write?): %s; playing "
                    "the recording up to it", where, str(exc).removeprefix(f"{where}: ")[:200])
        return parse(text[:-1], name)


@dataclass
class TraceDevice:
    """One device of a trace.

    Attributes:
        index: position in the file (hid-recorder ``D:`` number).
        name: device name.
        vid, pid, bus: ids (bus 3 USB, 5 Bluetooth, 0x18 I2C).
        phys: physical path, "" if not recorded.
        descriptor: HID report descriptor (hid-recorder, libinput ``hid:``), else None.
        caps: evdev capabilities (evemu, libinput record), else None.
        reports: timestamped HID input reports (seconds, file time).
        events: timestamped evdev events (seconds, file time).
        where: ``file:line`` where the device is declared.
    """

    index: int
    name: str = ""
    vid: int = 0
    pid: int = 0
    bus: int = 3
    phys: str = ""
    descriptor: bytes | None = None
    caps: EvdevCaps | None = None
    reports: list[TimedReport] = field(default_factory=list)
    events: list[InputEvent] = field(default_factory=list)
    where: str = ""

    @property
    def kind(self) -> str:
        """``"evdev"`` for kernel event streams, ``"hid"`` for raw reports."""
        return "evdev" if self.caps is not None else "hid"

    def hid_info(self, path: str) -> HidDeviceInfo:
        return HidDeviceInfo(name=self.name or f"{self.vid:04x}:{self.pid:04x}", vid=self.vid,
                             pid=self.pid, bus=self.bus, path=path, descriptor=self.descriptor,
                             phys=self.phys)

    @property
    def duration(self) -> float:
        times = [r.time for r in self.reports] or [e.time for e in self.events]
        return (times[-1] - times[0]) if times else 0.0


@dataclass
class Trace:
    """A whole trace file: its format and its devices in file order."""

    path: str
    format: str
    devices: list[TraceDevice]
