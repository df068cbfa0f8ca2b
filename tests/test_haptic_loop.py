"""The haptic loop single-stepped on a simulated clock against an in-memory line.

No threads, no sleeping: every tick is called by the test at the time the
test says, so the timing rules (watchdog at 50 ms, interpolation between sim
frames, rate limit, trips) are checked exactly.
"""

from __future__ import annotations

import itertools
import math
import random

import pytest
from station.drivers.haptic.contact import RoundBrushContact
from station.drivers.haptic.loop import HapticConfig, HapticSession, handle_axis, tilt_degrees
from station.drivers.mock.haptic import default_hello
from station.drivers.serial.protocol import (
    ERR_VERSION,
    STATION_TYPES,
    DeviceError,
    Enable,
    Force,
    FrameDecoder,
    Heartbeat,
    HelloRequest,
    Pose,
    Vibration,
    encode_frame,
)
from station.drivers.serial.transport import UsbSerialId, find_usb_port
from station.drivers.transport.base import DeviceSpecError, TransportError

from station import wire
from station.cli import main


class Line:
    """The station's end of an in-memory serial line; the test plays the device."""

    port = "line"

    def __init__(self) -> None:
        self.inbox = bytearray()
        self.decoder = FrameDecoder(accept=STATION_TYPES)
        self.sent: list[tuple[float, object]] = []
        self.clock = [0.0]
        self.seq = 0

    def device_sends(self, message: object) -> None:
        self.inbox += encode_frame(message, self.seq)  # type: ignore[arg-type]
        self.seq += 1

    def read(self, timeout: float | None = 0.0) -> bytes:
        if not self.inbox and self.clock[0] == 0.0:
            self.device_sends(default_hello())  # answer the hello request
        data = bytes(self.inbox)
        self.inbox.clear()
        return data

    def write(self, data: bytes) -> None:
        for _, msg in self.decoder.feed(data):
            self.sent.append((self.clock[0], msg))

    def close(self) -> None:
        pass

    def forces(self) -> list[tuple[float, Force]]:
        return [(t, m) for t, m in self.sent if isinstance(m, Force)]


def _session(**config) -> tuple[HapticSession, Line]:
    line = Line()
    session = HapticSession(line, HapticConfig(**config), clock=lambda: line.clock[0])
    session.handshake()
    line.clock[0] = 1.0
    return session, line


def _run(session: HapticSession, line: Line, until: float, each=None) -> None:
    while line.clock[0] < until - 1e-9:
        line.clock[0] = round(line.clock[0] + 0.001, 6)
        if each is not None:
            each(line.clock[0])
        session.tick()


def test_handshake_enables_and_stop_zeroes() -> None:
    session, line = _session()
    assert isinstance(line.sent[0][1], HelloRequest)
    assert [type(m) for _, m in line.sent[1:]] == [Force, Enable]
    assert session.limits is not None and session.limits.axis == pytest.approx((2.97, 2.97, 2.97))
    session.stop()
    assert isinstance(line.sent[-2][1], Force) and line.sent[-2][1].magnitude == 0.0
    assert line.sent[-1][1] == Enable(False)


def test_no_hello_is_a_transport_error() -> None:
    class Mute(Line):
        def read(self, timeout: float | None = 0.0) -> bytes:
            self.clock[0] += 0.05
            return b""

    line = Mute()
    session = HapticSession(line, HapticConfig(), clock=lambda: line.clock[0])
    with pytest.raises(TransportError, match="no hello"):
        session.handshake()
    assert sum(isinstance(m, HelloRequest) for _, m in line.sent) == 5  # every 200 ms for 1 s

    class Foreign(Line):
        def read(self, timeout: float | None = 0.0) -> bytes:
            if not self.inbox:
                self.device_sends(DeviceError(ERR_VERSION, "speaks 2.x"))
            data = bytes(self.inbox)
            self.inbox.clear()
            return data

    line = Foreign()
    with pytest.raises(TransportError, match="does not speak"):
        HapticSession(line, HapticConfig(), clock=lambda: line.clock[0]).handshake()


def test_pose_watchdog_zeroes_exactly_after_50ms() -> None:
    session, line = _session(contact=RoundBrushContact(grain=0.0, friction=0.0),
                             rate_n_per_s=1000.0)

    def pose(t: float) -> None:
        if t <= 1.2:
            line.device_sends(Pose(round(t * 1e6), 0.0, 0.0, 3.0))

    _run(session, line, 1.4, pose)
    forces = line.forces()
    pressing = [f.fz for t, f in forces if 1.1 < t <= 1.2]
    assert pressing == pytest.approx([1.5] * len(pressing))  # 3 mm into 6 mm hairs at 0.5 N/mm
    last_pose_arrival = 1.2  # read on the tick at 1.2
    after = [(t, f.fz) for t, f in forces if t > last_pose_arrival]
    # (the tick at exactly 50 ms may go either way in floating point)
    assert all(fz == 1.5 for t, fz in after if t < last_pose_arrival + 0.0499)
    assert all(fz == 0.0 for t, fz in after if t > last_pose_arrival + 0.0501)
    assert session.safety is not None and session.safety.stats.watchdog_trips == 1


def test_bad_frame_zeroes_one_tick_then_ramps_at_the_slew_rate() -> None:
    session, line = _session(contact=RoundBrushContact(grain=0.0, friction=0.0),
                             rate_n_per_s=200.0)

    def pose(t: float) -> None:
        line.device_sends(Pose(round(t * 1e6), 0.0, 0.0, 3.0))
        if abs(t - 1.1) < 1e-9:
            line.inbox += b"\x07garbage\x00"

    _run(session, line, 1.13, pose)
    fz = {round(t, 3): f.fz for t, f in line.forces() if t > 1.0}
    assert fz[1.099] == 1.5 and fz[1.1] == 0.0
    assert fz[1.101] == pytest.approx(0.2) and fz[1.105] == pytest.approx(1.0)
    assert fz[1.12] == 1.5
    assert session.decoder.stats.bad_frames == 1
    assert session.safety is not None and session.safety.stats.trips["bad frame"] == 1


