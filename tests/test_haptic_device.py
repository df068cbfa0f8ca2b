"""The haptic driver against the mock device on a pty pair: the whole loop, through pyserial.

Every test here ends by checking every force frame any mock device received
against the device's declared limits and the configured ``max_force``.
"""

from __future__ import annotations

import itertools
import os
import signal
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from station.drivers.haptic import source as haptic_source
from station.drivers.haptic.safety import ForceLimits
from station.drivers.pipeline import DeviceSpec, PenDriver, open_device

from station import wire
from station.bus import Publisher
from station.cli import main
from station.events import PenSample
from station.sessionlog import read_session

pytestmark = pytest.mark.timeout(60)


@pytest.fixture(autouse=True)
def _limits_never_exceeded() -> Iterator[None]:
    yield
    for spec_text, mock in list(haptic_source._MOCKS.items()):
        spec = DeviceSpec.parse(spec_text)
        configured = spec.options.get("max_force")
        limits = ForceLimits.from_device(mock.hello.max_force,
                                         float(configured) if configured else None)
        try:
            assert mock.violations == 0
            for r in mock.received:
                assert limits.within(r.force.vector), (spec_text, r)
        finally:
            haptic_source.forget_mock(spec_text)


def _wait(cond, timeout: float = 5.0) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.005)


def _mock(spec: str):
    return haptic_source._MOCKS[DeviceSpec.parse(spec).text]


def test_stroke_paints_and_the_force_rises_with_the_press(tmp_path: Path) -> None:
    spec = "serial-mock:?script=stroke&max_force=1.2"
    log = tmp_path / "stroke.jsonl"
    assert main(["driver", "--device", spec, "--bus", f"ipc://{tmp_path}/bus",
                 "--jsonl", str(log), "--status-interval", "0.2"]) == 0
    mock = _mock(spec)
    # the force the device felt: nothing while hovering, rising as the hand presses deeper
    rec = [(r.t, r.force.fz) for r in mock.received]
    hover = [fz for t, fz in rec if t < 0.4]
    early = [fz for t, fz in rec if 0.75 <= t < 0.95]
    late = [fz for t, fz in rec if 1.35 <= t < 1.55]
    assert hover and max(hover) == 0.0
    assert 0.2 < np.mean(early) < np.mean(late) - 0.3
    assert max(fz for _, fz in rec) <= 1.2  # the configured limit held while pressing hardest
    assert max(fz for _, fz in rec) > 1.1  # … and the spring did reach it
    # the pen samples: a left-to-right stroke whose pressure rises with the force
    _, records = read_session(log)
    pens = [r for r in records if isinstance(r, PenSample)]
    down = [p for p in pens if p.touching]
    assert len(down) > 300
    assert down[0].x < 0.42 and down[-1].x > 0.58
    third = len(down) // 3
    assert np.mean([p.pressure for p in down[:third]]) < np.mean(
        [p.pressure for p in down[-third:]])
    # … and it paints through the ordinary paint path
    from station.sim.paint import paint

    png, state = tmp_path / "stroke.png", tmp_path / "stroke.npz"
    result = paint(str(log), str(png), size=(64, 48), backend="numpy", state_path=str(state))
    assert result.steps > 0 and png.exists()
    with np.load(state) as z:
        pigment = (z["p"] + z["q"])[0]  # in the water + deposited, per cell
    x0, x1 = round(down[0].x * 64), round(down[-1].x * 64)
    y0, y1 = round(down[0].y * 48), round(down[-1].y * 48)
    cols = pigment.sum(axis=0)
    assert (cols[x0 + 1 : x1 - 1] > 0.01).all()  # every column the stroke crosses got paint
    inside = pigment[min(y0, y1) - 4 : max(y0, y1) + 5, x0 - 3 : x1 + 4].sum()
    assert inside == pytest.approx(pigment.sum())  # and nothing anywhere else
    mid = (x0 + x1) // 2
    assert cols[mid:x1].sum() > 1.1 * cols[x0:mid].sum()  # pressing harder: a wider stroke


def test_device_watchdog_zeroes_force_within_50ms_of_silence() -> None:
    spec = "serial-mock:?script=rest"
    src = open_device(spec)
    mock = src.mock
    try:
        _wait(lambda: any(f > 0.3 for _, f, _ in mock.applied))
        src.session.pause()  # the station hangs: no frame at all reaches the device
        time.sleep(0.15)
        silent_since = max(r.t for r in mock.received)
        after = [(t, f) for t, f, last in mock.applied if last == silent_since and t > silent_since]
        assert after and after[-1][0] > silent_since + 0.08
        before = [f for t, f in after if t <= silent_since + 0.05]
        zero_at = min(t for t, f in after if f == 0.0)
        assert zero_at - silent_since <= 0.050 + 0.001  # one 1 ms record of resolution
        assert all(f == 0.0 for t, f in after if t > silent_since + 0.05)
        assert max(before) > 0.3  # it was pushing until then
        assert mock.watchdog_trips >= 1
        # the station comes back: the device's watchdog error trips the station's filter,
        # and the force ramps up again from zero
        n = len(mock.received)
        src.session.pause(False)
        _wait(lambda: len(mock.received) > n + 100)
        resumed = [r.force.fz for r in mock.received[n:]]
        assert resumed[0] == 0.0 and max(resumed) > 0.3
        assert src.session.stats.device_errors.get("watchdog", 0) >= 1
    finally:
        src.close()


