"""CLI exit codes (interfaces.md): 0 success, 1 failure, 2 bad input with one line."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import station
from station.cli import _command_modules, _modules_for, build_parser

HEADER = ('{"format": "station-session", "version": 1, "canvas": {"width": 64, "height": 48},'
          ' "profile": "watercolor", "seed": 7}')
PEN = ('{{"type": "pen", "t": {t}, "device": "mock-0", "tool": "pen", "serial": null, '
       '"x": 0.41, "y": 0.52, "pressure": {p}, "tilt_x": 12.0, "tilt_y": -4.5, '
       '"proximity": true, "touching": {touch}, "buttons": 0}}')


def station_cmd(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "station", *args], capture_output=True,
                          text=True, timeout=120, env=dict(os.environ))


def make_log(tmp_path: Path, *extra: str) -> Path:
    lines = [HEADER, PEN.format(t=0.0, p=0.0, touch="false"),
             '{"type": "cmd", "t": 0.05, "cmd": "brush", "args": {"size": 8}}',
             PEN.format(t=0.1, p=0.5, touch="true"), PEN.format(t=0.2, p=0.5, touch="true"),
             PEN.format(t=0.3, p=0.0, touch="false"), *extra]
    path = tmp_path / "s.jsonl"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_version() -> None:
    r = station_cmd("--version")
    assert r.returncode == 0 and r.stdout.strip() == f"station {station.__version__}"


def test_log_stats_and_cat(tmp_path: Path) -> None:
    path = make_log(tmp_path)
    r = station_cmd("log", "stats", str(path))
    assert r.returncode == 0, r.stderr
    stats = json.loads(r.stdout)
    assert stats["pen_samples"] == 4 and stats["strokes"] == 1
    assert stats["commands"] == {"brush": 1} and stats["duration_s"] == pytest.approx(0.3)
    r = station_cmd("log", "cat", str(path))
    assert r.returncode == 0 and r.stdout.count(" pen  mock-0") == 4 and "cmd  brush" in r.stdout
    r = station_cmd("log", "cat", "--json", str(path))
    assert [json.loads(x)["t"] for x in r.stdout.splitlines()[1:]] == [0.0, 0.05, 0.1, 0.2, 0.3]


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["log", "stats", "{log_bad}"], "s.jsonl:7: not valid JSON"),
        (["log", "cat", "/nonexistent/file.jsonl"], "cannot open"),
        (["log", "frobnicate"], "invalid choice"),
        (["--no-such-flag"], "unrecognized arguments"),
        (["bench", "bus", "--transports", "carrier-pigeon"], "unknown transport"),
        (["bus", "--pub", "udp://nowhere"], "unknown endpoint"),
        ([], ""),
    ],
)
def test_bad_input_exits_2_with_one_line(tmp_path: Path, args: list[str], needle: str) -> None:
    bad = make_log(tmp_path, "{broken")
    r = station_cmd(*[a.format(log_bad=bad) for a in args])
    assert r.returncode == 2, r.stderr
    if needle:
        assert needle in r.stderr
        assert len(r.stderr.strip().splitlines()) == 1, r.stderr
        assert "Traceback" not in r.stderr


def test_keys_twice_is_bad_input_and_force_works(tmp_path: Path) -> None:
    d = tmp_path / "k"
    assert station_cmd("keys", "--dir", str(d), "--json").returncode == 0
    assert (d / "server.key_secret").stat().st_mode & 0o077 == 0
    r = station_cmd("keys", "--dir", str(d))
    assert r.returncode == 2 and "--force" in r.stderr
    assert station_cmd("keys", "--dir", str(d), "--force").returncode == 0


def test_environment_failure_exits_1(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    r = station_cmd("bus", "--pub", f"ipc://{blocker}/sock", "--sub", "ipc:s")
    assert r.returncode == 1, r.stderr
    assert "error:" in r.stderr and "Traceback" not in r.stderr


def test_help_lists_only_working_commands() -> None:
    r = station_cmd("--help")
    assert r.returncode == 0
    for name in ("bus", "keys", "log", "bench"):
        assert name in r.stdout


def test_a_command_line_imports_only_its_own_command() -> None:
    """``station driver …`` builds only the driver's parser (its start skips the
    simulation's imports); every command's name leads to the module that registers it,
    so no command is missed that way; help and unknown words build every command."""
    everything = _command_modules()
    assert len(everything) > 15
    assert _modules_for(["driver", "--device", "mock:intuos-pro-m"]) == ["cmd_driver"]
    assert _modules_for(["-v", "-q", "brush-sheet"]) == ["cmd_brush_sheet"]
    assert _modules_for(["--help"]) == everything == _modules_for([])
    assert _modules_for(["no-such-command"]) == everything
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    for name in sub.choices:
        assert _modules_for([name]) == ["cmd_" + name.replace("-", "_")], name
        alone = next(a for a in build_parser([name])._actions
                     if isinstance(a, argparse._SubParsersAction))
        assert list(alone.choices) == [name]
    # the driver's process no longer imports the simulation
    probe = subprocess.run(
        [sys.executable, "-c", "import sys\nfrom station.cli import build_parser\n"
         "build_parser(['driver'])\nprint('station.sim.player' in sys.modules)"],
        capture_output=True, text=True, timeout=60)
    assert probe.stdout.strip() == "False", probe.stderr
