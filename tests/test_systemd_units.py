"""systemd units on a public LAN (issue 25 item 2, issue 24 item 9): every string
escaped or refused, the sandbox widened only under the station's data
directories, Type=notify with a watchdog the station's processes feed, and
``systemd-analyze security`` at most 4.0 for every generated unit."""

from __future__ import annotations

import os
import re
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from station.blueprint.load import bundled_names, load
from station.blueprint.model import BlueprintError
from station.blueprint.systemd import exec_word, units, write_units
from station.cli import main
from station.sdnotify import Notifier

SMALL = ["--set", "sim.backend=numpy", "--set", "sim.width=64", "--set", "sim.height=48",
         "--set", "sim.rate=40"]


def blueprint(tmp_path: Path, body: str, name: str = "bp.xml") -> Path:
    path = tmp_path / name
    path.write_text(f'<station name="lan" version="1">\n{body}\n</station>\n')
    return path


def keys(text: str, key: str) -> list[str]:
    return [ln.split("=", 1)[1] for ln in text.splitlines() if ln.startswith(key + "=")]


def test_a_file_name_with_newlines_adds_no_line_to_the_unit(tmp_path: Path) -> None:
    evil = "x.xml\n[Service]\nExecStartPre=+/bin/sh -c 'id > /tmp/pwned'\n#"
    path = blueprint(tmp_path, '<driver id="pen" device="mock:intuos-pro-m?script=line"/>\n'
                     '<recorder id="rec" output="rec.jsonl"><requires interface="pen" '
                     'from="pen"/></recorder>', name="ok.xml")
    bp = load(str(path))
    bp.file = str(tmp_path / evil)
    with pytest.raises(BlueprintError, match="control character"):
        units(bp)
    bp.file = str(path)
    for bad in ("a\nb", "x\r"):
        with pytest.raises(BlueprintError):
            units(bp, overrides=[f"pen.device={bad}"])
        with pytest.raises(BlueprintError):
            units(bp, install_path=f"/etc/station/{bad}.xml")
    for bad_user in ("root\nExecStartPre=+/bin/sh", "a b", "../x"):
        with pytest.raises(BlueprintError):
            units(bp, user=bad_user)
    # odd but legal words are quoted the way systemd reads them
    assert exec_word("a b") == '"a b"'
    assert exec_word("it's $HOME 100%") == '"it\'s $$HOME 100%%"'
    assert exec_word('q"\\') == '"q\\"\\\\"'
    text = units(bp, overrides=["sim.width=100 200"])["station-lan.service"]
    assert '--set "sim.width=100 200"' in text
    # CLI: bad input, exit 2 and one line
    made = tmp_path / "units"
    assert main(["blueprint", "systemd", str(path), "-o", str(made), "--user",
                 "root\nx"]) == 2


def test_outputs_widen_the_sandbox_only_under_the_station_data_dirs(tmp_path: Path) -> None:
    def rec(output: str) -> Path:
        return blueprint(tmp_path, '<driver id="pen" device="mock:intuos-pro-m?script=line"/>'
                         f'\n<recorder id="rec" output="{output}"><requires interface="pen" '
                         'from="pen"/></recorder>')

    for bad in ("/etc/cron.d/station", "../../../etc/cron.d/x", "/var/lib/station-lan/../../x",
                "/var/lib/station-lan2/../../../etc/x", "/srv/../etc/x", "/var/lib/other/x"):
        with pytest.raises(BlueprintError, match="outside the station's data"):
            units(load(str(rec(bad))))
    ok = units(load(str(rec("/srv/station/recordings/rec.jsonl"))))["station-lan.service"]
    assert keys(ok, "ReadWritePaths") == ["/srv/station/recordings"]
    inside = units(load(str(rec("logs/rec.jsonl"))))["station-lan.service"]
    assert keys(inside, "ReadWritePaths") == []


def test_units_are_notify_with_a_watchdog_and_a_display() -> None:
    for name in bundled_names():
        for per in (False, True):
            for fname, text in units(load(name), per_component=per).items():
                if not fname.endswith(".service"):
                    continue
                lines = text.splitlines()
                for line in ("Type=notify", "NotifyAccess=main", "WatchdogSec=30s",
                             "CapabilityBoundingSet=", "SystemCallArchitectures=native",
                             "UMask=0077"):
                    assert line in lines, (fname, line)
                assert any(ln.startswith("SystemCallFilter=@system-service") for ln in lines)
    kiosk = units(load("kiosk"))["station-kiosk.service"]
    assert "Environment=XAUTHORITY=%S/station-kiosk/.Xauthority" in kiosk
    assert "cage" in kiosk and "BindReadOnlyPaths=-/tmp/.X11-unix" in kiosk