def test_station_watchdog_zeroes_force_when_poses_stop() -> None:
    spec = "serial-mock:?script=rest"
    src = open_device(spec)
    mock = src.mock
    try:
        _wait(lambda: len(mock.received) > 200 and mock.received[-1].force.fz > 0.3)
        mock.muted = True
        last_pose = mock.poses_sent[-1]
        time.sleep(0.15)
        after = [r for r in mock.received if r.t > last_pose]
        # the end of the pushing: the first frame of the final run of zeros (an earlier zero
        # can come from a trip, e.g. the device's own watchdog if this loaded machine stalls)
        last_push = max(i for i, r in enumerate(after) if r.force.magnitude > 0.0)
        zero = after[last_push + 1]
        latency = zero.t - last_pose
        # the station decides at 50 ms after the last pose arrived and its next tick sends
        # zero; the allowance is for scheduling on a loaded 2-core machine
        print(f"station watchdog: zero force {latency * 1000:.1f} ms after the last pose")
        assert 0.045 <= latency <= 0.050 + 0.025
        assert len(after) - last_push > 50  # and it stays zero
        assert src.session.safety is not None and src.session.safety.stats.watchdog_trips >= 1
    finally:
        src.close()


def test_bad_frames_are_counted_dropped_and_zero_the_force() -> None:
    spec = "serial-mock:?script=rest&corrupt=0.05&seed=3"
    src = open_device(spec)
    driver = PenDriver(src, live=True)
    try:
        samples = []
        deadline = time.monotonic() + 0.8
        while time.monotonic() < deadline:
            samples += driver.poll(0.05)
        status = driver.status()
        poses = src.session.stats.poses
        bad = status["bad_reports"]
        assert 0.02 * (poses + bad) < bad < 0.09 * (poses + bad)
        assert set(status["bad_reasons"]) <= {"CRC mismatch", "COBS block", "frame too long",
                                              "zero byte inside a COBS frame", "pose payload"}
        assert src.session.safety is not None
        assert src.session.safety.stats.trips["bad frame"] >= bad * 0.5  # bursts merge in a tick
        assert len(samples) > 0.9 * poses  # good poses still become samples
    finally:
        src.close()


def test_unplug_and_replug_are_survived(tmp_path: Path, capsys) -> None:
    spec = "serial-mock:?script=rest&unplug=0.4&replug=0.3"
    log = tmp_path / "replug.jsonl"
    timer = threading.Timer(2.0, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    try:
        assert main(["driver", "--device", spec, "--bus", f"ipc://{tmp_path}/bus",
                     "--jsonl", str(log)]) == 0
    finally:
        timer.cancel()
    assert '"reconnects": 1' in capsys.readouterr().err
    mock = _mock(spec)
    assert mock.unplugs == 1 and mock.plugged
    before = [t for t in mock.poses_sent if t < 0.4]
    after = [t for t in mock.poses_sent if t > 0.4 + 0.3]
    assert len(before) > 200 and len(after) > 300
    _, records = read_session(log)
    pens = [r for r in records if isinstance(r, PenSample)]
    assert len(pens) >= 0.9 * (len(before) + len(after))  # both sessions' poses became samples
    assert sum(p.touching for p in pens) > 400
    later = [r.force.fz for r in mock.received if r.t > 0.4 + 0.3]
    assert later and max(later) > 0.3  # forces again after the replug
    assert not mock.enabled and mock.received[-1].force.magnitude == 0.0  # station exit


def test_bus_forces_are_rendered_and_stop_with_the_bus(tmp_path: Path) -> None:
    """input=0: the device only renders what the simulation publishes on haptic.<device>."""
    spec = "serial-mock:?script=hover&input=0&slew=1000"
    endpoint = f"ipc://{tmp_path}/bus"
    pub = Publisher(endpoint, bind=True)
    src = open_device(spec, name="hx")
    src.attach_bus(endpoint)
    mock = src.mock
    try:
        time.sleep(0.2)  # the subscription settles
        t0 = time.monotonic()
        for i in range(20):  # 30 Hz frames, 0 → 0.5 of the limit and back
            amp = 0.5 * (1 - abs(i - 10) / 10)
            pub.publish_haptic("hx", wire.Haptic(t=i / 30, amplitude=amp))
            time.sleep(t0 + (i + 1) / 30 - time.monotonic())
        stop_at = mock.now()
        time.sleep(0.15)
        fz = [(r.t, r.force.fz) for r in mock.received]
        peak = max(f for _, f in fz)
        assert 0.5 * 2.97 * 0.6 < peak <= 0.5 * 2.97 * (1 + 1e-6)  # limit magnitude 2.97 N
        steps = [abs(b[1] - a[1]) for a, b in itertools.pairwise(fz) if b[1] and a[1]]
        # interpolated: a 30 Hz staircase would make ~18 steps of 0.15 N (a stall of this
        # loaded machine may make one or two big ones)
        assert sum(s > 0.08 for s in steps) <= 2 and np.median(steps) < 0.01
        assert all(f == 0.0 for t, f in fz if t > stop_at + 0.05 + 0.015)
        assert src.session.stats.bus_forces == 20
    finally:
        src.close()
        pub.close()


def test_bad_device_specs_and_flags_exit_2(capsys) -> None:
    for spec, needle in (("serial-mock:?script=nope", "script"),
                         ("serial-mock:?max_force=abc", "max_force"),
                         ("serial-mock:?bogus=1", "bogus"),
                         ("serial-mock:?input=0&force=0", "nothing to do"),
                         ("serial:usb:zz", "VID:PID"),
                         ("serial:/dev/null?rate=5", "rate")):
        assert main(["driver", "--device", spec]) == 2, spec
        err = capsys.readouterr().err.strip()
        assert needle in err and "\n" not in err
    assert main(["driver", "--device", "serial:/nonexistent/ttyACM9"]) == 1
    assert "no such serial device" in capsys.readouterr().err
