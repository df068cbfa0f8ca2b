"""systemd units generated from the bundled blueprints: the options asked for are there,
and ``systemd-analyze verify`` accepts them without a warning (skipped without systemd)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from station.blueprint.load import bundled_names, load
from station.blueprint.systemd import units, write_units

SANDBOX = ("NoNewPrivileges=yes", "ProtectSystem=strict", "PrivateTmp=yes", "ProtectHome=yes",
           "DevicePolicy=closed", "Group=station", "SupplementaryGroups=station")


def test_supervisor_unit_options() -> None:
    text = units(load("kiosk"))["station-kiosk.service"]
    assert "SupplementaryGroups=station video render" in text  # the kiosk's GPU
    for line in (*SANDBOX[:-1], "User=station", "RuntimeDirectory=station-kiosk",
                 "RuntimeDirectoryMode=0700", "Restart=on-failure", "KillMode=mixed",
                 "RestartPreventExitStatus=2", "DeviceAllow=char-hidraw rw",
                 "DeviceAllow=char-drm rw", "WantedBy=graphical.target"):
        assert line in text.splitlines(), line
    assert " run /etc/station/kiosk.xml --run-dir %t/station-kiosk " in text
    demo = units(load("headless-demo"), user="painter")["station-headless-demo.service"]
    assert "User=painter" in demo and "DeviceAllow" not in demo  # a mock opens no device
    assert "WantedBy=multi-user.target" in demo


def test_per_component_units(tmp_path: Path) -> None:
    made = units(load("two-tablets"), per_component=True, overrides=["sim.width=100"])
    assert sorted(made) == ["station-two-tablets-hub.service", "station-two-tablets-left.service",
                            "station-two-tablets-right.service",
                            "station-two-tablets-sim.service", "station-two-tablets.target"]
    left = made["station-two-tablets-left.service"]
    # A source starts after everything that listens to it (the start order of station run).
    assert ("After=station-two-tablets-hub.service station-two-tablets-sim.service"
            in left.splitlines())
    assert "--set sim.width=100 --component left" in left
    assert "RuntimeDirectoryPreserve=yes" in left
    for line in SANDBOX:
        assert line in left.splitlines()
    target = made["station-two-tablets.target"]
    assert "Wants=station-two-tablets-hub.service" in target


def test_device_allow_lists_the_devices() -> None:
    bp = load("record-only", ["pen.device=evdev:/dev/input/event7"])
    text = units(bp)["station-record-only.service"]
    assert "DeviceAllow=/dev/input/event7 rw" in text.splitlines()
    assert sum(ln.startswith("DeviceAllow=") for ln in text.splitlines()) == 1


@pytest.mark.skipif(shutil.which("systemd-analyze") is None,
                    reason="systemd-analyze is not installed here")
@pytest.mark.parametrize("per_component", [False, True])
def test_units_pass_systemd_analyze_verify(tmp_path: Path, per_component: bool) -> None:
    station = shutil.which("station") or str(Path(__file__).parents[1] / ".venv/bin/station")
    if not Path(station).exists():
        pytest.skip("no station executable to name in ExecStart=")
    for name in bundled_names():
        out = tmp_path / name
        files = write_units(load(name), out, per_component=per_component, station=station)
        unit_files = [str(p) for p in files if p.suffix in (".service", ".target")]
        proc = subprocess.run(["systemd-analyze", "verify", "--man=no", *unit_files],
                              capture_output=True, text=True, timeout=60, cwd=out)
        mine = [ln for ln in (proc.stdout + proc.stderr).splitlines() if str(out) in ln
                or "station-" in ln]
        assert proc.returncode == 0 and not mine, (name, proc.stdout, proc.stderr)
