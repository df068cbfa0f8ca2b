"""The driver pipeline: transport → parser → normaliser → (transform) → sinks.

One :class:`PenSource` per device turns transport input into raw samples (a
HID report parser or the evdev frame assembler); :class:`PenDriver` feeds
them through a :class:`~station.drivers.normalise.Normaliser` and hands the
pen samples to a sink (the bus, a session log).  :func:`open_device` builds
the source from a device SPEC string (see docs/drivers.md):

``mock:MODEL?script=…&rate=…``, ``mock-hidraw:REC.hid``, ``mock-usb:REC.hid``,
``trace:FILE``, ``evdev:/dev/input/eventN``, ``hidraw:/dev/hidrawN``,
``hidapi:VID:PID``, ``usb:VID:PID``.

:class:`TraceReplay` plays every pen device of a trace through the same
sources, merged in time order; interfaces that are not pens are skipped and listed.
"""

from __future__ import annotations

import heapq
import logging
import re
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, Protocol

from station.drivers.autodetect import WHAT, first_pen_spec
from station.drivers.evdev.frames import FrameAssembler, is_pen_device, ranges_from_caps
from station.drivers.normalise import Normaliser, NormaliserConfig
from station.drivers.raw import AxisRanges, RawSample
from station.drivers.traces import read_trace
from station.drivers.traces.model import Trace, TraceDevice
from station.drivers.transport.base import (
    DeviceGone,
    DeviceSpecError,
    EndOfStream,
    EvdevTransport,
    HidTransport,
    TransportError,
    parse_query,
)

from station.errors import BadInput
from station.events import PenSample

log = logging.getLogger(__name__)


class PenSource(Protocol):
    """Raw samples of one pen device, whatever carries them."""

    name: str
    ranges: AxisRanges
    finite: bool
    mock: Any

    def read_raw(self, timeout: float | None) -> list[RawSample]:
        """Samples from the next report/frame ([] on timeout); DeviceGone/EndOfStream at the end."""
        ...

    def now(self) -> float:
        """The current time on the clock the samples are stamped with."""
        ...

    def describe(self) -> dict[str, Any]: ...

    def close(self) -> None: ...


def _device_name(text: str, fallback: str = "pen-0") -> str:
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

    def __init__(self, transport: HidTransport, parser: Any = None, send_init: bool = True,
                 finite: bool = False, name: str | None = None) -> None:
        from station.drivers.registry import interface_from_phys, parser_for

        self.transport = transport
        info = transport.info
        self.parser = parser or parser_for(info.vid, info.pid, info.descriptor, info.bus,
                                           interface=interface_from_phys(info.phys))
        self.uclogic_params: Any = None
        if send_init:
            self.uclogic_params = _vendor_setup(self.parser, transport)
        if not self.parser.is_pen:
            raise DeviceSpecError(
                f"{info.path}: {info.name} ({info.vid:04x}:{info.pid:04x}) is a "
                f"{getattr(self.parser, 'kind', 'non-pen')} interface, not a pen")
        self.ranges: AxisRanges = self.parser.ranges
        self.finite = finite
        self.name = name or _device_name(_model_name(self.parser) or info.name)
        self.stats = SourceStats()
        self.mock: Any = None  # the mock device behind a mock: SPEC (tests inspect it)
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

    def describe(self) -> dict[str, Any]:
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


def _model_name(parser: Any) -> str:
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
        self.name = name or _device_name(caps.name)
        self.stats = SourceStats()
        self.mock: Any = None
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

    def describe(self) -> dict[str, Any]:
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


# -- device SPEC strings ---------------------------------------------------------
SCHEMES = ("mock", "mock-hidraw", "mock-usb", "mock-evdev", "mock-uclogic", "trace", "evdev",
           "hidraw", "hidapi", "usb", "serial", "serial-mock", "auto")
HAPTIC_SCHEMES = ("serial", "serial-mock")  # drivers/haptic/source.py (docs/haptic-protocol.md)


