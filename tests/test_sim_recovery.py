"""No painting is lost: the live sim's log, autosave and ``--recover`` (issue 8, item 2)."""

from __future__ import annotations

import errno
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from livesim import Pen, idle, log_records, paint, pixels, start_sim, stop, wait_for
from livesim import wait_subscriptions as wait_subs

from station.bus import Publisher
from station.canvas.state import read_extra
from station.events import Command, PenSample, Tool
from station.sessionlog import read_session
from station.sim.journal import autosave_path
from station.sim.live import LiveConfig, LiveCore


def warm_up(tmp_path: Path, backend: str) -> None:
    """Compile (and cache) the backend's kernels before timing-sensitive live runs."""
    warm = tmp_path / "warm.jsonl"
    warm.write_text(
        '{"format": "station-session", "version": 1, "canvas": {"width": 32, "height": 32}}\n'
        '{"type": "cmd", "t": 0, "cmd": "brush", "args": {"pigment": {"Black": 0.5}}}\n'
        '{"type": "pen", "t": 0.1, "device": "d", "tool": "pen", "x": 0.5, "y": 0.5, '
        '"pressure": 0.8, "proximity": true, "touching": true}\n'
        '{"type": "cmd", "t": 0.2, "cmd": "wait", "args": {"seconds": 0.2}}\n')
    paint(warm, tmp_path / "warm.png", backend)


def _autosaved_records(log: Path) -> int:
    cp = autosave_path(log)
    if not cp.exists():
        return -1
    return int(read_extra(cp, "session")["log"]["records"])


# On the cpu backend, the kiosk's and ``auto``'s: numpy's recovery after kill -9 is
# test_fault_matrix.py's test_kill_9_sim (the numpy variant here cost ~30 s of the suite).
@pytest.mark.parametrize("backend", ["cpu"])
def test_kill_9_mid_painting_then_recover_is_pixel_exact(tmp_path: Path, backend: str) -> None:
    """kill -9 a real ``station sim`` mid-stroke; ``--recover`` rebuilds the canvas from
    the autosave plus the log since it, pixel for pixel the picture an uninterrupted
    replay of the same input gives, and then goes on painting into the same log."""
    bus = f"ipc://{tmp_path}/bus"
    log, png = tmp_path / "s.jsonl", tmp_path / "final.png"
    common = ["--backend", backend, "--status", "none", "--cmd", "none", "--rate", "40"]
    warm_up(tmp_path, backend)
    pub = Publisher(bus, heartbeat=0.2)
    pen = Pen(pub)
    sim = start_sim(bus, "--size", "64x48", "--log", str(log), "--autosave", "0.3", *common)
    try:
        assert wait_subs(pub, 1), "station sim never subscribed"
        idle(pub, 0.3)
        pub.publish_cmd(Command(t=0.0, cmd="brush", args={
            "size": 8, "water": 0.9, "pigment": {"French Ultramarine": 0.7}}))
        pen.stroke(0.25)
        pen.stroke(0.45)
        assert wait_for(lambda: _autosaved_records(log) >= 26, 20, pub), "no autosave"
        pub.publish_cmd(Command(t=0.0, cmd="brush", args={"pigment": {"Burnt Umber": 0.8}}))
        pen.stroke(0.7, n=14, lift=False, start=0)  # pen still down ...
        pen_n = pen.seq
        assert wait_for(lambda: sum(r.get("seq") == pen_n for r in log_records(log)) == 1,
                        10, pub)
        sim.send_signal(signal.SIGKILL)  # ... when the sim dies
        sim.wait(10)
    finally:
        if sim.poll() is None:
            sim.kill()
            sim.communicate()
    saved = _autosaved_records(log)
    crashed = log_records(log)
    assert 0 < saved < len(crashed)  # the recovery has records to replay after the autosave
    assert any(r.get("touching") for r in crashed[saved:])

    # 1. Recover a copy and stop at once: the picture the dead process had painted.
    crash_dir = tmp_path / "crash"
    crash_dir.mkdir()
    shutil.copy(log, crash_dir / "s.jsonl")
    shutil.copy(autosave_path(log), autosave_path(crash_dir / "s.jsonl"))
    shutil.copy(log, tmp_path / "pristine.jsonl")
    rec = subprocess.run(
        [sys.executable, "-m", "station", "sim", "--bus", f"ipc://{tmp_path}/other",
         "--recover", str(crash_dir / "s.jsonl"), "--duration", "0", "--autosave", "0",
         "--png", str(tmp_path / "recovered.png"), *common],
        capture_output=True, text=True, timeout=120)
    assert rec.returncode == 0, rec.stderr
    assert f"{len(crashed) - saved} records replayed after the autosave" in rec.stderr
    paint(tmp_path / "pristine.jsonl", tmp_path / "uninterrupted.png", backend)
    recovered = pixels(tmp_path / "recovered.png")
    reference = pixels(tmp_path / "uninterrupted.png")
    assert (reference.sum(axis=2) < 650).mean() > 0.05  # there is a painting
    assert np.array_equal(recovered, reference)

    # 2. Recover for real: the same log goes on; the pen finishes its stroke.
    subs_before = pub.subscriptions
    sim = start_sim(bus, "--recover", str(log), "--png", str(png), "--autosave", "0.3", *common)
    try:
        assert wait_subs(pub, subs_before + 1), "recovered sim never subscribed"
        idle(pub, 0.5)
        pen.stroke(0.7, n=20, start=14)  # the rest of the interrupted stroke
        pen.stroke(0.85)
        final = pen.seq
        assert wait_for(lambda: sum(r.get("seq") == final for r in log_records(log)) == 1,
                        10, pub)
        code, err = stop(sim)
        assert code == 0, err
    finally:
        if sim.poll() is None:
            sim.kill()
            sim.communicate()
        pub.close()
    records = log_records(log)
    assert records[: len(crashed)] == crashed  # the log was continued, never rewritten
    seqs = [r["seq"] for r in records if r["type"] == "pen" and r.get("seq")]
    assert seqs == list(range(1, final + 1))  # every sample once: none lost, none twice
    paint(log, tmp_path / "whole.png", backend)
    assert np.array_equal(pixels(png), pixels(tmp_path / "whole.png"))


