"""`station tablet-test` (issue 24.1): raw beside normalised, curve and threshold, save;
the same for evdev, hidraw and UC-Logic devices; the window under Xvfb."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from station.calibration.files import read_file
from station.drivers.mock.evdev import states_to_events, wacom_like_caps
from station.drivers.mock.script import timed_states
from station.drivers.traces.evemu import format_evemu
from xvfb_server import xvfb

from station.cli import main


def _run(capsys: pytest.CaptureFixture[str], spec: str, *extra: str) -> list[str]:
    assert main(["tablet-test", "--device", spec, "--terminal", *extra]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("# ")
    return out[1:]


def _pressures(lines: list[str]) -> list[tuple[str, float]]:
    return [(ln.split(" | ")[0].strip(), float(ln.split(" p=")[-1].split()[0]))
            for ln in lines if "touching" in ln]


def _evemu(tmp_path: Path) -> str:
    caps = wacom_like_caps()
    path = tmp_path / "pen.evemu"
    path.write_text(format_evemu(caps, states_to_events(
        caps, timed_states("line", rate=200, reports=30))))
    return f"mock-evdev:{path}?speed=max"


@pytest.mark.parametrize("kind", ["hidraw", "evdev", "uclogic"])
def test_raw_beside_normalised_for_every_kind_of_device(
        kind: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = {"hidraw": "mock:intuos-pro-m?script=line&reports=30&speed=max",
            "evdev": _evemu(tmp_path),
            "uclogic": "mock-uclogic:v2?script=line&reports=30&speed=max"}[kind]
    lines = _run(capsys, spec)
    touching = [ln for ln in lines if ln.endswith("touching")]
    assert len(touching) >= 20, lines[:5]
    raw, norm = touching[len(touching) // 2].split(" | ")
    assert raw.startswith("raw x=") and " p=" in raw and raw.rstrip().endswith("tip")
    x = float(norm.split("x=")[1].split()[0])
    assert 0.0 <= x <= 1.0 and "p=" in norm


def test_the_curve_and_threshold_change_the_normalised_pressure_and_are_saved(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    spec = "mock:intuos-pro-m?script=line&reports=30&speed=max"
    linear = dict(_pressures(_run(capsys, spec)))
    soft = dict(_pressures(_run(capsys, spec, "--pressure-curve", "0.5,0,1,0.5")))
    same = [raw for raw in linear if raw in soft]
    assert len(same) >= 10
    # a curve below the diagonal: the same raw report paints lighter
    assert all(soft[r] <= linear[r] + 1e-9 for r in same)
    assert sum(soft[r] < linear[r] - 0.05 for r in same) >= 5
    late = _pressures(_run(capsys, spec, "--tip-threshold", "0.5"))
    assert 0 < len(late) < len(linear)  # a higher tip threshold: fewer samples touch
    cal_dir = tmp_path / "config"
    monkeypatch.setenv("STATION_CONFIG_DIR", str(cal_dir))
    _run(capsys, spec, "--pressure-curve", "0.5,0,1,0.5", "--tip-threshold", "0.1", "--save")
    (path,) = list((cal_dir / "calibration").glob("*.json"))
    cal = read_file(path)
    assert (cal.device.vid, cal.device.pid) == (0x056A, 0x0315)
    assert cal.pressure.curve == (0.5, 0.0, 1.0, 0.5) and cal.pressure.threshold == 0.1
    assert np.allclose(cal.matrix, np.eye(3))  # a new file maps the whole tablet


@pytest.fixture
def display() -> Iterator[str]:
    with xvfb(1280, 800) as name:
        yield name


def test_the_window_draws_the_trail_the_fields_and_the_curve(display: str,
                                                            tmp_path: Path) -> None:
    pytest.importorskip("imgui_bundle")
    from PIL import Image

    shot = tmp_path / "tt.png"
    proc = subprocess.run(
        [sys.executable, "-m", "station", "tablet-test", "--device",
         "mock:intuos-pro-m?script=line&reports=40&speed=4", "--screenshot", str(shot),
         "--linger", "0.2", "--tip-threshold", "0.1"], env={**os.environ, "DISPLAY": display},
        capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    img = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    pen = img[:, :700]
    magenta = (np.abs(pen - (230, 60, 200)).sum(axis=2) < 40)
    assert magenta.sum() > 2000  # the stroke, with width
    cols = np.nonzero(magenta.any(axis=0))[0]
    assert cols.max() - cols.min() > 300  # the line crosses most of the tablet
    panel = img[:, 762:]
    assert (np.abs(panel - (60, 220, 90)).sum(axis=2) < 40).sum() > 20  # the live point
    assert (np.abs(panel - (240, 190, 40)).sum(axis=2) < 80).sum() > 50  # the threshold
