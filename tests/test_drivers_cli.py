"""The drivers' commands against this machine: replay onto the bus, missing hardware."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from station.drivers.mock.tablet import MockTablet, find_model
from station.drivers.pipeline import iter_trace_samples
from station.drivers.traces import write_session_log

from station.bus import Subscriber
from station.cli import main
from station.events import PenSample
from station.sessionlog import read_session


def _recording(tmp_path: Path, model: str = "cintiq-22hd") -> Path:
    from station.drivers import synth

    tablet = MockTablet(find_model(model), script="proximity", reports=16)
    for f in tablet.init_features:
        tablet.feature(f)
    info = tablet.info
    path = tmp_path / f"{model}.hid"
    synth.write_hid_recorder([synth.RecordedDevice(
        info.name, info.vid, info.pid, info.descriptor or b"",
        [(r.time, r.data) for r in tablet.timed_reports()], bus=info.bus)], path)
    return path


def test_replay_onto_the_bus(tmp_path: Path, capsys) -> None:
    path = _recording(tmp_path)
    endpoint = f"ipc://{tmp_path}/bus"
    sub = Subscriber(endpoint, topics=("pen.", "status"))  # connects; the replay binds
    assert main(["replay", str(path), "--bus", endpoint, "--name", "cintiq",
                 "--wait-subscribers", "1"]) == 0
    pens: list[PenSample] = []
    statuses: list[dict] = []
    while (msg := sub.recv(1000)) is not None:
        (pens if msg.kind == "pen" else statuses).append(msg.value)
    sub.close()
    expected = [s.with_(device="cintiq") for s in iter_trace_samples(path)]
    assert [p.to_record() for p in pens] == [s.to_record() for s in expected]
    assert sum(1 for p in pens if not p.proximity) == 4  # the script leaves four times
    (status,) = statuses
    assert status["kind"] == "replay" and status["samples"] == len(pens)
    assert "cintiq: " in capsys.readouterr().out


def test_paced_replay_sends_heartbeats_with_the_last_pen_seq(tmp_path: Path) -> None:
    """Issue 8 item 3: a paced replay is a publisher like a driver: heartbeats on
    hb.<device> while it plays (also between samples), each carrying the bus seq of the
    last pen sample sent before it, and a last one at the end with the final seq."""
    path = _recording(tmp_path)  # 44 samples over ~0.97 s; at --speed 2 ~0.48 s
    endpoint = f"ipc://{tmp_path}/bus"
    sub = Subscriber(endpoint, topics=("pen.", "hb."))
    assert main(["replay", str(path), "--bus", endpoint, "--name", "cintiq", "--speed", "2",
                 "--heartbeat", "0.05", "--wait-subscribers", "1"]) == 0
    msgs = list(iter(lambda: sub.recv(1000), None))
    sub.close()
    pen_idx = [i for i, m in enumerate(msgs) if m.kind == "pen"]
    beats = [(i, m) for i, m in enumerate(msgs) if m.kind == "heartbeat"]
    assert len(pen_idx) == 44 and sub.stats.lost == 0 and sub.stats.malformed == 0
    assert all(m.topic == "hb.cintiq" and m.value.interval_s == 0.05 for _, m in beats)
    during = [i for i, _ in beats if pen_idx[0] < i < pen_idx[-1]]
    assert len(during) >= 4, len(during)  # ~9 expected in 0.48 s; a busy machine lags
    last_pen_seq = 0
    for m in msgs:  # every heartbeat names exactly the pen seq sent before it
        if m.kind == "pen":
            last_pen_seq = m.seq
        else:
            assert m.value.pen_seq == last_pen_seq
    assert msgs[-1].kind == "heartbeat" and msgs[-1].value.pen_seq == msgs[pen_idx[-1]].seq == 44


def test_write_session_log_of_a_trace(tmp_path: Path) -> None:
    path = _recording(tmp_path, "graphire-bt")
    out = tmp_path / "s.jsonl"
    n = write_session_log(iter_trace_samples(path), out, source=str(path))
    header, records = read_session(out)
    assert n == len(records) > 10 and header.extra["source"] == str(path)


def test_missing_hardware_fails_cleanly(tmp_path: Path, capsys) -> None:
    for spec, code, needle in (
        ("hidraw:/nonexistent/hidraw9", 1, "no such hidraw node"),
        ("hidapi:056a:0315", 2, "no HID device 056a:0315"),
        ("usb:056a:0315", None, "USB"),
    ):
        rc = main(["record", "--device", spec, "-o", str(tmp_path / "x.hid")])
        err = capsys.readouterr().err
        assert rc in ((1, 2) if code is None else (code,)), (spec, rc, err)
        assert needle in err and err.count("\n") == 1 and "Traceback" not in err


def test_devices_text_lists_every_mock(capsys) -> None:
    assert main(["devices"]) == 0
    out = capsys.readouterr().out
    for name in ("mock:intuos-pro-m", "mock:graphire-bt", "mock:huion-like"):
        assert name in out
    assert main(["devices", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["found"] >= 0


def _driver(*argv: str, tmp_path: Path) -> subprocess.Popen[str]:
    env = {**os.environ, "STATION_RUNTIME_DIR": str(tmp_path / "run")}
    return subprocess.Popen([sys.executable, "-m", "station", "driver", *argv], env=env,
                            text=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def _stop(proc: subprocess.Popen[str], sig: int) -> tuple[int, str]:
    """``sig`` to a driver, its exit code and stderr; killed (never left running) if it
    does not stop in a minute, or if the test failed before the signal."""
    try:
        if proc.poll() is None:
            proc.send_signal(sig)
        _out, err = proc.communicate(timeout=60)
        return proc.returncode, err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_driver_waits_for_a_missing_device_and_stops_on_a_signal(tmp_path: Path,
                                                                 sig: int) -> None:
    endpoint = f"ipc://{tmp_path}/bus"
    sub = Subscriber(endpoint, topics=("status",))
    proc = _driver("--device", "evdev:/nonexistent/event42", "--bus", endpoint, "--wait",
                   "--wait-subscribers", "1", tmp_path=tmp_path)
    stopped: tuple[int, str] | None = None
    try:
        deadline = time.monotonic() + 120  # a loaded machine starts Python slowly
        status = None
        while status is None and time.monotonic() < deadline and proc.poll() is None:
            msg = sub.recv(500)
            status = msg.value if msg is not None else None
        assert status is not None and status["state"] == "waiting", status
        assert "/nonexistent/event42" in status["error"]
        stopped = _stop(proc, sig)
    finally:
        _stop(proc, signal.SIGKILL)
        sub.close()
    assert stopped is not None
    code, err = stopped
    assert code == 0, err


def test_a_driver_stopped_while_waiting_for_subscribers_never_reads_its_device(
        tmp_path: Path) -> None:
    """SIGTERM during --wait-subscribers ends the wait at once: the driver stops without
    opening its device (it used to sit out the whole wait, then open the device and
    write its log as if it was going to run)."""
    sock = tmp_path / "bus"
    log = tmp_path / "pen.jsonl"
    proc = _driver("--device", "mock:intuos-pro-m?script=line", "--bus", f"ipc://{sock}",
                   "--wait-subscribers", "1", "--jsonl", str(log), tmp_path=tmp_path)
    stopped: tuple[int, str] | None = None
    try:
        deadline = time.monotonic() + 120
        while not sock.exists() and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.02)
        assert sock.exists()  # its publisher is bound: it waits for a subscriber now
        stopped = _stop(proc, signal.SIGTERM)
    finally:
        _stop(proc, signal.SIGKILL)
    assert stopped is not None
    code, err = stopped
    assert code == 0, err
    assert not log.exists(), err


def test_driver_normaliser_flags_are_checked(capsys) -> None:
    for flags, needle in ((["--pressure-curve", "0,1,2"], "--pressure-curve"),
                          (["--pressure-curve", "0,1.5,0.5,1"], "pressure curve"),
                          (["--tip-down", "0.01", "--tip-up", "0.05"], "tip_up"),
                          (["--status-interval", "0"], "--status-interval")):
        assert main(["driver", "--device", "mock:intuos-pro-m", *flags]) == 2
        assert needle in capsys.readouterr().err


def test_record_evdev_as_libinput_yaml_and_driver_area(tmp_path: Path) -> None:
    from station.drivers.mock.evdev import states_to_events, wacom_like_caps
    from station.drivers.mock.script import timed_states
    from station.drivers.traces.evemu import format_evemu

    caps = wacom_like_caps()
    src = tmp_path / "pen.evemu"
    src.write_text(format_evemu(caps, states_to_events(caps, timed_states("line", reports=12))))
    out = tmp_path / "pen.yaml"
    assert main(["record", "--device", f"mock-evdev:{src}?speed=max", "-o", str(out)]) == 0
    a, b = list(iter_trace_samples(src)), list(iter_trace_samples(out))
    assert [(s.x, s.y, s.pressure, s.touching) for s in a] == \
        [(s.x, s.y, s.pressure, s.touching) for s in b]
    # the active area: the left half of the tablet becomes the whole [0, 1]
    log = tmp_path / "area.jsonl"
    assert main(["driver", "--device", f"mock-evdev:{src}?speed=max", "--bus",
                 f"ipc://{tmp_path}/bus", "--area", "0,0,22352,27940", "--mapping", "stretch",
                 "--jsonl", str(log)]) == 0
    _, records = read_session(log)
    xs = [r.x for r in records if isinstance(r, PenSample)]
    full = [s.x for s in a]
    assert xs == pytest.approx([min(1.0, 2 * x) for x in full])  # 0.1 → 0.2, past half → 1
    assert max(xs) == 1.0