@pytest.mark.skipif(shutil.which("systemd-analyze") is None,
                    reason="systemd-analyze is not installed here")
def test_systemd_analyze_security_rates_every_unit_at_most_4(tmp_path: Path) -> None:
    files = []
    for name in bundled_names():
        for per in (False, True):
            out = tmp_path / f"{name}-{per}"
            files += [p for p in write_units(load(name), out, per_component=per,
                                             station="/usr/bin/station")
                      if p.suffix == ".service"]
    proc = subprocess.run(["systemd-analyze", "security", "--offline=true", "--threshold=40",
                           *map(str, files)], capture_output=True, text=True, timeout=120)
    scores = [float(m) for m in re.findall(r"Overall exposure level for \S+: ([0-9.]+)",
                                           proc.stdout + proc.stderr)]
    assert len(scores) == len(files) and max(scores) <= 4.0, (scores, proc.stdout[-3000:])
    assert proc.returncode == 0


def listen(tmp_path: Path) -> tuple[socket.socket, str]:
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    path = str(tmp_path / "notify")
    sock.bind(path)
    sock.settimeout(0.2)
    return sock, path


def drain(sock: socket.socket, until: float, want: str, got: list[str]) -> bool:
    while time.monotonic() < until:
        try:
            got.append(sock.recv(4096).decode())
        except TimeoutError:
            pass
        if any(want in g for g in got):
            return True
    return False


def test_notifier_speaks_the_protocol(tmp_path: Path) -> None:
    sock, path = listen(tmp_path)
    n = Notifier({"NOTIFY_SOCKET": path, "WATCHDOG_USEC": "400000"})
    n.alive()
    n.alive()  # within a quarter period: no second ping
    got: list[str] = []
    assert drain(sock, time.monotonic() + 2, "WATCHDOG=1", got)
    assert got[0] == "READY=1" and got.count("WATCHDOG=1") == 1
    time.sleep(0.12)
    n.alive()
    assert drain(sock, time.monotonic() + 2, "WATCHDOG", got) and got.count("WATCHDOG=1") == 2
    other = Notifier({"NOTIFY_SOCKET": path, "WATCHDOG_USEC": "400000", "WATCHDOG_PID": "1"})
    assert other.watchdog_s is None  # another process's watchdog
    assert not Notifier({}).enabled and not Notifier({"NOTIFY_SOCKET": "rel"}).enabled
    Notifier({}).alive()  # no systemd: nothing, no error


def test_supervisor_and_bus_notify_ready_and_feed_the_watchdog(tmp_path: Path) -> None:
    sock, path = listen(tmp_path)
    env = {**os.environ, "NOTIFY_SOCKET": path, "WATCHDOG_USEC": "300000"}
    sup = subprocess.Popen(
        [sys.executable, "-m", "station", "run", "headless-demo", "--once", "--run-dir",
         str(tmp_path / "r"), *SMALL, "--set", "pen.device=mock:intuos-pro-m?script=line"],
        cwd=tmp_path, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    got: list[str] = []
    try:
        assert drain(sock, time.monotonic() + 120, "STOPPING=1", got), got
    finally:
        _out, err = sup.communicate(timeout=60)
    assert sup.returncode == 0, err[-2000:]
    # one READY (the supervisor's, once all is up: its children do not speak for it)
    assert [g.split("\n")[0] for g in got].count("READY=1") == 1, got
    assert "components up" in next(g for g in got if g.startswith("READY=1"))
    assert "WATCHDOG=1" in got and got[-1] == "STOPPING=1"
    # a component run on its own (per-component units exec it) notifies by running
    bus = subprocess.Popen(
        [sys.executable, "-m", "station", "bus", "--pub", f"ipc://{tmp_path}/p",
         "--sub", f"ipc://{tmp_path}/s"], env={**env, "STATION_RUNTIME_DIR": str(tmp_path)},
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        got = []
        assert drain(sock, time.monotonic() + 60, "READY=1", got), got
        end = time.monotonic() + 5
        while got.count("WATCHDOG=1") < 3 and time.monotonic() < end:
            drain(sock, time.monotonic() + 0.3, "never", got)
        assert got.count("WATCHDOG=1") >= 3, got
    finally:
        bus.terminate()
        bus.wait(10)
