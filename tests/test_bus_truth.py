"""The bus tells the truth (issue 8, item 3): no endpoint stealing, heartbeats and silent
devices, ``station send``."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path
from typing import Any

import pytest
import zmq
from livesim import idle, log_records, start_sim, stop, wait_for, wait_subscriptions

from station import wire
from station.bus import EndpointInUse, Publisher, Subscriber
from station.errors import BusConfigError, WireError
from station.events import PenSample, Tool
from station.sim.live import LiveConfig, LiveCore


def test_second_publisher_on_a_live_ipc_endpoint_is_refused(tmp_path: Path) -> None:
    """The second binder fails; the first keeps its subscribers and loses nothing."""
    ctx = zmq.Context()
    first = Publisher("ipc:dup", context=ctx)
    sub = Subscriber("ipc:dup", topics=("pen.",), context=ctx)
    assert first.wait_for_subscribers(1, 5)
    with pytest.raises(EndpointInUse, match="in use by another live process"):
        Publisher("ipc:dup", context=ctx)
    for i in range(1, 101):
        first.publish_pen(PenSample(t=i / 100, device="a", tool=Tool.PEN, x=0.5, y=0.5, seq=i))
    got = [sub.recv(1000) for _ in range(100)]
    assert [m.value.seq for m in got if m is not None] == list(range(1, 101))
    assert sub.stats.lost == 0
    sub.close()
    first.close()
    ctx.destroy(linger=0)


def test_a_second_driver_on_the_same_endpoint_exits_2(tmp_path: Path) -> None:
    bus = f"ipc://{tmp_path}/bus"
    with Publisher(bus):
        proc = subprocess.run([sys.executable, "-m", "station", "driver", "--device",
                               "mock:intuos-pro-m?script=line&speed=max", "--bus", bus],
                              capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "in use by another live process" in lines[0], proc.stderr


def test_stale_socket_of_a_killed_process_is_replaced(tmp_path: Path) -> None:
    path = tmp_path / "bus"
    child = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import time
        from station.bus import Publisher
        pub = Publisher("ipc://{path}")
        print("bound", flush=True)
        time.sleep(60)
        """)], stdout=subprocess.PIPE, text=True)
    assert child.stdout is not None and child.stdout.readline().strip() == "bound"
    with pytest.raises(EndpointInUse):
        Publisher(f"ipc://{path}")
    child.send_signal(signal.SIGKILL)
    child.wait(10)
    assert path.exists()  # the dead process left its socket file
    with Publisher(f"ipc://{path}") as pub:
        assert pub.url == f"ipc://{path}"


def test_a_file_that_is_not_a_socket_is_never_replaced(tmp_path: Path) -> None:
    precious = tmp_path / "notes.txt"
    precious.write_text("keep me")
    with pytest.raises(BusConfigError, match="not a socket"):
        Publisher(f"ipc://{precious}")
    assert precious.read_text() == "keep me"


def test_heartbeat_on_the_wire_and_invisible_to_old_subscribers() -> None:
    frames = wire.encode("hb.tab", wire.Heartbeat(0.2, 17), 5, 1)
    env = wire.decode(frames)
    assert env.kind == "heartbeat" and env.value == wire.Heartbeat(0.2, 17)
    assert frames[1][3] == wire.KIND_HEARTBEAT == 6
    for bad in (wire.encode("pen.tab", wire.Heartbeat(0.2, 1), 5, 1),
                [frames[0], frames[1][:-1]]):
        with pytest.raises(WireError):
            wire.decode(bad)
    with pytest.raises(WireError, match="interval"):
        wire.decode([frames[0], frames[1][:20] + bytes(16)])
    ctx = zmq.Context()
    with Publisher("ipc:hb", context=ctx, heartbeat=0.05) as pub, \
            Subscriber("ipc:hb", topics=("pen.", "cmd"), context=ctx) as old, \
            Subscriber("ipc:hb", topics=("pen.", "hb."), context=ctx) as new:
        assert wait_subscriptions(pub, 4)
        pub.publish_pen(PenSample(t=0.0, device="tab", tool=Tool.PEN, x=0.1, y=0.1, seq=1))
        idle(pub, 0.3)
        kinds_old = [m.kind for m in iter(lambda: old.recv(100), None)]
        kinds_new = [m.kind for m in iter(lambda: new.recv(100), None)]
        assert kinds_old == ["pen"]  # a v1 subscriber sees nothing new
        assert kinds_new[0] == "pen" and kinds_new.count("heartbeat") >= 3
        assert old.stats.malformed == new.stats.malformed == 0
    ctx.destroy(linger=0)


def test_heartbeat_reveals_samples_lost_at_the_end_of_a_stream() -> None:
    ctx = zmq.Context()
    with Publisher("ipc:tail", context=ctx, heartbeat=0.05) as pub, \
            Subscriber("ipc:tail", topics=("pen.", "hb."), context=ctx) as sub:
        assert wait_subscriptions(pub, 2)
        for i in range(1, 4):
            pub.publish_pen(PenSample(t=i / 100, device="t", tool=Tool.PEN, x=0.1, y=0.1,
                                      seq=i))
        pub._seq["pen.t"] += 5  # five samples that never made it onto the wire
        idle(pub, 0.2)
        while sub.recv(100) is not None:
            pass
        assert sub.stats.lost == 5 and sub.stats.received == 3
    ctx.destroy(linger=0)


