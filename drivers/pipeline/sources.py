"""Pen sources: a transport plus what turns its input into raw samples.

:class:`HidPenSource` holds a HID transport and the parser the registry picks
(after the vendor set-up a UC-Logic tablet needs); :class:`EvdevPenSource` an
evdev transport and the frame assembler.  Both count what they read and drop.
"""

from __future__ import annotations

import logging
import re
import time
from collections import Counter
from dataclasses import dataclass, field
from typing import Protocol

from station.drivers.devicedata import SourceInfo
from station.drivers.evdev.frames import FrameAssembler, is_pen_device, ranges_from_caps
from station.drivers.raw import AxisRanges, RawSample
from station.drivers.registry import ReportParser, interface_from_phys, parser_for
from station.drivers.transport.base import DeviceSpecError, EvdevTransport, HidTransport
from station.drivers.uclogic.init import UclogicControl
from station.drivers.uclogic.params import UclogicParams
from station.drivers.uclogic.parser import UclogicPenParser

from station.errors import BadInput

log = logging.getLogger("station.drivers.pipeline")  # one logger for the pipeline, as before


class PenSource(Protocol):
    """Raw samples of one pen device, whatever carries them."""

    name: str
    ranges: AxisRanges
    finite: bool

    @property
    def mock(self) -> object:
        """The mock device behind a mock: SPEC (None for a real one; tests inspect it)."""
        ...

    def read_raw(self, timeout: float | None) -> list[RawSample]:
        """Samples from the next report/frame ([] on timeout); DeviceGone/EndOfStream at the end."""
        ...

    def now(self) -> float:
        """The current time on the clock the samples are stamped with."""
        ...

    def describe(self) -> SourceInfo: ...

    def close(self) -> None: ...


def device_name(text: str, fallback: str = "pen-0") -> str:
    name = re.sub(r"[^A-Za-z0-9_-]+", "-", text.strip().lower()).strip("-")[:48]
    return name or fallback


@dataclass
class SourceStats:
    """Counts of one source: reports read, bad reports dropped (by reason), non-pen skips."""

    reports: int = 0
    bad_reports: int = 0
    bad_reasons: Counter[str] = field(default_factory=Counter)
    last_error: str = ""


class HidPenSource:
    """A HID transport plus the parser the registry picks for it.

    Sends the parser's init feature reports (Wacom ``02 02``) on open unless
    ``send_init`` is False.  A report the parser rejects (ReportError) is
    counted and dropped; it never becomes a sample.
    """

    def __init__(self, transport: HidTransport, parser: ReportParser | None = None,
                 send_init: bool = True,
                 finite: bool = False, name: str | None = None) -> None:
        self.transport = transport
        info = transport.info
        self.parser = parser or parser_for(info.vid, info.pid, info.descriptor, info.bus,
                                           interface=interface_from_phys(info.phys))
        self.uclogic_params: UclogicParams | None = None
        if send_init:
            self.uclogic_params = vendor_setup(self.parser, transport)
        if not self.parser.is_pen:
            raise DeviceSpecError(
                f"{info.path}: {info.name} ({info.vid:04x}:{info.pid:04x}) is a "
                f"{getattr(self.parser, 'kind', 'non-pen')} interface, not a pen")
        self.ranges: AxisRanges = self.parser.ranges
        self.finite = finite
        self.name = name or device_name(_model_name(self.parser) or info.name)
        self.stats = SourceStats()
        self.mock: object = None  # the mock device behind a mock: SPEC (tests inspect it)
        self.features_sent: list[bytes] = []
        if send_init:
            for feature in self.parser.init_features:
                transport.send_feature(feature)
                self.features_sent.append(bytes(feature))

    def read_raw(self, timeout: float | None) -> list[RawSample]:
        report = self.transport.read(timeout)
        if report is None:
            return []
        self.stats.reports += 1
        try:
            return list(self.parser.parse(report.data, report.time))
        except BadInput as exc:  # ReportError: counted, logged, dropped
            self.stats.bad_reports += 1
            reason = str(exc).split(":", 1)[0][:60]
            self.stats.bad_reasons[reason] += 1
            self.stats.last_error = str(exc)
            _warn_bad(self.transport.info.path, self.stats.bad_reports, self.stats.reports,
                      report.data, exc)
            return []

    def now(self) -> float:
        clock = getattr(self.transport, "now", None)
        return float(clock()) if clock is not None else time.monotonic()

    def describe(self) -> SourceInfo:
        info = self.transport.info
        p = self.parser
        return {
            "name": self.name, "source": "hid", "path": info.path, "product": info.name,
            "vid": info.vid, "pid": info.pid, "usb_id": f"{info.vid:04x}:{info.pid:04x}",
            "bus": info.bus,
            "parser": getattr(p, "name", type(p).__name__), "generic": bool(p.generic),
            "model": _model_name(p), "can_map_mm": self.ranges.has_resolution,
            "features_sent": [f.hex(" ") for f in self.features_sent],
        }

    def close(self) -> None:
        self.transport.close()


