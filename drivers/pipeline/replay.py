"""Trace replay: every pen device of a recorded trace through its real parser and
normaliser, merged in time order (``station paint``, ``station replay``, calibration)."""

from __future__ import annotations

import heapq
import os
from collections.abc import Callable, Iterator

from station.drivers.evdev.frames import is_pen_device
from station.drivers.normalise import NormaliserConfig
from station.drivers.pipeline.driver import PenDriver
from station.drivers.pipeline.sources import EvdevPenSource, HidPenSource, PenSource
from station.drivers.registry import interface_from_phys, parser_for
from station.drivers.traces import read_trace
from station.drivers.traces.model import Trace, TraceDevice
from station.drivers.transport.recording import RecordedEvdevTransport, RecordedHidTransport

from station.errors import BadInput
from station.events import PenSample


class TraceReplay:
    """Every pen device of a trace through its real parser and normaliser.

    Devices that are not pens (touch, pad, keyboard interfaces) are skipped
    and listed in :attr:`skipped` with the reason.
    """

    def __init__(self, trace: Trace, config: NormaliserConfig | None = None,
                 device_name: str | None = None,
                 transform: Callable[[PenSample], PenSample] | None = None) -> None:
        self.trace = trace
        self.config = config
        self.device_name = device_name
        self.transform = transform
        self.skipped: list[dict[str, object]] = []
        self.pen_devices: list[TraceDevice] = []
        self.drivers: list[PenDriver] = []
        for dev in trace.devices:
            reason = self._why_not_pen(dev)
            if reason:
                self.skipped.append({"device": dev.index, "name": dev.name, "reason": reason,
                                     "reports": len(dev.reports) or len(dev.events)})
            else:
                self.pen_devices.append(dev)

    @staticmethod
    def _why_not_pen(dev: TraceDevice) -> str:
        if dev.kind == "evdev":
            assert dev.caps is not None
            return "" if is_pen_device(dev.caps) else "evdev device without a pen (touch/pad)"
        try:
            parser = parser_for(dev.vid, dev.pid, dev.descriptor, dev.bus,
                                interface=interface_from_phys(dev.phys))
        except BadInput as exc:
            return f"no parser: {exc}"
        if not parser.is_pen:
            why = getattr(parser, "why", "")
            return f"{getattr(parser, 'kind', 'non-pen')} interface" + (f": {why}" if why else "")
        return ""

    def skipped_text(self) -> str:
        if not self.skipped:
            return "nothing skipped"
        return "; ".join(f"device {s['device']} {s['name']!r}: {s['reason']}" for s in self.skipped)

    def _origin(self) -> float:
        firsts = [d.reports[0].time for d in self.pen_devices if d.reports]
        firsts += [d.events[0].time for d in self.pen_devices if d.events]
        return min(firsts) if firsts else 0.0

    def duration(self) -> float:
        """Seconds from the first to the last pen report (the samples' ``t`` range)."""
        lasts = [d.reports[-1].time for d in self.pen_devices if d.reports]
        lasts += [d.events[-1].time for d in self.pen_devices if d.events]
        return max(0.0, max(lasts) - self._origin()) if lasts else 0.0

    def open_drivers(self, speed: float | None = None) -> list[PenDriver]:
        origin = self._origin()
        drivers = []
        multi = len(self.pen_devices) > 1
        for dev in self.pen_devices:
            name = self.device_name
            if name and multi:
                name = f"{name}-{dev.index}"
            source: PenSource
            if dev.kind == "evdev":
                source = EvdevPenSource(RecordedEvdevTransport(dev, speed), finite=True, name=name)
            else:
                source = HidPenSource(RecordedHidTransport(dev, self.trace.path, speed),
                                      finite=True, name=name)
            if multi and not self.device_name:
                source.name = f"{source.name[:40]}-{dev.index}"
            drivers.append(PenDriver(source, self.config, transform=self.transform,
                                     origin=origin))
        self.drivers = drivers
        return drivers

    def samples(self) -> Iterator[PenSample]:
        """All pen samples, merged in time order (no pacing)."""
        drivers = self.open_drivers(None)
        streams = [d.samples() for d in drivers]
        if len(streams) == 1:
            yield from streams[0]
            return
        yield from heapq.merge(*streams, key=lambda s: s.t)

    def status(self) -> dict[str, object]:
        return {"trace": self.trace.path, "format": self.trace.format,
                "devices": [d.status() for d in self.drivers], "skipped": self.skipped}



def iter_trace_samples(path: str | os.PathLike[str], device: str | None = None,
                       config: NormaliserConfig | None = None) -> Iterator[PenSample]:
    """Pen samples of every pen device in the trace, in time order.

    Device-normalised unless ``config`` names a canvas to map them onto.  A
    trace without a pen device raises :class:`~station.errors.BadInput`.
    """
    replay = TraceReplay(read_trace(path), config=config, device_name=device)
    if not replay.pen_devices:
        raise BadInput(f"no pen device in this trace ({replay.skipped_text()})", str(path))
    yield from replay.samples()