def test_a_silent_device_is_named_and_its_stroke_ended(tmp_path: Path) -> None:
    """LiveCore: heartbeats stop mid-stroke → silent within 1 s, a pen-up synthesised,
    counted and logged; the device speaking again is live again."""
    core = LiveCore(LiveConfig(bus=None, width=32, height=32, backend="numpy",
                               log_path=str(tmp_path / "s.jsonl"), autosave=0.0))
    core.handle("heartbeat", wire.Heartbeat(0.2, 0), topic="hb.tab")
    for i in range(5):
        core.feed_sample(PenSample(t=i * 0.01, device="tab", tool=Tool.PEN, x=0.3 + i * 0.05,
                                   y=0.5, pressure=0.6, touching=True, seq=i + 1))
    t0 = time.monotonic()
    while not core.check_devices():
        assert time.monotonic() - t0 < 1.0, "no silence noticed within 1 s"
        time.sleep(0.01)
    st = core.status()
    assert st["silent_devices"] == ["tab"] and st["devices"]["tab"]["state"] == "silent"
    assert st["synthetic_pen_ups"] == 1 and not core.player.brush.drawing
    assert core.check_devices() == []  # named once
    core.handle("heartbeat", wire.Heartbeat(0.2, 5), topic="hb.tab")
    assert core.status()["silent_devices"] == []
    core.finish()
    pens = [r for r in log_records(tmp_path / "s.jsonl") if r["type"] == "pen"]
    assert len(pens) == 6 and pens[-1]["touching"] is False and pens[-1]["proximity"] is False


def _status(sub: Subscriber, pred: Any, timeout: float) -> dict[str, Any] | None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        m = sub.recv(100)
        if m is not None and m.kind == "status" and pred(m.value):
            return dict(m.value)
    return None


def test_station_send_drives_a_live_sim(tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    from station.cli import main

    bus, status = f"ipc://{tmp_path}/bus", f"ipc://{tmp_path}/status"
    log, state = tmp_path / "s.jsonl", tmp_path / "s.npz"
    pub = Publisher(bus)
    sim = start_sim(bus, "--size", "32x32", "--backend", "numpy", "--log", str(log),
                    "--state", str(state), "--status", "@" + status)
    st_sub = Subscriber(status, topics=("status",))
    try:
        assert pub.wait_for_subscribers(1, 30)
        assert _status(st_sub, lambda s: True, 15) is not None

        def send(*words: str) -> subprocess.CompletedProcess[str]:
            return subprocess.run([sys.executable, "-m", "station", "send", *words],
                                  capture_output=True, text=True, timeout=60)

        ok = send("brush", "size=10", 'pigment={"Burnt Umber": 0.7}')
        assert ok.returncode == 0, ok.stderr
        assert send("profile", '{"name": "ink"}').returncode == 0
        assert send("dry").returncode == 0
        for words, text in ((["brush", 'pigment={"Unobtainium": 1}'], "Unobtainium"),
                            (["profile", "name=oil"], "unknown profile 'oil'"),
                            (["wait", "seconds=1e12"], "wait seconds"),
                            (["fly"], "command 'fly' is unknown"),
                            (["palette"], "not implemented yet"),
                            (["brush", "size"], "is not key=value"),
                            (["brush", "{nope"], "not a JSON object")):
            # refused before anything is sent: in this process (a process each took 1 s)
            assert main(["send", *words]) == 2, words
            err = capsys.readouterr().err
            lines = err.strip().splitlines()
            assert len(lines) == 1 and text in lines[0], (words, err)
        # statuses queue up: the one that already counts the five refusals
        seen = _status(st_sub, lambda s: s["commands"] >= 3 and s["bad_commands"] >= 5, 15)
        assert seen is not None and seen["bad_commands"] == 5 and seen["profile"] == "ink"
        assert send("save").returncode == 0
        assert wait_for(state.exists, 10)
        assert send("stop").returncode == 0
        assert sim.wait(30) == 0
    finally:
        if sim.poll() is None:
            stop(sim)
        st_sub.close()
        pub.close()
    cmds = [r["cmd"] for r in log_records(log) if r["type"] == "cmd"]
    assert cmds == ["brush", "profile", "dry", "wait"]  # save and stop are not logged
    nobody = subprocess.run([sys.executable, "-m", "station", "send", "dry", "--timeout",
                             "0.5"], capture_output=True, text=True, timeout=60)
    assert nobody.returncode == 1 and "no station sim listens" in nobody.stderr


def test_two_sims_cannot_share_the_command_endpoint(tmp_path: Path) -> None:
    first = start_sim(f"ipc://{tmp_path}/bus", "--size", "16x16", "--backend", "numpy",
                      "--status", "none", "--log", str(tmp_path / "a.jsonl"))
    try:
        cmd_sock = Path(os.environ["STATION_RUNTIME_DIR"]) / "sim-cmd"
        assert wait_for(cmd_sock.exists, 30)
        second = subprocess.run(
            [sys.executable, "-m", "station", "sim", "--bus", f"ipc://{tmp_path}/bus2",
             "--size", "16x16", "--backend", "numpy", "--status", "none", "--log",
             str(tmp_path / "b.jsonl")], capture_output=True, text=True, timeout=60)
        assert second.returncode == 2 and "in use" in second.stderr
        assert not (tmp_path / "b.jsonl").exists()  # refused before any file was made
        assert first.poll() is None
    finally:
        code, err = stop(first)
    assert code == 0, err
