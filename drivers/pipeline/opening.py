"""Opening what a device SPEC names: the transport (live, mock or recorded), then
the pen source on it (see docs/drivers.md for the schemes).

:func:`open_transport` picks one opener per scheme; :func:`open_device` puts the
parser (HID) or frame assembler (evdev) on the transport, or hands a haptic SPEC
to :mod:`station.drivers.haptic.source`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from station.drivers.autodetect import WHAT, first_pen_spec
from station.drivers.haptic.source import open_haptic
from station.drivers.mock.evdev import MockEvdevNode
from station.drivers.mock.hidraw import MockHidrawNode
from station.drivers.mock.script import SCRIPTS
from station.drivers.mock.tablet import mock_tablet_from_spec
from station.drivers.pipeline.replay import TraceReplay
from station.drivers.pipeline.sources import EvdevPenSource, HidPenSource, PenSource
from station.drivers.pipeline.spec import HAPTIC_SCHEMES, DeviceSpec, vid_pid
from station.drivers.traces import read_trace
from station.drivers.traces.model import Trace, TraceDevice
from station.drivers.transport.base import DeviceSpecError
from station.drivers.transport.evdev import EvdevNodeTransport
from station.drivers.transport.hidapi import HidapiTransport
from station.drivers.transport.hidraw import HidrawTransport, OsHidrawNode
from station.drivers.transport.pyusb import UsbTransport
from station.drivers.transport.recording import RecordedEvdevTransport, RecordedHidTransport


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
    transport: Any  # HidTransport or EvdevTransport, as ``kind`` says
    finite: bool
    spec: DeviceSpec
    mock: object = None


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
    return _OPENERS[s](spec)


# -- mocks and recordings ---------------------------------------------------------
def _open_mock(spec: DeviceSpec) -> OpenedTransport:
    """``mock:MODEL?script=…``: a scripted mock tablet behind a mock hidraw node."""
    tablet, speed = mock_tablet_from_spec(spec)
    finite = not spec.flag("unplug")
    node = MockHidrawNode(tablet.info, tablet.timed_reports(), speed=speed,
                          on_feature=tablet.feature, finite=finite)
    return OpenedTransport("hid", HidrawTransport(node), finite, spec, tablet)


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


def _open_recorded(spec: DeviceSpec) -> OpenedTransport:
    """``trace:``, ``mock-evdev:``, ``mock-hidraw:`` and ``mock-usb:`` FILE: one pen
    device of a trace, read straight (``trace:``, at full speed by default) or served
    by a mock node the live transports read (in real time by default)."""
    s = spec.scheme
    trace = read_trace(spec.target)
    dev = _trace_pen_device(trace, spec)
    speed = spec.speed(None if s == "trace" else 1.0)
    if s == "mock-evdev":
        return _open_mock_evdev(spec, dev, speed)
    if s == "trace":
        if dev.kind == "evdev":
            return OpenedTransport("evdev", RecordedEvdevTransport(dev, speed), True, spec)
        return OpenedTransport("hid", RecordedHidTransport(dev, spec.target, speed), True, spec)
    if dev.kind != "hid" or dev.descriptor is None:
        raise DeviceSpecError(f"{spec.target}: {s} needs a hid-recorder trace with a "
                              "report descriptor", "--device")
    info = dev.hid_info(f"{s}:{spec.target}")
    if s == "mock-hidraw":
        node = MockHidrawNode(info, dev.reports, speed=speed)
        return OpenedTransport("hid", HidrawTransport(node), True, spec, node)
    return _open_mock_usb(spec, dev, info.name, dev.descriptor, speed)


def _open_mock_usb(spec: DeviceSpec, dev: TraceDevice, product: str, descriptor: bytes,
                   speed: float | None) -> OpenedTransport:
    """A hid-recorder trace served by a mock USB device, read by the pyusb transport."""
    # optional extra: the mock USB backend is built on pyusb (the "usb" extra)
    from station.drivers.mock.usb import RecordedUsbBackend, RecordedUsbDevice

    usb_dev = RecordedUsbDevice(dev.vid, dev.pid, product, descriptor, dev.reports,
                                speed=speed, kernel_driver=spec.flag("kernel_driver"))
    backend = RecordedUsbBackend([usb_dev])
    transport = UsbTransport(dev.vid, dev.pid, backend=backend,
                             detach_kernel_driver=spec.flag("detach"))
    return OpenedTransport("hid", transport, True, spec, usb_dev)


def _open_mock_evdev(spec: DeviceSpec, dev: TraceDevice, speed: float | None) -> OpenedTransport:
    """An evemu/libinput trace served by a mock evdev node, read by the live evdev transport."""
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
    # optional extra: the UC-Logic mock is a mock USB device, built on pyusb (the "usb" extra)
    from station.drivers.mock.uclogic import TABLETS, MockUclogicTablet
    from station.drivers.mock.usb import RecordedUsbBackend

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


# -- live devices ----------------------------------------------------------------
def _open_evdev(spec: DeviceSpec) -> OpenedTransport:
    return OpenedTransport("evdev", EvdevNodeTransport(spec.target, grab=spec.flag("grab")),
                           False, spec)


def _open_hidraw(spec: DeviceSpec) -> OpenedTransport:
    return OpenedTransport("hid", HidrawTransport(OsHidrawNode(spec.target)), False, spec)


def _open_hidapi(spec: DeviceSpec) -> OpenedTransport:
    if spec.target.startswith("/"):
        return OpenedTransport("hid", HidapiTransport(path=spec.target.encode()), False, spec)
    vid, pid = vid_pid(spec.target)
    return OpenedTransport("hid", HidapiTransport(vid, pid), False, spec)


def _open_usb(spec: DeviceSpec) -> OpenedTransport:
    vid, pid = vid_pid(spec.target)
    interface = spec.options.get("interface")
    if interface is not None and not interface.isdigit():
        raise DeviceSpecError(f"interface={interface!r} must be a number", "--device")
    return OpenedTransport("hid", UsbTransport(vid, pid,
                                               interface=int(interface) if interface else None,
                                               detach_kernel_driver=spec.flag("detach")),
                           False, spec)


#: One opener per report-stream scheme (the haptic schemes open elsewhere: open_device).
_OPENERS: dict[str, Callable[[DeviceSpec], OpenedTransport]] = {
    "mock": _open_mock,
    "mock-uclogic": _open_mock_uclogic,
    "mock-hidraw": _open_recorded,
    "mock-usb": _open_recorded,
    "mock-evdev": _open_recorded,
    "trace": _open_recorded,
    "evdev": _open_evdev,
    "hidraw": _open_hidraw,
    "hidapi": _open_hidapi,
    "usb": _open_usb,
}


def open_device(spec_text: str, name: str | None = None, send_init: bool = True) -> PenSource:
    """Open the pen device a SPEC string names, with its parser (HID) or assembler (evdev)."""
    spec = DeviceSpec.parse(spec_text)
    if spec.scheme in HAPTIC_SCHEMES:
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
