"""Hostile input gets exit 2 and one line — never a hang or a traceback (issue 8, item 5).

Each case of the issue, through the CLI in process (``station.cli.main``); the
fuzzing over every reader is tests/test_hostile_fuzz.py.
"""

from __future__ import annotations

import json
import logging
import warnings
from pathlib import Path

import pytest
from station.drivers import synth

from station.bench.fuzz import alarm
from station.cli import main

HEADER = json.dumps({"format": "station-session", "version": 1,
                     "canvas": {"width": 32, "height": 24}})


def pen(t: float, **kw: object) -> str:
    rec = {"type": "pen", "t": t, "device": "m", "tool": "pen", "x": 0.5, "y": 0.5,
           "pressure": 0.5, "proximity": True, "touching": True, **kw}
    return json.dumps(rec)


OUT: list[str] = []  # stdout of the last run


def run(capsys: pytest.CaptureFixture[str], *argv: str, seconds: float = 30.0
        ) -> tuple[int, str]:
    """Exit code and stderr of ``station ARGV`` (stdout in ``OUT[-1]``)."""
    with alarm(seconds):  # the fuzzer's: a hang raises its Hang, failing the test
        try:
            rc = main(list(argv))
        except SystemExit as exc:  # argparse usage errors
            rc = int(exc.code or 0)
    captured = capsys.readouterr()
    OUT.append(captured.out)
    return rc, captured.err


def one_bad_line(rc: int, err: str, *needles: str) -> str:
    assert rc == 2, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


PAINT = ("--backend", "numpy", "--size", "16x16")
# docs/painting.md: a replayed session may reach one day (86,400 s) of painting time


@pytest.mark.parametrize("where", ["header", "record"])
def test_json_nested_50000_deep(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                where: str) -> None:
    deep = "[" * 50_000 + "]" * 50_000
    path = tmp_path / "deep.jsonl"
    path.write_text(deep + "\n" if where == "header" else f"{HEADER}\n{pen(0.0)}\n{deep}\n")
    line = "1" if where == "header" else "3"
    for argv in (["paint", str(path), "-o", str(tmp_path / "o.png"), *PAINT],
                 ["log", "cat", str(path)], ["log", "stats", str(path)]):
        rc, err = run(capsys, *argv)
        one_bad_line(rc, err, f"deep.jsonl:{line}", "nested too deeply")


@pytest.mark.parametrize("record", [pen(1e12), pen(86_400 + 1),
                                    json.dumps({"type": "cmd", "t": 0.0, "cmd": "wait",
                                                "args": {"seconds": 1e12}})])
def test_times_past_the_documented_limit_are_refused_not_run(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], record: str) -> None:
    path = tmp_path / "far.jsonl"
    path.write_text(f"{HEADER}\n{pen(0.0)}\n{record}\n")
    rc, err = run(capsys, "paint", str(path), "-o", str(tmp_path / "o.png"), *PAINT,
                  seconds=20.0)
    one_bad_line(rc, err, "far.jsonl:3")


@pytest.mark.parametrize(("flag", "value"), [("--settle", "1e12"), ("--settle", "-1"),
                                             ("--settle", "nan"), ("--rate", "1e12")])
def test_settle_and_rate_past_the_limits(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                         flag: str, value: str) -> None:
    path = tmp_path / "s.jsonl"
    path.write_text(f"{HEADER}\n{pen(0.0)}\n")
    rc, err = run(capsys, "paint", str(path), "-o", str(tmp_path / "o.png"), *PAINT, flag,
                  value, seconds=20.0)
    one_bad_line(rc, err, flag)
    assert not (tmp_path / "o.png").exists()  # refused before painting anything


@pytest.mark.parametrize("argv", [
    ["sim", "--duration", "-1", "--backend", "numpy", "--status", "none"],
    ["sim", "--duration", "nan", "--backend", "numpy", "--status", "none"],
    ["record", "--device", "mock:wacom-graphire-usb", "-o", "{tmp}/r.hid", "--duration", "-1"],
])
def test_negative_durations(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                            argv: list[str]) -> None:
    rc, err = run(capsys, *[a.format(tmp=tmp_path) for a in argv], seconds=20.0)
    one_bad_line(rc, err, "--duration")


def test_record_to_a_directory_that_does_not_exist(capsys: pytest.CaptureFixture[str]) -> None:
    rc, err = run(capsys, "record", "--device", "mock:wacom-graphire-usb", "-o",
                  "/nonexistent/x", "--duration", "0.2")
    one_bad_line(rc, err, "-o", "/nonexistent/x")


def touch_only_trace(path: Path) -> None:
    dev = synth.RecordedDevice("Synthetic Touch", 0x1234, 0x5678, synth.touch_descriptor(),
                               [(0.01 * i, r) for i, r in
                                enumerate(synth.stroke_reports("touch", 5))])
    synth.write_hid_recorder([dev], path)