@dataclass(frozen=True)
class DeviceSpec:
    """A parsed SPEC: ``scheme:target?key=value&…``."""

    scheme: str
    target: str
    options: dict[str, str]
    text: str

    @classmethod
    def parse(cls, text: str) -> DeviceSpec:
        scheme, sep, rest = text.partition(":")
        if not sep or scheme not in SCHEMES:
            schemes = ", ".join(s + ":" for s in SCHEMES)
            raise DeviceSpecError(f"device {text!r}: use one of {schemes} (see docs/drivers.md)",
                                  "--device")
        target, _, query = rest.partition("?")
        if not target and scheme == "serial-mock":
            target = "pen"  # the mock haptic device needs no name
        if not target:
            raise DeviceSpecError(f"device {text!r} names nothing after {scheme}:", "--device")
        return cls(scheme, target, dict(parse_query(query, "--device")), text)

    def speed(self, default: float | None) -> float | None:
        value = self.options.get("speed")
        if value is None:
            return default
        if value == "max":
            return None
        try:
            speed = float(value)
        except ValueError:
            raise DeviceSpecError(f"speed {value!r} must be a number or max", "--device") from None
        if not 0.01 <= speed <= 1000:
            raise DeviceSpecError(f"speed {speed} must be 0.01..1000 or max", "--device")
        return speed

    def flag(self, key: str) -> bool:
        return self.options.get(key, "0").lower() in ("1", "true", "yes", "on")

    def number(self, key: str, default: float, lo: float, hi: float) -> float:
        value = self.options.get(key)
        if value is None:
            return default
        try:
            x = float(value)
        except ValueError:
            raise DeviceSpecError(f"{key}={value!r} must be a number", "--device") from None
        if not lo <= x <= hi:
            raise DeviceSpecError(f"{key}={x} must be in {lo}..{hi}", "--device")
        return x


def _vid_pid(target: str) -> tuple[int, int]:
    m = re.fullmatch(r"([0-9a-fA-F]{1,4}):([0-9a-fA-F]{1,4})", target)
    if not m:
        raise DeviceSpecError(f"{target!r} is not VID:PID in hex (e.g. 056a:0315)", "--device")
    return int(m.group(1), 16), int(m.group(2), 16)


def _trace_pen_device(trace: Trace, spec: DeviceSpec) -> TraceDevice:
    index = spec.options.get("device")
    if index is not None:
        for dev in trace.devices:
            if str(dev.index) == index:
                return dev
        raise DeviceSpecError(f"{trace.path} has no device {index}", "--device")
    replay = TraceReplay(trace)
    if not replay.pen_devices:
        raise DeviceSpecError(f"{trace.path}: no pen device ({replay.skipped_text()})")
    return replay.pen_devices[0]


@dataclass
class OpenedTransport:
    """A transport opened from a SPEC, before any parser is chosen.

    Attributes:
        kind: ``"hid"`` (reports) or ``"evdev"`` (events).
        transport: the transport.
        finite: a recording or script that ends by itself.
        spec: the parsed SPEC.
        mock: the mock device object where there is one (tablet, usb device, node).
    """

    kind: str
    transport: Any
    finite: bool
    spec: DeviceSpec
    mock: Any = None


def open_transport(spec_text: str) -> OpenedTransport:
    """Open the transport a SPEC string names (live, mock or recorded)."""
    spec = DeviceSpec.parse(spec_text)
    if spec.scheme == "auto":  # the first pen tablet plugged in (drivers/autodetect.py)
        if spec.target != WHAT:
            raise DeviceSpecError(f"device {spec_text!r}: auto: takes 'pen' (auto:pen)",
                                  "--device")
        spec = DeviceSpec.parse(first_pen_spec())
    s = spec.scheme
    if s in HAPTIC_SCHEMES:
        raise DeviceSpecError(f"{s}: devices are haptic sessions, not report streams "
                              "(use station driver)", "--device")
    if s == "mock":
        from station.drivers.mock.hidraw import MockHidrawNode
        from station.drivers.mock.tablet import mock_tablet_from_spec
        from station.drivers.transport.hidraw import HidrawTransport

        tablet, speed = mock_tablet_from_spec(spec)
        finite = not spec.flag("unplug")
        node = MockHidrawNode(tablet.info, tablet.timed_reports(), speed=speed,
                              on_feature=tablet.feature, finite=finite)
        return OpenedTransport("hid", HidrawTransport(node), finite, spec, tablet)
    if s == "mock-uclogic":
        return _open_mock_uclogic(spec)
    if s in ("mock-hidraw", "mock-usb", "mock-evdev", "trace"):
        trace = read_trace(spec.target)
        dev = _trace_pen_device(trace, spec)
        speed = spec.speed(None if s == "trace" else 1.0)
        if s == "mock-evdev":
            return _open_mock_evdev(spec, dev, speed)
        if s == "trace":
            from station.drivers.transport.recording import (
                RecordedEvdevTransport,
                RecordedHidTransport,
            )

            if dev.kind == "evdev":
                return OpenedTransport("evdev", RecordedEvdevTransport(dev, speed), True, spec)
            return OpenedTransport("hid", RecordedHidTransport(dev, spec.target, speed), True,
                                   spec)
        if dev.kind != "hid" or dev.descriptor is None:
            raise DeviceSpecError(f"{spec.target}: {s} needs a hid-recorder trace with a "
                                  "report descriptor", "--device")
        info = dev.hid_info(f"{s}:{spec.target}")
        if s == "mock-hidraw":
            from station.drivers.mock.hidraw import MockHidrawNode
            from station.drivers.transport.hidraw import HidrawTransport

            node = MockHidrawNode(info, dev.reports, speed=speed)
            return OpenedTransport("hid", HidrawTransport(node), True, spec, node)
        from station.drivers.mock.usb import RecordedUsbBackend, RecordedUsbDevice
        from station.drivers.transport.pyusb import UsbTransport

        usb_dev = RecordedUsbDevice(dev.vid, dev.pid, info.name, dev.descriptor, dev.reports,
                                    speed=speed, kernel_driver=spec.flag("kernel_driver"))
        backend = RecordedUsbBackend([usb_dev])
        transport = UsbTransport(dev.vid, dev.pid, backend=backend,
                                 detach_kernel_driver=spec.flag("detach"))
        return OpenedTransport("hid", transport, True, spec, usb_dev)
    if s == "evdev":
        from station.drivers.transport.evdev import EvdevNodeTransport

        return OpenedTransport("evdev", EvdevNodeTransport(spec.target, grab=spec.flag("grab")),
                               False, spec)
    if s == "hidraw":
        from station.drivers.transport.hidraw import HidrawTransport, OsHidrawNode

        return OpenedTransport("hid", HidrawTransport(OsHidrawNode(spec.target)), False, spec)
    if s == "hidapi":
        from station.drivers.transport.hidapi import HidapiTransport

        if spec.target.startswith("/"):
            return OpenedTransport("hid", HidapiTransport(path=spec.target.encode()), False, spec)
        vid, pid = _vid_pid(spec.target)
        return OpenedTransport("hid", HidapiTransport(vid, pid), False, spec)
    from station.drivers.transport.pyusb import UsbTransport

    vid, pid = _vid_pid(spec.target)
    interface = spec.options.get("interface")
    if interface is not None and not interface.isdigit():
        raise DeviceSpecError(f"interface={interface!r} must be a number", "--device")
    return OpenedTransport("hid", UsbTransport(vid, pid,
                                               interface=int(interface) if interface else None,
                                               detach_kernel_driver=spec.flag("detach")),
                           False, spec)


