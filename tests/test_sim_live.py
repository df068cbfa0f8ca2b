"""``station sim`` end to end: a real process on an ipc bus, SIGTERM, log and state."""

from __future__ import annotations

import itertools
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from station.bus import Publisher, Subscriber
from station.canvas.state import CanvasState
from station.events import Command, PenSample, Tool
from station.sessionlog import read_session


def s_steps(path: Path) -> int:
    return CanvasState.load(path).step_count


def _wait_status(sub: Subscriber, pred: Any, timeout: float) -> dict[str, Any] | None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        msg = sub.recv(200)
        if msg is not None and msg.kind == "status" and pred(msg.value):
            return dict(msg.value)
    return None


def test_sim_paints_bus_input_logs_it_and_saves_on_sigterm(tmp_path: Path) -> None:
    bus = f"ipc://{tmp_path}/bus"
    status = f"ipc://{tmp_path}/status"
    log, state, png = tmp_path / "session.jsonl", tmp_path / "state.npz", tmp_path / "end.png"
    pub = Publisher(bus, bind=True)
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen(
        [sys.executable, "-m", "station", "sim", "--bus", bus, "--size", "48x32",
         "--backend", "numpy", "--log", str(log), "--state", str(state), "--png", str(png),
         "--status", "@" + status, "--rate", "30"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True)
    st_sub = None
    try:
        assert pub.wait_for_subscribers(1, timeout=30.0), "station sim never subscribed"
        st_sub = Subscriber(status, topics=("status",))
        first = _wait_status(st_sub, lambda s: True, 15.0)
        assert first is not None and first["process"] == "sim" and first["width"] == 48
        pub.publish_cmd(Command(t=0.0, cmd="brush", args={
            "kind": "round", "size": 8, "water": 0.9, "pigment": {"French Ultramarine": 0.8}}))
        pub.publish_cmd(Command(t=0.0, cmd="brush", args={"pigment": {"Mauve Dream": 1}}))
        pub.publish_cmd(Command(t=0.0, cmd="sparkle", args={}))
        t0 = 100.0  # the publisher's own clock: the sim re-times into its session clock
        n = 30
        for i in range(n):
            pub.publish_pen(PenSample(t=t0 + i * 0.01, device="test-0", tool="pen",  # type: ignore[arg-type]
                                      x=0.2 + 0.6 * i / (n - 1), y=0.5, pressure=0.8,
                                      touching=True, proximity=True, seq=i + 1))
            time.sleep(0.01)
        pub.publish_pen(PenSample(t=t0 + n * 0.01, device="test-0", tool="pen",  # type: ignore[arg-type]
                                  x=0.8, y=0.5, pressure=0.0, touching=False, proximity=True))
        seen = _wait_status(st_sub, lambda s: s["samples"] >= n + 1 and s["steps"] > 5, 15.0)
        assert seen is not None, "status never showed the samples"
        assert seen["bad_commands"] == 1 and seen["lost_samples"] == 0
        assert seen["commands"] == 2  # the good brush and the (skipped) unknown command
        assert seen["fps"] > 0 and seen["sim_time"] > 0
        proc.send_signal(signal.SIGTERM)
        _out, err = proc.communicate(timeout=30)
        assert proc.returncode == 0, err
        final = _wait_status(st_sub, lambda s: s.get("state") == "stopped", 5.0)
        assert final is not None and final["samples"] == n + 1
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        pub.close()
        if st_sub is not None:
            st_sub.close()

    header, records = read_session(log)
    assert (header.width, header.height) == (48, 32)
    assert header.extra["sim"]["rate"] == 30.0
    pens = [r for r in records if isinstance(r, PenSample)]
    cmds = [r for r in records if isinstance(r, Command)]
    assert len(pens) == n + 1 and sum(p.touching for p in pens) == n
    # the rejected brush is not logged; a no-op wait marks the end
    assert [c.cmd for c in cmds] == ["brush", "sparkle", "wait"]
    assert cmds[-1].args == {"seconds": 0.0}
    assert math.floor(cmds[-1].t * 30 + 1e-6) == s_steps(state)
    # re-timed into the session clock, keeping the device's 10 ms spacing
    ts = [p.t for p in pens]
    assert all(b >= a for a, b in itertools.pairwise(ts))
    assert ts[0] < 60.0
    # each end is moved into its step's slot (1/30 s at --rate 30), so the span may differ
    # from the device's 0.29 s by up to two slots; more would mean the spacing was lost —
    # unless the sim fell behind: then the samples a step's run collected keep their
    # spacing scaled into the slot of the step after it (LiveCore._compressed,
    # tests/test_sim_behind.py), so the span shrinks, never grows
    span = ts[n - 1] - ts[0]
    if abs(span - 0.29) > 2 / 30 + 0.02:
        assert span < 0.29, (span, ts[:n])
    s = CanvasState.load(state)
    assert (s.width, s.height) == (48, 32) and s.step_count > 5
    painted = float(s.p.sum() + s.q.sum())
    assert painted > 1.0  # the stroke's pigment is on the canvas
    assert png.exists() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_sim_wait_runs_painting_time_and_stop_ends_it(tmp_path: Path) -> None:
    bus = f"ipc://{tmp_path}/bus"
    log = tmp_path / "session.jsonl"
    pub = Publisher(bus, bind=True)
    proc = subprocess.Popen(
        [sys.executable, "-m", "station", "sim", "--bus", bus, "--size", "32x32",
         "--backend", "numpy", "--log", str(log), "--status", "none", "--rate", "30"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert pub.wait_for_subscribers(1, timeout=30.0)
        pub.publish_cmd(Command(t=0.0, cmd="wait", args={"seconds": 4.0}))
        time.sleep(0.3)
        pub.publish_cmd(Command(t=0.0, cmd="stop", args={}))
        _out, err = proc.communicate(timeout=30)
        assert proc.returncode == 0, err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        pub.close()
    # the 4 s wait ran 120 steps on top of the wall-clock ones
    summary = json.loads(err.strip().splitlines()[-1].split("stopped ", 1)[1])
    assert summary["steps"] >= 120
    _header, records = read_session(log)
    assert [r.cmd for r in records if isinstance(r, Command)] == ["wait", "wait"]


def test_replaying_a_live_log_repaints_the_live_canvas(tmp_path: Path) -> None:
    """The log of a live run, painted by ``station paint``, runs the same steps and
    gives the same painting, pixel for pixel, even across a wait."""
    from station.cli import main

    bus = f"ipc://{tmp_path}/bus"
    log, state, png = tmp_path / "live.jsonl", tmp_path / "live.npz", tmp_path / "live.png"
    pub = Publisher(bus, bind=True)
    proc = subprocess.Popen(
        [sys.executable, "-m", "station", "sim", "--bus", bus, "--size", "40x40",
         "--backend", "numpy", "--log", str(log), "--state", str(state), "--png", str(png),
         "--status", "none"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert pub.wait_for_subscribers(1, timeout=30.0)
        pub.publish_cmd(Command(t=0.0, cmd="brush", args={
            "size": 10, "water": 1.0, "pigment": {"Burnt Umber": 1.0}}))
        for i in range(25):
            pub.publish_pen(PenSample(t=i * 0.02, device="p", tool="pen",  # type: ignore[arg-type]
                                      x=0.2 + 0.025 * i, y=0.3 + 0.015 * i, pressure=0.9,
                                      touching=True))
            time.sleep(0.02)
            if i == 12:
                pub.publish_cmd(Command(t=0.0, cmd="wait", args={"seconds": 0.5}))
        time.sleep(0.5)
        proc.send_signal(signal.SIGTERM)
        _out, err = proc.communicate(timeout=30)
        assert proc.returncode == 0, err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        pub.close()
    stats = tmp_path / "replay.json"
    assert main(["paint", str(log), "-o", str(tmp_path / "replay.png"), "--backend", "numpy",
                 "--stats", str(stats)]) == 0
    assert json.loads(stats.read_text())["steps"] == CanvasState.load(state).step_count

    from PIL import Image

    live = np.asarray(Image.open(png), dtype=np.int32)
    replay = np.asarray(Image.open(tmp_path / "replay.png"), dtype=np.int32)
    assert (live.sum(axis=2) < 700).mean() > 0.05
    assert np.array_equal(live, replay)  # every record between the same two steps


def test_sim_survives_refused_paint(tmp_path: Path) -> None:
    """A brush with nine pigments cannot paint into one layer: its samples are
    counted and dropped, the process goes on and still exits 0."""
    bus = f"ipc://{tmp_path}/bus"
    status = f"ipc://{tmp_path}/status"
    pub = Publisher(bus, bind=True)
    proc = subprocess.Popen(
        [sys.executable, "-m", "station", "sim", "--bus", bus, "--size", "32x32",
         "--backend", "numpy", "--status", "@" + status],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    st_sub = None
    try:
        assert pub.wait_for_subscribers(1, timeout=30.0)
        st_sub = Subscriber(status, topics=("status",))
        assert _wait_status(st_sub, lambda s: True, 15.0) is not None
        nine = ["French Ultramarine", "Cerulean Blue", "Hansa Yellow", "Cadmium Yellow",
                "Quinacridone Rose", "Cadmium Red", "Indian Red", "Burnt Umber", "Black"]
        pub.publish_cmd(Command(t=0.0, cmd="brush", args={"pigment": dict.fromkeys(nine, 0.5)}))
        for i in range(4):
            pub.publish_pen(PenSample(t=i * 0.01, device="p", tool="pen",  # type: ignore[arg-type]
                                      x=0.3 + 0.1 * i, y=0.5, pressure=0.5, touching=True))
        pub.publish_cmd(Command(t=0.0, cmd="brush", args={"pigment": {"Black": 0.5}}))
        pub.publish_pen(PenSample(t=0.1, device="p", tool="pen",  # type: ignore[arg-type]
                                  x=0.5, y=0.5, pressure=0.5, touching=True))
        seen = _wait_status(st_sub, lambda s: s["bad_samples"] + s["samples"] >= 5, 15.0)
        assert seen is not None
        assert seen["bad_samples"] == 4 and seen["samples"] == 1
        assert seen["stamps"] == 1  # the Black dab painted
        proc.send_signal(signal.SIGTERM)
        _out, err = proc.communicate(timeout=30)
        assert proc.returncode == 0, err
        assert err.count("sample not painted") == 1  # warned once, not per sample
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        pub.close()
        if st_sub is not None:
            st_sub.close()


def test_sim_bad_flags_exit_2_in_one_line(tmp_path: Path, capsys: Any) -> None:
    from station.cli import main

    for args, text in ((["--log", str(tmp_path / "no" / "s.jsonl")], "does not exist"),
                       (["--profile", "oil"], "unknown profile 'oil'"),
                       (["--size", "3x3"], "too small"),
                       (["--bus", "carrier-pigeon://x"], "unknown endpoint")):
        assert main(["sim", "--backend", "numpy", *args]) == 2
        err = capsys.readouterr().err
        assert text in err and len(err.strip().splitlines()) == 1, err


def test_sim_resumes_a_saved_canvas(tmp_path: Path) -> None:
    """``--resume`` continues a state: size and profile from it, paint kept, steps go on."""
    from station.backends.factory import create_backend
    from station.brush.stamp import BrushSettings, RoundBrush
    from station.sim.player import add_sources

    canvas = create_backend("numpy", 40, 30, "ink", 3)
    brush = RoundBrush(40, 30, BrushSettings(size=8, water=1.0, pigment={"Sumi Ink": 0.5}))
    for i in range(6):
        brush.feed(PenSample(t=i * 0.05, device="d", tool="pen",  # type: ignore[arg-type]
                             x=0.2 + 0.1 * i, y=0.5, pressure=0.8, touching=True))
    src = brush.take()
    assert src is not None
    add_sources(canvas, src)
    for _ in range(5):
        canvas.step()
    before = canvas.state()
    saved, after_path = tmp_path / "before.npz", tmp_path / "after.npz"
    before.save(saved)
    proc = subprocess.run(
        [sys.executable, "-m", "station", "sim", "--bus", f"ipc://{tmp_path}/bus",
         "--resume", str(saved), "--backend", "numpy", "--state", str(after_path),
         "--status", "none", "--duration", "0.5"],
        capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert "40x30 ink" in proc.stderr
    after = CanvasState.load(after_path)
    assert (after.width, after.height, after.profile, after.seed) == (40, 30, "ink", 3)
    assert after.step_count >= before.step_count + 10
    total = float(before.p.sum() + before.q.sum())
    assert total > 1.0
    assert float(after.p.sum() + after.q.sum()) == pytest.approx(total, rel=1e-4)


def test_a_record_after_a_wait_ending_just_short_of_a_step_never_goes_back(
        tmp_path: Path) -> None:
    """A wait logged at 0.099998 s whose 0.5 s end falls 2 µs short of step 18's start
    (0.6 s): the next record's slot ends, by its float floor, at 0.099997 s. The log
    kept that time once (a loaded machine's live run), and ``station paint`` refused
    its own log ("time 0.099997 goes back"). The record keeps the wait's time, and the
    log replays to the live painting."""
    from station.cli import main
    from station.sim.live import LiveConfig, LiveCore

    log, png = tmp_path / "live.jsonl", tmp_path / "live.png"
    core = LiveCore(LiveConfig(bus=None, width=16, height=16, backend="numpy", rate=30.0,
                               log_path=str(log), png_path=str(png), status="none",
                               autosave=0.0))
    clock = [0.0]
    core.now = lambda: clock[0]  # type: ignore[method-assign]
    core.feed_command(Command(t=0.0, cmd="brush", args={
        "size": 6, "water": 1.0, "pigment": {"Burnt Umber": 1.0}}))
    for i in range(3):  # three samples in step 0, the last at 0.03 s
        clock[0] = 0.01 * (i + 1)
        core.feed_sample(PenSample(t=clock[0], device="p", tool=Tool.PEN, x=0.3 + 0.1 * i,
                                   y=0.5, pressure=0.9, touching=True))
    while core.player.counters.steps < 2:
        core.step()  # steps 0 and 1: the painting time up to 0.0667 s
    clock[0] = 0.099998  # in step 2's slot [0.0667, 0.1)
    core.feed_command(Command(t=0.0, cmd="wait", args={"seconds": 0.5}))
    assert core.player.counters.steps == 17  # floor(0.599998 * 30)
    clock[0] = 0.099999
    core.feed_sample(PenSample(t=clock[0], device="p", tool=Tool.PEN, x=0.6, y=0.5,
                               pressure=0.9, touching=False))
    core.step()
    core.finish()
    _header, records = read_session(log)
    times = [r.t for r in records]
    assert times == sorted(times), times
    assert times[-2] == 0.099998  # the sample keeps the wait's time: same slot, same step
    out = tmp_path / "replay.png"
    assert main(["paint", str(log), "-o", str(out), "--backend", "numpy"]) == 0
    assert out.read_bytes() == png.read_bytes()
