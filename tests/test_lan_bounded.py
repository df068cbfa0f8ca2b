"""Every file reader caps what it reads and refuses special files (issue 25 item 3):
``/dev/zero``, a FIFO with no writer and an oversized file each give exit 2 and one
line, at once, from every command that reads a file."""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from station import boundedio
from station.cli import main
from station.errors import BadInput

COMMANDS = [
    ["calibrate", "--check", "{f}"],
    ["calibrate", "--fit", "{f}"],
    ["replay", "{f}"],
    ["paint", "{f}", "-o", "{tmp}/x.png"],
    ["brush-sheet", "--shape", "{f}", "-o", "{tmp}/x.png"],
    ["driver", "--calibration", "{f}", "--device", "mock:intuos-pro-m"],
    ["driver", "--device", "trace:{f}"],
    ["blueprint", "check", "{f}"],
]


def _limit() -> None:  # on a reader that slurps /dev/zero: a MemoryError, not the machine
    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))


class Hang(Exception):
    pass


def _ring(*_: object) -> None:
    raise Hang


def test_special_files_are_refused_by_every_command(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # /dev/zero in processes of their own, under a memory limit (two at once)
    runs = []
    for argv in (COMMANDS[2], COMMANDS[-1]):
        args = [a.format(f="/dev/zero", tmp=tmp_path) for a in argv]
        runs.append((args, subprocess.Popen(
            [sys.executable, "-m", "station", *args], stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE, text=True, preexec_fn=_limit)))
    # a FIFO nobody writes, in process: open() itself would block; an alarm ends a hang
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    old = signal.signal(signal.SIGALRM, _ring)
    try:
        for n, argv in enumerate(COMMANDS):
            args = [a.format(f=fifo, tmp=tmp_path) for a in argv]
            if args[0] == "driver":
                args += ["--bus", f"@ipc:bounded-{n}"]
            signal.alarm(20)
            try:
                code = main(args)
            except Hang:
                pytest.fail(f"station {' '.join(args)} hangs on a FIFO")
            finally:
                signal.alarm(0)
            lines = capsys.readouterr().err.strip().splitlines()
            assert code == 2 and len(lines) == 1, (args, lines)
            assert "a FIFO, not a regular file" in lines[0], (args, lines)
    finally:
        signal.signal(signal.SIGALRM, old)
    for args, proc in runs:
        try:
            _out, err = proc.communicate(timeout=90)
        except subprocess.TimeoutExpired:
            proc.kill()
            pytest.fail(f"station {' '.join(args)} hangs")
        lines = err.strip().splitlines()
        assert proc.returncode == 2 and len(lines) == 1, (args, err[-600:])
        assert "character device, not a regular file" in lines[0], (args, lines)


def test_caps_and_kinds(tmp_path: Path) -> None:
    big = tmp_path / "big.xml"
    big.write_bytes(b" " * (boundedio.CAP_CONFIG + 1))
    with pytest.raises(BadInput, match="more than the 4 MiB"):
        boundedio.read_bytes(big)
    small = tmp_path / "s.txt"
    small.write_text("héllo")
    assert boundedio.read_text(small, 100) == "héllo"
    with pytest.raises(BadInput, match="more than"):
        boundedio.read_bytes(small, 3)
    with pytest.raises(BadInput, match="directory"):
        boundedio.read_bytes(tmp_path)
    with pytest.raises(FileNotFoundError):
        boundedio.read_bytes(tmp_path / "missing")