def _open_mock_evdev(spec: DeviceSpec, dev: TraceDevice, speed: float | None) -> OpenedTransport:
    """An evemu/libinput trace served by a mock evdev node, read by the live evdev transport."""
    from station.drivers.mock.evdev import MockEvdevNode
    from station.drivers.transport.evdev import EvdevNodeTransport

    if dev.caps is None:
        raise DeviceSpecError(f"{spec.target}: mock-evdev needs an evemu or libinput trace",
                              "--device")
    caps = dev.caps
    try:
        drop = [int(v) for v in spec.options.get("drop", "").split(",") if v]
    except ValueError:
        raise DeviceSpecError("drop=N,M… needs frame numbers", "--device") from None
    finite = not spec.flag("unplug")
    node = MockEvdevNode(caps, dev.events, path=f"mock-evdev:{spec.target}", speed=speed,
                         drop_frames=drop, finite=finite)
    transport = EvdevNodeTransport(node.path, grab=spec.flag("grab"), opener=lambda _: node)
    return OpenedTransport("evdev", transport, finite, spec, node)


def _open_mock_uclogic(spec: DeviceSpec) -> OpenedTransport:
    """``mock-uclogic:v1|v2|ugee-v2?script=…&reports=…&speed=…``: the UC-Logic mock over pyusb."""
    from station.drivers.mock.script import SCRIPTS
    from station.drivers.mock.uclogic import TABLETS, MockUclogicTablet
    from station.drivers.mock.usb import RecordedUsbBackend
    from station.drivers.transport.pyusb import UsbTransport

    if spec.target not in TABLETS:
        raise DeviceSpecError(f"mock-uclogic:{spec.target}: one of {', '.join(TABLETS)}",
                              "--device")
    script = spec.options.get("script", "line")
    if script not in SCRIPTS:
        raise DeviceSpecError(f"unknown script {script!r} (one of {', '.join(SCRIPTS)})",
                              "--device")
    tablet = MockUclogicTablet(spec.target, script=script,
                               rate=spec.number("rate", 200.0, 1, 2000),
                               reports=int(spec.number("reports", 60, 2, 100000)))
    tablet.device.speed = spec.speed(1.0)
    transport = UsbTransport(tablet.vid, tablet.pid, backend=RecordedUsbBackend([tablet.device]))
    return OpenedTransport("hid", transport, True, spec, tablet)


def _vendor_setup(parser: Any, transport: HidTransport) -> Any:
    """UC-Logic tablets: the set-up over transports that can do it (pyusb), else say why not."""
    from station.drivers.uclogic.init import UclogicControl

    if not getattr(parser, "needs_control", False):
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


