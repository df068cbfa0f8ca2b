"""Mocks as real backends: pyusb backend, mock hidraw node, mock tablet, driver → bus.

Every backend is chosen by configuration (a device SPEC or a backend object
handed to pyusb), never by monkeypatching.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from itertools import pairwise
from pathlib import Path

import pytest
import usb.core
import usb.util
from station.drivers import synth
from station.drivers.mock.hidraw import MockHidrawNode
from station.drivers.mock.script import report_times
from station.drivers.mock.tablet import MockTablet, find_model
from station.drivers.mock.usb import RecordedUsbBackend, RecordedUsbDevice
from station.drivers.pipeline import (
    DeviceSpec,
    HidPenSource,
    PenDriver,
    iter_trace_samples,
    open_device,
)
from station.drivers.registry import interface_from_phys
from station.drivers.traces import read_trace
from station.drivers.transport.base import (
    DeviceSpecError,
    EndOfStream,
    HidDeviceInfo,
    TimedReport,
    TransportError,
)
from station.drivers.transport.hidraw import HidrawTransport, list_hidraw
from station.drivers.transport.pyusb import UsbTransport

from station.bus import Publisher, Subscriber
from station.cli import main
from station.events import PenSample, Tool

PY = sys.executable


def write_recording(path: Path, model: str = "intuos-pro-m", script: str = "line",
                    reports: int = 20, with_mouse_mode: bool = True) -> Path:
    """A hid-recorder file of the mock tablet, mouse-mode reports first (as a real capture)."""
    tablet = MockTablet(find_model(model), script=script, reports=reports)
    tablet.feature(b"\x02\x02")
    events = [(r.time, r.data) for r in tablet.timed_reports()]
    if not with_mouse_mode:
        events = [e for e in events if e[1][0] != 1]
    info = tablet.info
    synth.write_hid_recorder([synth.RecordedDevice(info.name, info.vid, info.pid,
                                                   info.descriptor or b"", events)], path)
    return path


def fields(samples: list[PenSample]) -> list[tuple]:
    return [(s.tool, s.x, s.y, s.pressure, s.tilt_x, s.tilt_y, s.touching, s.proximity,
             s.buttons, s.serial) for s in samples]


# -- pyusb ---------------------------------------------------------------------------
def test_pyusb_backend_presents_the_recorded_device_through_pyusb(tmp_path: Path) -> None:
    (dev,) = read_trace(write_recording(tmp_path / "r.hid")).devices
    assert dev.descriptor is not None
    recorded = RecordedUsbDevice(dev.vid, dev.pid, "Intuos Pro M", dev.descriptor, dev.reports)
    backend = RecordedUsbBackend([recorded])
    found = usb.core.find(idVendor=0x056A, idProduct=0x0315, backend=backend)
    assert found is not None and (found.idVendor, found.idProduct) == (0x056A, 0x0315)
    assert usb.core.find(idVendor=0x056A, idProduct=0x9999, backend=backend) is None
    cfg = found.get_active_configuration()
    intf = cfg[(0, 0)]
    assert intf.bInterfaceClass == 3
    (ep,) = list(intf)
    assert ep.bEndpointAddress == 0x81 and usb.util.endpoint_type(ep.bmAttributes) == 3
    assert usb.util.get_string(found, found.iProduct) == "Intuos Pro M"
    transport = UsbTransport(0x056A, 0x0315, backend=backend)
    assert transport.info.descriptor == dev.descriptor  # via GET_DESCRIPTOR(report)
    transport.send_feature(b"\x02\x02")
    got = [transport.read(0.1) for _ in range(len(dev.reports))]
    assert [g.data for g in got if g] == [r.data for r in dev.reports]
    with pytest.raises(TransportError):  # the recording ended: the device is gone
        transport.read(0.1)
    transport.close()
    assert recorded.features == [b"\x02\x02"]
    assert "set_report 0x0302 02 02" in recorded.log


def test_pyusb_kernel_driver_detached_only_when_asked(tmp_path: Path) -> None:
    rec = write_recording(tmp_path / "r.hid")
    with pytest.raises(TransportError, match="kernel driver owns interface 0"):
        open_device(f"mock-usb:{rec}?speed=max&kernel_driver=1")
    src = open_device(f"mock-usb:{rec}?speed=max&kernel_driver=1&detach=1")
    samples = list(PenDriver(src).samples())
    usb_dev = src.mock
    assert usb_dev.log[:4] == ["open", "detach 0", "claim 0", "set_report 0x0302 02 02"]
    assert usb_dev.log[-2:] == ["attach 0", "close"] and usb_dev.kernel_driver
    assert fields(samples) == fields(list(iter_trace_samples(rec)))


# -- mock hidraw -----------------------------------------------------------------------
def test_mock_hidraw_serves_recording_and_logs_the_mode_switch(tmp_path: Path) -> None:
    rec = write_recording(tmp_path / "r.hid")
    src = open_device(f"mock-hidraw:{rec}?speed=max")
    assert isinstance(src, HidPenSource)
    node = src.mock
    assert isinstance(node, MockHidrawNode)
    assert node.features == [b"\x02\x02"]  # the Wacom mouse-mode switch arrived
    driver = PenDriver(src)
    samples = list(driver.samples())
    # identical to the trace replay; the node stamps recorded times, so the times match up
    # to the origin (replay counts from the trace's first report, a live driver from its
    # first sample)
    replayed = list(iter_trace_samples(rec))
    assert fields(samples) == fields(replayed)
    shift = replayed[0].t - samples[0].t
    assert shift == pytest.approx(0.021)  # three mouse-mode reports came first
    assert [s.t + shift for s in samples] == pytest.approx([s.t for s in replayed])
    status = driver.status()
    assert status["skipped_reports"] == 3 and status["bad_reports"] == 0
    assert status["features_sent"] == ["02 02"]


def test_mock_hidraw_feature_refused_is_a_transport_error() -> None:
    info = HidDeviceInfo("x", 0x056A, 0x0315, descriptor=synth.wacom_protocol_descriptor(9))
    node = MockHidrawNode(info, [TimedReport(0.0, synth.intuos_prox_out())],
                          refuse_features=[b"\x02\x02"])
    transport = HidrawTransport(node)
    with pytest.raises(TransportError, match="refused"):
        transport.send_feature(b"\x02\x02")
    assert transport.read(1.0) == TimedReport(0.0, synth.intuos_prox_out())
    with pytest.raises(EndOfStream):
        transport.read(1.0)
    transport.close()


def test_mock_hidraw_read_times_out_without_reports() -> None:
    def slow():
        time.sleep(0.3)
        yield TimedReport(1.0, b"\x02\x80")

    node = MockHidrawNode(HidDeviceInfo("x", 1, 2, descriptor=b""), slow())
    transport = HidrawTransport(node)
    assert transport.read(0.01) is None
    assert transport.read(2.0) == TimedReport(1.0, b"\x02\x80")
    transport.close()


# -- mock tablet ---------------------------------------------------------------------------
def test_mock_tablet_stays_in_mouse_mode_without_the_switch() -> None:
    src = open_device("mock:intuos-pro-m?speed=max&script=line&reports=10", send_init=False)
    src.mock.pen_mode.set()  # do not make the test wait 2 s for a switch that never comes
    driver = PenDriver(src)
    samples = list(driver.samples())
    assert driver.status()["skipped_reports"] >= 3
    assert src.mock.features == []
    # with the switch only pen reports follow the three mouse reports
    src2 = open_device("mock:intuos-pro-m?speed=max&script=line&reports=10")
    d2 = PenDriver(src2)
    s2 = list(d2.samples())
    assert src2.mock.features == [b"\x02\x02"] and d2.status()["skipped_reports"] == 3
    assert len(s2) == 10 + 12 + 1 and len(samples) <= len(s2)


def test_report_times_jitter_on_usb_frames() -> None:
    times = [t for t, _ in zip(report_times(200.0, seed=3), range(400), strict=False)]
    gaps = {round((b - a) * 1000) for a, b in pairwise(times)}
    assert gaps == {4, 5, 6}
    times = [t for t, _ in zip(report_times(133.0, seed=3), range(400), strict=False)]
    gaps133 = [round((b - a) * 1000) for a, b in pairwise(times)]
    assert set(gaps133) <= {6, 7, 8, 9} and len(set(gaps133)) >= 3
    assert sum(gaps133) / len(gaps133) == pytest.approx(1000 / 133, abs=0.05)


@pytest.mark.parametrize("spec,needle", [
    ("nope:x", "use one of"),
    ("mock:", "names nothing"),
    ("mock:no-such-tablet", "no mock model"),
    ("mock:intuos-pro-m?script=zigzag", "unknown script"),
    ("mock:intuos-pro-m?rate=fast", "must be a number"),
    ("mock:intuos-pro-m?speed=0", "speed"),
    ("usb:56a", "VID:PID"),
    ("mock:intuos-pro-m?tool=quill", "unknown tool"),
])
def test_bad_specs_are_bad_input(spec: str, needle: str, capsys) -> None:
    with pytest.raises(DeviceSpecError, match=needle):
        open_device(spec)
    assert main(["driver", "--device", spec, "--bus", "ipc:unused"]) == 2
    assert needle.split()[0] in capsys.readouterr().err


def test_spec_parsing() -> None:
    spec = DeviceSpec.parse("mock:intuos-pro-m?script=spiral&rate=200&grab")
    assert (spec.scheme, spec.target, spec.options) == (
        "mock", "intuos-pro-m", {"script": "spiral", "rate": "200", "grab": "1"})
    assert spec.speed(1.0) == 1.0 and spec.flag("grab")
    assert DeviceSpec.parse("evdev:/dev/input/event5").target == "/dev/input/event5"


def test_eraser_and_tools_through_the_mock(tmp_path: Path) -> None:
    src = open_device("mock:intuos-pro-m?speed=max&script=eraser&reports=10&tool=pencil")
    samples = list(PenDriver(src).samples())
    assert {s.tool for s in samples} == {Tool.ERASER}
    assert {s.tool_id for s in samples} == {0x81A}  # the pencil's eraser end
    src = open_device("mock:intuos-pro-m?speed=max&script=line&reports=10&tool=brush")
    assert {s.tool for s in PenDriver(src).samples()} == {Tool.BRUSH}


# -- sysfs listing, by configuration -------------------------------------------------------
def test_list_hidraw_reads_sysfs(tmp_path: Path) -> None:
    node = tmp_path / "hidraw7" / "device"
    node.mkdir(parents=True)
    (node / "uevent").write_text("DRIVER=wacom\nHID_ID=0003:0000056A:00000315\n"
                                 "HID_NAME=Wacom Intuos Pro M\n"
                                 "HID_PHYS=usb-0000:00:14.0-2/input1\n")
    (entry,) = list_hidraw(str(tmp_path))
    assert entry["path"] == "/dev/hidraw7" and (entry["vid"], entry["pid"]) == (0x56A, 0x315)
    assert entry["bus"] == 3 and entry["name"] == "Wacom Intuos Pro M"
    # the interface number `station devices` shows comes from the physical path
    assert interface_from_phys(entry["phys"]) == 1
    assert list_hidraw(str(tmp_path / "missing")) == []


def test_station_devices_on_a_machine_without_tablets(capsys) -> None:
    assert main(["devices", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    from station.drivers.registry import load_devices

    specs = {m["spec"] for m in result["mock"]}
    curated = [m for m in load_devices() if "provenance" not in m]
    assert curated and {"mock:" + m["id"].removeprefix("wacom-") for m in curated} <= specs
    if not os.path.isdir("/dev/input") and not list_hidraw():
        assert result["found"] == 0 and result["notes"]
        assert main(["devices"]) == 0
        assert "No pen tablet found" in capsys.readouterr().out


# -- driver → bus ---------------------------------------------------------------------------
def test_driver_to_bus_in_threads(tmp_path: Path) -> None:
    endpoint = f"ipc://{tmp_path}/bus"
    pub = Publisher(endpoint)
    sub = Subscriber(endpoint, topics=("pen.",))
    assert pub.wait_for_subscribers(1, timeout=5.0)
    src = open_device("mock:graphire-usb?speed=max&script=arc&reports=15", name="mock-0")
    sent = list(PenDriver(src).samples())
    for s in sent:
        pub.publish_pen(s)
    got: list[PenSample] = []
    while len(got) < len(sent):
        msg = sub.recv(2000)
        assert msg is not None, f"only {len(got)} of {len(sent)} arrived"
        got.append(msg.value)
    assert [m.to_record() for m in got] == [s.to_record() for s in sent]
    assert {m.device for m in got} == {"mock-0"}
    sub.close()
    pub.close()


def _env(tmp_path: Path) -> dict[str, str]:
    return {**os.environ, "STATION_RUNTIME_DIR": str(tmp_path / "run")}


def test_driver_process_publishes_and_exits_0_on_sigterm(tmp_path: Path) -> None:
    endpoint = f"ipc://{tmp_path}/bus"
    sub = Subscriber(endpoint, topics=("pen.", "status"))  # connects; the driver binds
    proc = subprocess.Popen(
        [PY, "-m", "station", "driver", "--device",
         "mock:intuos-pro-m?script=spiral&rate=200&repeat=0&reports=60", "--bus", endpoint,
         "--name", "mock-0", "--wait-subscribers", "1", "--status-interval", "0.2"],
        env=_env(tmp_path), stderr=subprocess.PIPE, text=True)
    pens: list[PenSample] = []
    statuses: list[dict] = []
    deadline = time.monotonic() + 20
    try:
        while (len(pens) < 40 or not statuses) and time.monotonic() < deadline:
            msg = sub.recv(500)
            if msg is None:
                assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
                continue
            (pens if msg.kind == "pen" else statuses).append(msg.value)
    finally:
        proc.send_signal(signal.SIGTERM)
        rc = proc.wait(timeout=10)
    assert rc == 0
    assert len(pens) >= 40 and {p.device for p in pens} == {"mock-0"}
    for p in pens:
        assert 0 <= p.x <= 1 and 0 <= p.y <= 1 and (p.touching or p.pressure == 0.0)
    seqs = [p.seq for p in pens]
    assert seqs == sorted(seqs)
    st = statuses[-1]
    assert st["kind"] == "driver" and st["parser"] == "wacom-intuos"
    assert st["features_sent"] == ["02 02"] and st["bad_reports"] == 0
    sub.close()


def test_driver_reconnects_after_unplug_and_keeps_session_time(tmp_path: Path) -> None:
    out = tmp_path / "d.jsonl"
    rc = main(["driver", "--device", "mock:bamboo-pen-ctl460?script=line&speed=max&unplug=1"
               "&reports=10", "--bus", f"ipc://{tmp_path}/bus2", "--max-reconnects", "2",
               "--jsonl", str(out)])
    assert rc == 0
    from station.sessionlog import read_session

    _, records = read_session(out)
    pens = [r for r in records if isinstance(r, PenSample)]
    strokes = sum(1 for a, b in pairwise(pens) if b.touching and not a.touching)
    assert strokes == 3  # the first connection and two reconnections
    assert all(b.t >= a.t for a, b in pairwise(pens))


def test_record_then_replay_matches_the_mock(tmp_path: Path, capsys) -> None:
    out = tmp_path / "rec.hid"
    assert main(["record", "--device", "mock:intuos-pro-2-m-pth660?speed=max&script=buttons"
                 "&reports=12", "-o", str(out)]) == 0
    assert "reports written" in capsys.readouterr().err
    (dev,) = read_trace(out).devices
    assert (dev.vid, dev.pid) == (0x056A, 0x0357) and dev.descriptor
    direct = list(PenDriver(open_device(
        "mock:intuos-pro-2-m-pth660?speed=max&script=buttons&reports=12")).samples())
    assert fields(list(iter_trace_samples(out))) == fields(direct)
    short = tmp_path / "short.hid"
    assert main(["record", "--device", "mock:intuos-pro-m?speed=max&script=demo",
                 "--duration", "0.2", "-o", str(short)]) == 0
    (d,) = read_trace(short).devices
    assert d.reports[-1].time - d.reports[0].time <= 0.2 + 1e-6


def test_hidraw_ioctl_numbers_match_the_kernel_headers() -> None:
    from station.drivers.transport import hidraw as h

    # values of the macros in linux/hidraw.h on x86-64 / arm64
    assert h.HIDIOCGRDESCSIZE == 0x80044801
    assert h.HIDIOCGRDESC == 0x90044802
    assert h.HIDIOCGRAWINFO == 0x80084803
    assert h.HIDIOCGRAWNAME(256) == 0x81004804
    assert h.HIDIOCGRAWPHYS(256) == 0x81004805
    assert h.HIDIOCSFEATURE(2) == 0xC0024806
    with pytest.raises(TransportError, match="no such hidraw node"):
        h.OsHidrawNode("/nonexistent/hidraw0")