def test_paint_on_a_trace_without_a_pen_or_without_events(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    touch = tmp_path / "touch.hid"
    touch_only_trace(touch)
    rc, err = run(capsys, "paint", str(touch), "-o", str(tmp_path / "a.png"), *PAINT)
    one_bad_line(rc, err, "no pen device")
    empty = tmp_path / "empty.hid"
    synth.write_hid_recorder([synth.RecordedDevice(
        "Wacom Graphire", 0x056A, 0x0081, synth.wacom_protocol_descriptor(7), [])], empty)
    rc, err = run(capsys, "paint", str(empty), "-o", str(tmp_path / "b.png"), *PAINT)
    one_bad_line(rc, err, "no pen samples")
    assert not (tmp_path / "a.png").exists() and not (tmp_path / "b.png").exists()


@pytest.mark.parametrize("value", ["1e308", "-1e308", "inf", "nan", "1e400", "9" * 400])
def test_extreme_numbers_in_a_points_csv(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                         value: str) -> None:
    path = tmp_path / "p.csv"
    path.write_text("device_x,device_y,canvas_x,canvas_y\n0.1,0.1,0.1,0.1\n0.9,0.1,0.9,0.1\n"
                    f"{value},0.9,0.9,0.9\n0.1,0.9,0.1,0.9\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # today: a numpy overflow warning, then a wrong message
        rc, err = run(capsys, "calibrate", "--fit", str(path), "--json")
    line = one_bad_line(rc, err, "p.csv:4", "device_x")
    assert "duplicate" not in line and "collinear" not in line


def test_a_session_log_cut_mid_line_plays_up_to_the_cut(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog) -> None:
    path = tmp_path / "cut.jsonl"
    path.write_text(f"{HEADER}\n{pen(0.0)}\n{pen(0.1)}\n" + pen(0.2)[:40])  # killed mid-write
    with caplog.at_level(logging.WARNING):
        rc, err = run(capsys, "log", "cat", "--json", str(path))
    assert rc == 0, err
    assert [json.loads(ln).get("t") for ln in OUT[-1].splitlines()] == [None, 0.0, 0.1]
    assert any("cut.jsonl:4" in r.getMessage() and "cut off" in r.getMessage()
               for r in caplog.records)
    rc, err = run(capsys, "paint", str(path), "-o", str(tmp_path / "o.png"), *PAINT, "--json")
    assert rc == 0, err
    # the same damage with the line ended (not a cut: a malformed line) stays exit 2
    path.write_text(f"{HEADER}\n{pen(0.0)}\n" + pen(0.1)[:40] + f"\n{pen(0.2)}\n")
    rc, err = run(capsys, "log", "stats", str(path))
    one_bad_line(rc, err, "cut.jsonl:3", "not valid JSON")


@pytest.mark.parametrize("fmt", ["hid", "evemu"])
def test_a_recording_cut_mid_line_plays_up_to_the_cut(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog, fmt: str) -> None:
    if fmt == "hid":
        reports = [(0.01 * i, synth.graphire_report(2000 + 100 * i, 3000, 200, tip=True))
                   for i in range(10)]
        text = synth.write_hid_recorder([synth.RecordedDevice(
            "Wacom Graphire", 0x056A, 0x0081, synth.wacom_protocol_descriptor(7), reports)])
    else:
        from station.drivers.mock.evdev import states_to_events, wacom_like_caps
        from station.drivers.mock.script import timed_states
        from station.drivers.traces.evemu import format_evemu

        caps = wacom_like_caps()
        text = format_evemu(caps, states_to_events(caps, timed_states("line", reports=10)))
    whole = len(text.splitlines())
    path = tmp_path / f"cut.{fmt}"
    path.write_text(text.rstrip("\n")[:-4])  # the recorder killed inside the last line
    out = tmp_path / "out.jsonl"
    with caplog.at_level(logging.WARNING):
        rc, err = run(capsys, "replay", str(path), "--jsonl", str(out))
    assert rc == 0, err
    assert any(f"cut.{fmt}:{whole}" in r.getMessage() and "cut off" in r.getMessage()
               for r in caplog.records), [r.getMessage() for r in caplog.records]
    assert out.read_text().count('"type": "pen"') > 5
    # a malformed line in the middle is still exit 2, naming it
    lines = text.splitlines(keepends=True)
    lines[-3] = lines[-3][:-6] + "\n"
    path.write_text("".join(lines))
    rc, err = run(capsys, "replay", str(path), "--jsonl", str(out))
    one_bad_line(rc, err, f"cut.{fmt}:{whole - 2}")