def open_device(spec_text: str, name: str | None = None, send_init: bool = True) -> PenSource:
    """Open the pen device a SPEC string names, with its parser (HID) or assembler (evdev)."""
    spec = DeviceSpec.parse(spec_text)
    if spec.scheme in HAPTIC_SCHEMES:
        from station.drivers.haptic.source import open_haptic

        return open_haptic(spec, name=name)
    opened = open_transport(spec_text)
    source: PenSource
    try:
        if opened.kind == "evdev":
            source = EvdevPenSource(opened.transport, finite=opened.finite, name=name)
        else:
            source = HidPenSource(opened.transport, finite=opened.finite, name=name,
                                  send_init=send_init)
    except BaseException:
        opened.transport.close()
        raise
    source.mock = opened.mock
    return source


# -- the driver -------------------------------------------------------------------
class PenDriver:
    """Runs one source through a normaliser; samples go to ``sink``.

    ``poll`` does one read (with timeout) and returns the samples it produced,
    forcing proximity-out on the source's clock when nothing came.
    """

    def __init__(self, source: PenSource, config: NormaliserConfig | None = None,
                 transform: Callable[[PenSample], PenSample] | None = None,
                 on_device_sample: Callable[[PenSample], None] | None = None,
                 origin: float | None = None, live: bool = False,
                 t_offset: float = 0.0) -> None:
        self.source = source
        self.live = live
        self.normaliser = Normaliser(source.ranges, device=source.name, config=config,
                                     origin=origin, transform=transform,
                                     on_device_sample=on_device_sample, t_offset=t_offset)

    def poll(self, timeout: float | None = 0.01) -> list[PenSample]:
        raws = self.source.read_raw(timeout)
        if not raws:
            return self.normaliser.tick(self.source.now())
        out: list[PenSample] = []
        t_mono = time.monotonic() if self.live else 0.0
        for raw in raws:
            out.extend(self.normaliser.feed(raw, t_mono))
        return out

    def samples(self) -> Iterator[PenSample]:
        """Every sample until the source ends (or is removed); then closes the source."""
        try:
            while True:
                yield from self.poll(0.05)
        except DeviceGone:
            yield from self.normaliser.flush()
        finally:
            self.source.close()

    def status(self) -> dict[str, Any]:
        n = self.normaliser.stats
        src = self.source.describe()
        stats = getattr(self.source, "stats", None)
        parser = getattr(self.source, "parser", None)
        return {
            **src,
            "reports": getattr(stats, "reports", 0),
            "bad_reports": getattr(stats, "bad_reports", 0),
            "bad_reasons": dict(getattr(stats, "bad_reasons", {})),
            "skipped_reports": getattr(parser, "skipped", 0) if parser is not None else 0,
            # skipped reports by report ID (decimal) and by kind (touch, pad, unused …)
            "skipped_by_id": {str(k): v for k, v in sorted(
                getattr(parser, "skipped_by_id", {}).items())},
            "skipped_by_kind": dict(sorted(getattr(parser, "skipped_by_kind", {}).items())),
            "parser_dropped": getattr(parser, "dropped", 0) if parser is not None else 0,
            "long_reports": getattr(parser, "long_reports", 0) if parser is not None else 0,
            "samples": n.samples,
            "rejected_samples": n.rejected,
            "forced_proximity_out": n.forced_out,
            "nib_offsets": n.nib_offsets,
            "in_proximity": self.normaliser.in_proximity,
        }


# -- traces -----------------------------------------------------------------------
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
        self.skipped: list[dict[str, Any]] = []
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
        from station.drivers.registry import interface_from_phys, parser_for

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
        from station.drivers.transport.recording import (
            RecordedEvdevTransport,
            RecordedHidTransport,
        )

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

    def status(self) -> dict[str, Any]:
        return {"trace": self.trace.path, "format": self.trace.format,
                "devices": [d.status() for d in self.drivers], "skipped": self.skipped}


def run_paced(drivers: list[PenDriver], emit: Callable[[PenSample], None],
              stop: threading.Event | None = None,
              idle: Callable[[], None] | None = None) -> None:
    """Run paced drivers (speed set on their transports) round-robin until all end.

    ``idle`` is called after every poll, samples or not (at least every 0.05 s),
    so the caller can send heartbeats while the recording waits."""
    active = list(drivers)
    while active and not (stop and stop.is_set()):
        for drv in list(active):
            try:
                for sample in drv.poll(0.002 if len(active) > 1 else 0.05):
                    emit(sample)
            except DeviceGone:
                for sample in drv.normaliser.flush():
                    emit(sample)
                active.remove(drv)
            if idle is not None:
                idle()


__all__ = [
    "DeviceSpec",
    "EndOfStream",
    "EvdevPenSource",
    "HidPenSource",
    "PenDriver",
    "PenSource",
    "TraceReplay",
    "TransportError",
    "open_device",
    "run_paced",
]
