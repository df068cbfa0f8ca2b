"""Packaging: the layout maps under ``station``; no generic top-level names are installed."""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_mapped_packages_import_by_station_names(tmp_path: Path) -> None:
    code = ("import station.drivers, station.calibration, station.shaders, station.udev;"
            "import importlib.util as u; print(u.find_spec('drivers'), u.find_spec('calibration'))")
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "None None"


@pytest.mark.timeout(180)
def test_wheel_contents(tmp_path: Path) -> None:
    r = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
         "-w", str(tmp_path), str(ROOT)],
        capture_output=True, text=True, timeout=170,
    )
    if r.returncode != 0:
        pytest.fail(r.stderr[-2000:])
    wheel = next(tmp_path.glob("*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names}
    assert tops <= {"station"} | {n.split("/")[0] for n in names if ".dist-info" in n}
    assert "station/drivers/raw.py" in names
    assert "station/cli/cmd_log.py" in names
    shaders = [n for n in names if n.startswith("station/shaders/") and not n.endswith(".py")]
    shader_files = [p for p in (ROOT / "shaders").iterdir()
                    if p.suffix in (".glsl", ".comp", ".vert", ".frag")]
    assert len(shaders) == len(shader_files)
    # every source package directory is in the wheel
    for init in ROOT.glob("**/__init__.py"):
        rel = init.relative_to(ROOT)
        if rel.parts[0] in (".venv", "tests", "build") or rel.parts[0].startswith("."):
            continue
        mapped = {"drivers": "station/drivers", "calibration": "station/calibration",
                  "shaders": "station/shaders", "udev": "station/udev"}.get(rel.parts[0])
        target = "/".join([mapped, *rel.parts[1:]]) if mapped else rel.as_posix()
        assert target in names, f"{rel} missing from the wheel as {target}"
