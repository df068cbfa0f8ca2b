"""Long work shows progress on a terminal and nothing otherwise (issue 8 item 7).

A terminal is faked with a StringIO whose ``isatty()`` is true, installed as
``sys.stderr``; the same commands with a plain (non-terminal) stderr must leave
no bar, no carriage return, no progress text behind.
"""

from __future__ import annotations

import io
import json
import re
import sys
from pathlib import Path

import pytest
from station.drivers import synth
from station.drivers.mock.tablet import MockTablet, find_model

from station.cli import cmd_demo, main
from station.pictures.demo import DEMO_FILE
from station.progress import Progress, on_terminal
from station.sim.script import Script


class FakeTTY(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_draws_on_a_terminal_only() -> None:
    tty, pipe = FakeTTY(), io.StringIO()
    assert on_terminal(tty) and not on_terminal(pipe)
    for stream in (tty, pipe):
        with Progress(40, "work", unit="step", stream=stream, interval=0) as bar:
            bar.note("first half")
            for _ in range(20):
                bar.update()
            bar.write("a line above the bar")
            bar.set(40)
            bar.set(10)  # never back
    out = tty.getvalue()
    assert out.startswith("\rwork:") and "100%" in out and "40/40" in out
    assert "first half" in out and "a line above the bar\n" in out and out.endswith("\n")
    assert pipe.getvalue() == ""
    forced = io.StringIO()
    with Progress(3, "forced", stream=forced, show=True) as bar:
        bar.update(3)
    assert "forced:" in forced.getvalue()
    closed = io.StringIO()
    closed.close()
    assert not on_terminal(closed)  # isatty() on a closed stream raises: not a terminal
    assert Progress(3, "x", stream=closed).enabled is False


def _session(tmp_path: Path) -> Path:
    s = Script(24, 16, seed=1)
    s.brush(size=4, water=0.6, pigment={"Burnt Umber": 0.5})
    s.line((0.2, 0.5), (0.8, 0.5), 0.3, pressure=0.8)
    s.wait(0.5)
    path = tmp_path / "s.jsonl"
    s.save(path)
    return path


def _trace(tmp_path: Path) -> Path:
    tablet = MockTablet(find_model("intuos-pro-m"), script="demo", reports=60)
    for feature in tablet.init_features:
        tablet.feature(feature)
    info = tablet.info
    dev = synth.RecordedDevice(info.name, info.vid, info.pid, info.descriptor or b"",
                               [(r.time, r.data) for r in tablet.timed_reports()], bus=info.bus)
    path = tmp_path / "t.hid"
    synth.write_hid_recorder([dev], path)
    return path


COMMANDS = {
    "paint": lambda d: ["paint", str(_session(d)), "-o", str(d / "p.png"), "--backend",
                        "numpy"],
    "demo": lambda d: ["demo", "-o", str(d / "d.png"), "--size", "24x16", "--backend",
                       "numpy"],
    "replay": lambda d: ["replay", str(_trace(d)), "--speed", "max", "--jsonl",
                         str(d / "r.jsonl")],
    "bench sim": lambda d: ["bench", "sim", "--sizes", "24x16", "--seconds", "0.01",
                            "--backends", "numpy"],
    "bench parse": lambda d: ["bench", "parse", "--reports", "20", "--repeat", "1",
                              "--no-pin"],
    "bench bus": lambda d: ["bench", "bus", "--transports", "ipc", "--samples-1khz", "20",
                            "--samples-flat", "200"],
}
BAR = {"paint": "painting:", "demo": "painting:", "replay": "replay:",
       "bench sim": "bench sim:", "bench parse": "bench parse:", "bench bus": "bench bus:"}


def _short_demo(tmp_path: Path) -> Path:
    """The bundled demo's first 6 s (its bar, not its 5905 steps twice, is what is tested
    here; test_sim_paint paints the whole demo)."""
    lines = DEMO_FILE.read_text(encoding="utf-8").splitlines(keepends=True)
    keep = [lines[0]] + [ln for ln in lines[1:] if json.loads(ln)["t"] <= 6.0]
    path = tmp_path / "demo-start.jsonl"
    path.write_text("".join(keep), encoding="utf-8")
    return path


@pytest.mark.parametrize("name", list(COMMANDS))
def test_commands_show_a_bar_on_a_terminal_and_stay_quiet_otherwise(
        name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    short = _short_demo(tmp_path) if name == "demo" else None
    if short:
        monkeypatch.setattr(cmd_demo, "DEMO_FILE", short)
    tty = FakeTTY()
    monkeypatch.setattr(sys, "stderr", tty)
    assert main(COMMANDS[name](tmp_path)) == 0
    monkeypatch.undo()
    if short:
        monkeypatch.setattr(cmd_demo, "DEMO_FILE", short)
    drawn = tty.getvalue()
    assert f"\r{BAR[name]}" in drawn and "100%" in drawn, drawn[-500:]
    capsys.readouterr()

    assert main(COMMANDS[name](tmp_path)) == 0  # stderr is captured: not a terminal
    captured = capsys.readouterr()
    assert "\r" not in captured.err and "%|" not in captured.err
    # a slow run (a loaded machine) may say it is alive, a plain line every few seconds
    err = "".join(ln for ln in captured.err.splitlines(keepends=True)
                  if not re.match(r"^[a-z ]+: (\d+% \(|[\d.]+ )\S.*s so far$", ln.rstrip()))
    captured = type(captured)(captured.out, err)
    if name.startswith("bench"):
        assert captured.err == ""  # completely quiet; the figures are in the JSON
        json.loads(captured.out)
    elif name == "demo":
        assert captured.err.startswith("station demo:") and captured.err.count("\n") == 1
    elif name == "paint":
        assert captured.err == ""


def test_without_a_terminal_a_line_every_few_seconds(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """`station demo 2>log` used to print nothing for minutes (issue 24.6)."""
    import station.progress as progress

    pipe = io.StringIO()
    with Progress(40, "work", unit="step", stream=pipe) as bar:
        bar.update(10)
    assert pipe.getvalue() == ""  # under LINE_EVERY_S: silent
    monkeypatch.setattr(progress, "LINE_EVERY_S", 0.0)
    with Progress(40, "work", unit="step", stream=pipe) as bar:
        bar.update(10)
        bar.set(30)
    lines = pipe.getvalue().splitlines()
    assert lines[0].startswith("work: 25% (10/40 step), ") and lines[0].endswith("s so far")
    assert lines[1].startswith("work: 75% (30/40 step)")
    assert main(COMMANDS["paint"](tmp_path)) == 0
    err = capsys.readouterr().err
    assert "\r" not in err and "painting: " in err and "% (" in err