# Bad reports warned one by one; after that only a count at 10, 100, 1000 … (the summary
# and the status messages carry them all, by reason).
BAD_WARNINGS = 5


def _warn_bad(path: str, bad: int, index: int, data: bytes, exc: Exception) -> None:
    if bad <= BAD_WARNINGS:
        log.warning("%s: dropped report %d (%s): %s", path, index, data[:16].hex(" "), exc)
        if bad == BAD_WARNINGS:
            log.warning("%s: further bad reports are counted without a warning each "
                        "(the summary lists them by reason)", path)
        return
    if bad >= 10 and str(bad).rstrip("0") == "1":  # 10, 100, 1000 …
        log.warning("%s: %d bad reports dropped so far (last: %s)", path, bad, exc)


def _model_name(parser: object) -> str:
    model = getattr(parser, "model", None)
    if isinstance(model, dict):
        return str(model.get("id") or model.get("name") or "")
    return ""


class EvdevPenSource:
    """An evdev transport plus the frame assembler (resync state from the transport)."""

    def __init__(self, transport: EvdevTransport, finite: bool = False,
                 name: str | None = None) -> None:
        caps = transport.caps
        if not is_pen_device(caps):
            raise DeviceSpecError(f"{caps.path or caps.name}: {caps.name!r} is not a pen "
                                  "(needs ABS_X/ABS_Y and BTN_TOOL_PEN or BTN_STYLUS)")
        self.transport = transport
        self.assembler = FrameAssembler(caps, transport.state())
        self.ranges = ranges_from_caps(caps)
        self.finite = finite
        self.name = name or device_name(caps.name)
        self.stats = SourceStats()
        self.mock: object = None
        if not self.ranges.has_resolution:
            log.warning("%s: no resolution: works in normalised units, cannot map millimetres",
                        caps.name)

    def read_raw(self, timeout: float | None) -> list[RawSample]:
        out = []
        for ev in self.transport.read(timeout):
            raw = self.assembler.feed(ev)
            if raw is not None:
                self.stats.reports += 1
                out.append(raw)
        return out

    def now(self) -> float:
        clock = getattr(self.transport, "now", None)
        return float(clock()) if clock is not None else time.monotonic()

    def describe(self) -> SourceInfo:
        caps = self.transport.caps
        s = self.assembler.stats
        return {
            "name": self.name, "source": "evdev", "path": caps.path, "product": caps.name,
            "vid": caps.vid, "pid": caps.pid, "usb_id": f"{caps.vid:04x}:{caps.pid:04x}",
            "bus": caps.bus,
            "parser": "evdev", "generic": False, "model": "",
            "can_map_mm": self.ranges.has_resolution,
            "syn_dropped": s.dropped, "resyncs": s.resyncs,
        }

    def close(self) -> None:
        self.transport.close()




def vendor_setup(parser: ReportParser, transport: HidTransport) -> UclogicParams | None:
    """UC-Logic tablets: the set-up over transports that can do it (pyusb), else say why not."""
    if not isinstance(parser, UclogicPenParser) or not parser.needs_control:
        return None
    if not isinstance(transport, UclogicControl):
        log.info("%s: UC-Logic set-up needs raw USB (usb: SPEC); reading the reports its "
                 "descriptor describes (the kernel's hid-uclogic may have set it up)",
                 transport.info.path)
        return None
    params = parser.initialise(transport)
    if params is None:
        log.warning("%s: UC-Logic set-up found no parameters; reading the device's own reports",
                    transport.info.path)
    else:
        log.info("%s: UC-Logic %s parameters: %dx%d, pressure %d, %d lpi", transport.info.path,
                 params.kind, params.max_x, params.max_y, params.max_pressure,
                 params.resolution_lpi)
    return params