def test_sim_always_logs_and_never_overwrites(tmp_path: Path) -> None:
    """Without --log the session goes to the data directory; an existing --log is kept
    byte for byte and the new session goes next to it."""
    data = Path(os.environ["STATION_DATA_DIR"])
    bus = f"ipc://{tmp_path}/bus"
    args = ["--size", "32x32", "--backend", "numpy", "--status", "none", "--duration", "0.3"]
    proc = subprocess.run([sys.executable, "-m", "station", "sim", "--bus", bus, *args],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    logs = sorted((data / "sessions").glob("session-*.jsonl"))
    assert len(logs) == 1 and f"logging to {logs[0]}" in proc.stderr
    header, records = read_session(logs[0])
    assert (header.width, header.height) == (32, 32) and records[-1].cmd == "wait"

    mine = tmp_path / "mine.jsonl"
    mine.write_text("precious\n")
    proc = subprocess.run([sys.executable, "-m", "station", "sim", "--bus", bus, "--log",
                           str(mine), *args], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert mine.read_text() == "precious\n"
    assert f"logging to {tmp_path / 'mine-2.jsonl'}" in proc.stderr
    read_session(tmp_path / "mine-2.jsonl")


def _core(tmp_path: Path, **kw: Any) -> LiveCore:
    cfg = LiveConfig(bus=None, width=40, height=32, backend="numpy", rate=40.0,
                     log_path=str(tmp_path / "s.jsonl"), **kw)
    return LiveCore(cfg)


def _paint(core: LiveCore, y: float, n: int = 10) -> None:
    for i in range(n):
        core.feed_sample(PenSample(t=i * 0.01, device="d", tool=Tool.PEN, x=0.2 + 0.06 * i,
                                   y=y, pressure=0.7, touching=True, seq=i + 1))
        core.step()
    core.feed_sample(PenSample(t=n * 0.01, device="d", tool=Tool.PEN, x=0.8, y=y,
                               touching=False, proximity=False))
    core.step()


def test_full_disk_is_reported_once_and_painting_goes_on(tmp_path: Path, caplog: Any,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """ENOSPC on every write: one error in the log, painting goes on, the autosave and
    the log already on disk stay intact; when space is back the log catches up, complete."""
    core = _core(tmp_path, autosave=0.0)
    core.feed_command(Command(t=0.0, cmd="brush", args={"size": 6, "pigment": {"Black": 0.5}}))
    _paint(core, 0.3)
    assert core.autosave()
    cp = core.autosave_path
    saved_cp, saved_log = cp.read_bytes(), core.log_path.read_bytes()

    real_write = os.write

    def full(fd: int, data: Any) -> int:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "write", full)
    caplog.clear()
    steps = core.player.counters.steps
    _paint(core, 0.6)
    assert not core.autosave()  # refused: the log is not on disk
    core.feed_command(Command(t=0.0, cmd="save", args={}))
    for _ in range(5):
        core.tick()
    errors = [r for r in caplog.records if r.levelname == "ERROR"]
    assert len(errors) == 1 and "No space left" in errors[0].getMessage()
    assert core.player.counters.steps >= steps + 11  # painting went on
    assert core.status()["storage_failures"] > 1 and core.status()["log_pending_bytes"] > 0
    assert cp.read_bytes() == saved_cp and core.log_path.read_bytes() == saved_log
    assert not [p for p in tmp_path.iterdir() if ".tmp-" in p.name]

    monkeypatch.setattr(os, "write", real_write)
    core.finish()
    assert core.status()["log_pending_bytes"] == 0
    _header, records = read_session(core.log_path)
    assert sum(isinstance(r, PenSample) for r in records) == 22  # nothing lost
    # the log, replayed, repaints the live canvas
    from station.cli import main

    assert main(["paint", str(core.log_path), "-o", str(tmp_path / "r.png"), "--backend",
                 "numpy", "--state", str(tmp_path / "r.npz")]) == 0
    from station.canvas.state import CanvasState

    assert np.array_equal(CanvasState.load(tmp_path / "r.npz").w, core.canvas.state().w)


def test_partial_write_resumes_where_it_stopped(tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """The disk fills in the middle of a line: the rest follows when space is back, so
    the log holds every line whole (no truncation, no duplicate bytes)."""
    core = _core(tmp_path, autosave=0.0)
    real_write = os.write
    budget = {"n": 50}

    def filling(fd: int, data: Any) -> int:
        if budget["n"] <= 0:
            raise OSError(errno.ENOSPC, "No space left on device")
        n = real_write(fd, bytes(data)[: budget["n"]])
        budget["n"] -= n
        return n

    monkeypatch.setattr(os, "write", filling)
    _paint(core, 0.5, n=4)
    monkeypatch.setattr(os, "write", real_write)
    core.finish()
    _header, records = read_session(core.log_path)
    assert [r.seq for r in records if isinstance(r, PenSample)] == [1, 2, 3, 4, 0]


def test_unwritable_log_path_is_reported_and_painting_goes_on(tmp_path: Path) -> None:
    """A log directory nobody can write (``/proc``): one line, exit 0, the PNG is written."""
    png = tmp_path / "out.png"
    proc = subprocess.run(
        [sys.executable, "-m", "station", "sim", "--bus", f"ipc://{tmp_path}/bus", "--size",
         "32x32", "--backend", "numpy", "--status", "none", "--log", "/proc/self/s.jsonl",
         "--png", str(png), "--duration", "0.5", "--autosave", "0.1"],
        capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.count("cannot write session log") == 1, proc.stderr
    assert png.exists() and "Traceback" not in proc.stderr


def test_recover_flags_and_missing_logs_exit_2(tmp_path: Path, capsys: Any) -> None:
    from station.cli import main

    for args, text in ((["--recover", str(tmp_path / "none.jsonl")], "no such session log"),
                       (["--recover"], "no session log to recover"),
                       (["--recover", "x.jsonl", "--size", "10x10"], "--size cannot be used"),
                       (["--autosave", "-1"], "--autosave")):
        assert main(["sim", "--backend", "numpy", *args]) == 2
        err = capsys.readouterr().err
        assert text in err and len(err.strip().splitlines()) == 1, err


def test_recover_replays_the_whole_log_without_autosave(tmp_path: Path) -> None:
    """No (or a foreign) autosave: the log alone rebuilds the canvas."""
    core = _core(tmp_path, autosave=0.0)
    core.feed_command(Command(t=0.0, cmd="brush", args={"size": 6, "pigment": {"Black": 0.6}}))
    _paint(core, 0.4)
    core.journal.flush()
    want = core.canvas.state()
    want_steps = core.player.counters.steps
    # a stale autosave of another session sits next to the log: it must not be used
    other = LiveCore(LiveConfig(bus=None, width=40, height=32, backend="numpy",
                                log_path=str(tmp_path / "other.jsonl")))
    other.autosave()
    shutil.copy(other.autosave_path, core.autosave_path)
    rec = LiveCore(LiveConfig(bus=None, backend="numpy", recover=str(core.log_path)))
    assert rec.player.counters.steps == want_steps - 1 or rec.player.counters.steps == want_steps
    while rec.player.counters.steps < want_steps:
        rec.step()
    assert np.array_equal(rec.canvas.state().w, want.w)
    assert np.array_equal(rec.canvas.state().p, want.p)


def test_clean_stop_then_recover_continues_exactly(tmp_path: Path) -> None:
    """Stop with stamps still pending (the final autosave holds them in the canvas),
    recover, paint on: the canvas equals the whole continued log painted from scratch."""
    core = _core(tmp_path, autosave=30.0)
    core.feed_command(Command(t=0.0, cmd="brush", args={"size": 6, "pigment": {"Black": 0.6}}))
    _paint(core, 0.3)
    core.feed_sample(PenSample(t=1.0, device="e", tool=Tool.PEN, x=0.5, y=0.3, pressure=0.9,
                               touching=True, seq=1))
    core.feed_sample(PenSample(t=1.01, device="e", tool=Tool.PEN, x=0.5, y=0.3,
                               touching=False, proximity=False, seq=2))
    assert core.player.brush.pending  # a dab not yet stepped
    core.finish()
    assert core.counters.autosaves == 1
    rec = LiveCore(LiveConfig(bus=None, backend="numpy", recover=str(core.log_path),
                              autosave=0.0))
    assert rec.tick()  # the next slot's step runs first
    _paint(rec, 0.3)  # over the wet first stroke and the pending dab
    rec.finish()
    from station.cli import main

    assert main(["paint", str(core.log_path), "-o", str(tmp_path / "r.png"), "--backend",
                 "numpy", "--state", str(tmp_path / "r.npz")]) == 0
    from station.canvas.state import CanvasState

    whole, live = CanvasState.load(tmp_path / "r.npz"), rec.canvas.state()
    assert whole.step_count == live.step_count
    for name in ("w", "p", "q", "wc", "vx", "vy"):
        assert np.array_equal(getattr(whole, name), getattr(live, name)), name


def test_recover_after_autosave_with_a_deformable_brush_is_exact(tmp_path: Path) -> None:
    """The deformable brush carries state between strokes (its reservoir, what it picked
    up, the spines' plastic set): the autosave keeps it, so a recovery from an autosave
    taken between strokes paints on exactly as the uninterrupted session does."""
    core = _core(tmp_path, autosave=0.0)
    core.feed_command(Command(t=0.0, cmd="brush", args={
        "kind": "round3d", "size": 10, "water": 0.8, "pigment": {"French Ultramarine": 0.6}}))
    _paint(core, 0.3)
    _paint(core, 0.5)
    brush = core.player.brush
    assert brush.reservoir.fill < 0.99 and brush.stamps > 0  # the brush is not fresh
    assert not brush.drawing and core.autosave()
    _paint(core, 0.4)  # over the wet strokes: picks up, deposits from a used reservoir
    _paint(core, 0.7)
    core.finish()
    rec = LiveCore(LiveConfig(bus=None, backend="numpy", recover=str(core.log_path),
                              autosave=0.0))
    while rec.player.counters.steps < core.player.counters.steps:
        rec.step()
    want, got = core.canvas.state(), rec.canvas.state()
    for name in ("w", "p", "q", "wc"):
        assert np.array_equal(getattr(want, name), getattr(got, name)), name
    assert rec.player.brush.reservoir.ledger() == core.player.brush.reservoir.ledger()


def test_samples_lost_after_a_crash_right_after_an_autosave_are_counted(tmp_path: Path) -> None:
    """The sim dies just after an autosave, with no record after it: the recovered sim
    still knows each device's last seq (from the records before the autosave) and counts
    the samples sent while no sim listened (CI's fault matrix lost 168 uncounted)."""
    core = _core(tmp_path, autosave=0.0)
    _paint(core, 0.3)  # device "d", seqs 1..10
    assert not core.player.brush.drawing and core.autosave()
    rec = LiveCore(LiveConfig(bus=None, backend="numpy", recover=str(core.log_path),
                              autosave=0.0))
    assert rec.devices["d"].resume_seq == 10
    rec.feed_sample(PenSample(t=2.0, device="d", tool=Tool.PEN, x=0.5, y=0.5, pressure=0.5,
                              touching=True, seq=178))
    assert rec.counters.missed_while_down == 167
    rec.finish()
