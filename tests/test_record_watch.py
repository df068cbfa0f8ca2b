"""Recordings you can watch (issue 24.3): record prints live, replay --decode, --uhid."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from station.cli import main

MOCK = "mock:intuos-pro-m?script=line&reports=6"


def test_record_prints_each_report_and_q_is_quiet(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["record", "--device", MOCK, "-o", str(tmp_path / "a.hid")]) == 0
    out, err = capsys.readouterr()
    written = int(err.split("station record: ")[-1].split()[0])
    lines = [ln for ln in out.splitlines() if not ln.startswith("#")]
    assert written > 10 and len(lines) == written  # one line per report written
    pen = [ln for ln in lines if "-> pen x=" in ln]
    assert pen and any(" tip" in ln for ln in pen) and "report 2:" in pen[0]
    assert main(["record", "--device", MOCK, "-o", str(tmp_path / "b.hid"), "-q"]) == 0
    assert capsys.readouterr().out == ""
    # what it printed live is what --decode prints from the file
    assert main(["replay", str(tmp_path / "a.hid"), "--decode"]) == 0
    decoded = [ln for ln in capsys.readouterr().out.splitlines() if not ln.startswith("#")]
    assert decoded == lines


def test_record_output_arrives_while_it_records(tmp_path: Path) -> None:
    """Into a pipe, not at the end: a line per report, flushed (hid-recorder does so)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "station", "record", "--device",
         "mock:intuos-pro-m?script=line&reports=2000&speed=1", "-o", str(tmp_path / "c.hid")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        first = proc.stdout.readline()
        assert first.startswith("# Wacom Intuos Pro M")
        deadline = time.monotonic() + 60
        seen = 0
        while seen < 20 and time.monotonic() < deadline:
            if "->" in proc.stdout.readline():
                seen += 1
        assert seen == 20 and proc.poll() is None  # still recording
    finally:
        proc.terminate()
        proc.communicate(timeout=60)


def test_replay_uhid_says_why_not_here_and_drives_hid_tools_where_it_can(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """No /dev/uhid in this container: exit 1 with one line.  With a stand-in for
    /dev/uhid and hid-tools' UHIDDevice, the calls a kernel would see are checked."""
    import hidtools.uhid

    from station.cli import cmd_replay

    trace = tmp_path / "t.hid"
    assert main(["record", "--device", MOCK, "-o", str(trace), "-q"]) == 0
    capsys.readouterr()
    monkeypatch.setattr(cmd_replay, "UHID", str(tmp_path / "no-uhid"))
    assert main(["replay", str(trace), "--uhid"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no " + str(tmp_path / "no-uhid") in err[0]

    calls: list[Any] = []

    class FakeUHID:
        def __init__(self) -> None:
            calls.append("new")

        def create_kernel_device(self) -> None:
            calls.append(("create", self.name, self.info, bytes(self.rdesc)[:2]))

        def dispatch(self, timeout: int) -> None:
            calls.append("dispatch")

        def call_input_event(self, data: list[int]) -> None:
            calls.append(bytes(data))

        def destroy(self) -> None:
            calls.append("destroy")

    (tmp_path / "uhid").write_bytes(b"")
    monkeypatch.setattr(cmd_replay, "UHID", str(tmp_path / "uhid"))
    monkeypatch.setattr(hidtools.uhid, "UHIDDevice", FakeUHID)
    assert main(["replay", str(trace), "--uhid", "--speed", "max"]) == 0
    from station.drivers.traces import read_trace

    (dev,) = read_trace(trace).devices
    assert calls[:2] == ["new", ("create", dev.name, (3, 0x056A, 0x0315), dev.descriptor[:2])]
    assert [c for c in calls if isinstance(c, bytes)] == [r.data for r in dev.reports]
    assert calls[-1] == "destroy"