def test_bus_frames_with_jittery_arrival_render_smoothly_and_stop_after_50ms() -> None:
    session, line = _session(contact=None, input=False, rate_n_per_s=1000.0)
    rng = random.Random(5)
    arrivals = [(1.0 + k / 30 + rng.uniform(0.0, 0.012), k) for k in range(30)]
    heard = []

    def publish(t: float) -> None:
        while arrivals and arrivals[0][0] <= t:
            _, k = arrivals.pop(0)
            heard.append(t)
            session.submit_haptic(wire.Haptic(t=k / 30, amplitude=0.5 * min(k, 15) / 15))

    _run(session, line, 2.2, publish)
    fz = [(t, f.fz) for t, f in line.forces() if t > 1.0]
    values = [f for t, f in fz if t < heard[-1] + 0.0499]  # before the watchdog
    steps = [abs(b - a) for a, b in itertools.pairwise(values)]
    # a staircase would jump 0.1 N per frame; with up to 12 ms of bus jitter a frame later
    # than any recent one still shows, as a step a fifth of that
    assert max(steps) < 0.025
    assert sum(s > 0.0045 for s in steps) <= 5  # the ramp itself: 0.0037 N/ms (±10 % warp)
    assert max(values) == pytest.approx(0.5 * 2.97)  # ramps up to 0.5 of the limit, holds
    last_arrival = heard[-1]
    zero_from = min(t for t, f in fz if t > last_arrival and f == 0.0)
    assert 0.0499 < zero_from - last_arrival <= 0.0511  # the first tick past 50 ms
    assert all(f == 0.0 for t, f in fz if t >= zero_from)


def test_vibration_and_heartbeat_frames() -> None:
    session, line = _session(contact=None)
    session.submit_haptic(wire.Haptic(t=0.0, amplitude=0.5, frequency_hz=250.0, duration_s=0.04))
    _run(session, line, 1.002)
    vib = [m for _, m in line.sent if isinstance(m, Vibration)]
    assert vib == [Vibration(pytest.approx(0.5 * 2.97), 250.0, 40)]  # type: ignore[arg-type]
    quiet, line2 = _session(force=False)
    _run(quiet, line2, 1.1)
    beats = [t for t, m in line2.sent if isinstance(m, Heartbeat)]
    assert not line2.forces()[1:] and 4 <= len(beats) <= 6  # every 20 ms, motors never on
    assert not any(isinstance(m, Enable) for _, m in line2.sent)


def test_pose_becomes_pen_axes() -> None:
    session, line = _session(contact=RoundBrushContact(grain=0.0, friction=0.0))
    h = math.radians(30) / 2
    line.device_sends(Pose(0, -40.0, 30.0, 2.0, (math.cos(h), 0.0, math.sin(h), 0.0), 1))
    _run(session, line, 1.001)
    (raw,) = session.take_samples(0)
    ranges = session.ranges
    assert raw.x / ranges.x.maximum == pytest.approx(40 / 160) and raw.y == 9000
    assert raw.pressure == 1000  # 4 mm deep at 0.5 N/mm = 2 N = full_force
    assert raw.tilt_x == pytest.approx(3000, abs=1) and raw.tilt_y == 0 and raw.buttons == 1
    assert tilt_degrees(handle_axis((1.0, 0.0, 0.0, 0.0))) == (0.0, 0.0)


def test_usb_identity_symlink_rule_and_enumeration(monkeypatch) -> None:
    ident = UsbSerialId.parse("1209:4A50:SN42")
    assert (ident.vid, ident.pid, ident.serial) == (0x1209, 0x4A50, "SN42")
    rule = ident.udev_rule()
    assert 'SYMLINK+="station-haptic-1209-4a50-SN42"' in rule and 'MODE="0660"' in rule
    assert "0666" not in rule and 'ATTRS{serial}=="SN42"' in rule
    for bad in ("1209", "1209:4a50:", "xyz:1", "1209:4a50:a b"):
        with pytest.raises(DeviceSpecError):
            UsbSerialId.parse(bad)

    class Port:
        def __init__(self, device: str, serial: str) -> None:
            self.device, self.vid, self.pid, self.serial_number = device, 0x1209, 0x4A50, serial

    from serial.tools import list_ports

    ports = [Port("/dev/ttyACM0", "SN41"), Port("/dev/ttyACM1", "SN42")]
    monkeypatch.setattr(list_ports, "comports", lambda: ports)
    assert find_usb_port(ident) == "/dev/ttyACM1"
    with pytest.raises(DeviceSpecError, match="add the serial"):
        find_usb_port(UsbSerialId(0x1209, 0x4A50))
    with pytest.raises(TransportError, match="no serial device"):
        find_usb_port(UsbSerialId(0x1209, 0x4A51))


def test_cli_udev_haptic_and_bench_flags(capsys) -> None:
    assert main(["udev", "--haptic", "1209:4a50"]) == 0
    assert 'SYMLINK+="station-haptic-1209-4a50"' in capsys.readouterr().out
    assert main(["udev", "--haptic", "12:zz"]) == 2
    assert main(["bench", "haptic", "--seconds", "0"]) == 2
    assert main(["bench", "haptic", "--rate", "1e6"]) == 2
    err = capsys.readouterr().err
    assert "--seconds" in err and "--rate" in err
