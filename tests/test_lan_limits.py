"""Bounded everything (issue 25 item 3): the supervisor's back-off has a floor and a
give-up limit."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

from station.cli import main


def test_restart_delay_below_the_floor_is_refused(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    bp = tmp_path / "bp.xml"
    bp.write_text('<station name="crash" version="1">\n'
                  '<driver id="pen" device="mock:intuos-pro-m" restart-delay="0ms"/>\n'
                  '<recorder id="rec" output="rec.jsonl"><requires interface="pen" '
                  'from="pen"/></recorder></station>\n')
    assert main(["blueprint", "check", str(bp)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "100ms floor" in err[0], err


def test_a_component_crashing_in_a_row_is_given_up(tmp_path: Path) -> None:
    (tmp_path / "bp.xml").write_text(
        '<station name="crash" version="1">\n'
        '<driver id="pen" device="hidraw:/dev/hidraw-not-here" restart-delay="100ms" '
        'restart-limit="1"/>\n'
        '<recorder id="rec" output="rec.jsonl"><requires interface="pen" from="pen"/>'
        '</recorder></station>\n')
    run = tmp_path / "r"
    sup = subprocess.Popen([sys.executable, "-m", "station", "run", "bp.xml", "--run-dir",
                            str(run)], cwd=tmp_path, stdout=subprocess.DEVNULL,
                           stderr=subprocess.PIPE, text=True)
    pen: dict = {}
    try:
        deadline = time.monotonic() + 90
        while time.monotonic() < deadline:
            try:
                pen = json.loads((run / "supervisor.json").read_text())["components"]["pen"]
            except (OSError, ValueError, KeyError):
                pen = {}
            if pen.get("state") == "failed":
                break
            time.sleep(0.2)
        time.sleep(0.5)  # no further start after giving up
        after = json.loads((run / "supervisor.json").read_text())["components"]["pen"]
    finally:
        sup.terminate()
        _out, err = sup.communicate(timeout=60)
    assert pen.get("state") == "failed" and pen.get("restarts") == 1, pen
    assert after.get("restarts") == 1
    assert "2 times in a row: giving up on it (restart-limit=1)" in err, err[-2000:]
    delays = [float(ln.rsplit(" in ", 1)[1].split()[0]) for ln in err.splitlines()
              if ln.startswith("station run: pen died (exit 1)") and " restart " in ln]
    assert delays == [0.1], err[-2000:]


def test_a_canvas_larger_than_memory_allows_is_refused_up_front(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    from station import sizes
    from station.sim import paint

    monkeypatch.setattr(sizes, "available_memory", lambda: 8_000_000_000)
    code = main(["demo", "--size", "4096x4096", "-o", str(tmp_path / "x.png")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert "4096x4096 needs about 15.1 GB" in err[0] and "8.0 GB available" in err[0], err
    assert not (tmp_path / "x.png").exists()
    paint.check_size(2048, 2048, "--size")  # 3.8 GB of 8: fine


def test_a_bus_flood_is_dropped_and_counted(tmp_path: Path) -> None:
    from station.events import PenSample, Tool
    from station.sim import live
    from station.sim.live import LiveConfig, LiveCore

    core = LiveCore(LiveConfig(bus=None, width=24, height=16, backend="numpy", rate=40.0,
                               log_path=str(tmp_path / "s.jsonl"), autosave=0.0))
    # the gate at a rate this loop outruns in process (the real one: 4000/s, 8000 burst)
    core.flood_rate, core.flood_burst = 200.0, 500.0
    n = 6000
    t0 = time.monotonic()
    for i in range(n):
        core.handle("pen", PenSample(t=i * 1e-5, device="flood", tool=Tool.PEN, x=0.5, y=0.5,
                                     proximity=True, touching=False, seq=i + 1))
    elapsed = time.monotonic() - t0
    c = core.counters
    assert c.samples <= 500 + 200 * elapsed + 1, (c, elapsed)
    assert c.samples + c.flood_dropped == n and c.flood_dropped > n // 2
    assert core.status()["flood_dropped"] == c.flood_dropped
    log_lines = (tmp_path / "s.jsonl").read_text().count("\n") if core.journal.sync() else 0
    assert log_lines <= c.samples + 5  # the log grows only by what was painted
    for k in range(200):  # a flood of device names: state for at most MAX_DEVICES
        core.handle("pen", PenSample(t=1.0, device=f"d{k}", tool=Tool.PEN, x=0.5, y=0.5,
                                     proximity=True, touching=False, seq=1))
    assert len(core.devices) <= live.MAX_DEVICES
