"""Drivers apply the device's calibration when publishing; raw samples stay available."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from station.calibration.area import AreaSettings
from station.calibration.files import default_path, write_file
from station.calibration.model import Calibration, DeviceId
from station.calibration.pressure import PressureSettings
from station.drivers.calibrated import choose_calibration

from station.events import PenSample
from station.sessionlog import read_session

INTUOS_PRO_M = (0x056A, 0x0315)


def run_driver(tmp_path: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    args = [sys.executable, "-m", "station", "driver", "--device",
            "mock:intuos-pro-m?script=line&rate=400", "--bus", f"ipc://{tmp_path}/bus",
            "--no-reconnect", "--jsonl", str(tmp_path / "out.jsonl"),
            "--raw-jsonl", str(tmp_path / "raw.jsonl"), *extra]
    return subprocess.run(args, capture_output=True, text=True, timeout=120,
                          env=dict(os.environ))


def pens(path: Path) -> list[PenSample]:
    return [r for r in read_session(path)[1] if isinstance(r, PenSample)]


def test_auto_applies_the_devices_file_and_keeps_raw_samples(tmp_path: Path) -> None:
    cal = Calibration(DeviceId(*INTUOS_PRO_M), area=AreaSettings(left_handed=True))
    write_file(cal, default_path(cal.device))  # the config dir of this test (conftest)
    r = run_driver(tmp_path)
    assert r.returncode == 0, r.stderr
    out, raw = pens(tmp_path / "out.jsonl"), pens(tmp_path / "raw.jsonl")
    assert len(out) == len(raw) > 20
    for o, w in zip(out, raw, strict=True):
        # left-handed = the tablet turned by 180 degrees: both axes flip
        assert o.x == pytest.approx(1 - w.x, abs=1e-9)
        assert o.y == pytest.approx(1 - w.y, abs=1e-9)
        assert o.pressure == w.pressure and o.touching == w.touching


def test_none_publishes_device_normalised(tmp_path: Path) -> None:
    cal = Calibration(DeviceId(*INTUOS_PRO_M), area=AreaSettings(left_handed=True))
    write_file(cal, default_path(cal.device))
    r = run_driver(tmp_path, "--calibration", "none", "--mapping", "stretch")
    assert r.returncode == 0, r.stderr
    out, raw = pens(tmp_path / "out.jsonl"), pens(tmp_path / "raw.jsonl")
    assert [(s.x, s.y) for s in out] == [(s.x, s.y) for s in raw]


def test_none_fits_the_tablet_to_the_canvas_keeping_its_aspect(tmp_path: Path) -> None:
    # Intuos Pro M: 44704 x 27940 units at the same resolution, 1.6:1, onto 4:3 (800x600):
    # x spans the canvas, y a centred band 4/3 / 1.6 of its height
    r = run_driver(tmp_path, "--calibration", "none")
    assert r.returncode == 0, r.stderr
    out, raw = pens(tmp_path / "out.jsonl"), pens(tmp_path / "raw.jsonl")
    assert len(out) == len(raw) > 20
    band = (4 / 3) / (44704 / 27940)
    for o, w in zip(out, raw, strict=True):
        assert o.x == pytest.approx(w.x, abs=1e-12)
        assert o.y - 0.5 == pytest.approx((w.y - 0.5) * band, abs=1e-12)


def test_explicit_file_of_another_device_is_refused_exit_2(tmp_path: Path) -> None:
    other = Calibration(DeviceId(0x056A, 0x00B8))
    path = write_file(other, tmp_path / "other.json")
    r = run_driver(tmp_path, "--calibration", str(path))
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr


def test_auto_with_a_corrupt_file_runs_uncalibrated_and_says_why(tmp_path: Path) -> None:
    path = default_path(DeviceId(*INTUOS_PRO_M))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("{ this is not a calibration")
    choice = choose_calibration("auto", *INTUOS_PRO_M)
    assert choice.store is None and choice.description.startswith("refused:")
    r = run_driver(tmp_path)
    assert r.returncode == 0, r.stderr
    assert "calibration refused" in r.stderr
    out, raw = pens(tmp_path / "out.jsonl"), pens(tmp_path / "raw.jsonl")
    band = (4 / 3) / (44704 / 27940)  # uncalibrated: the tablet fitted to the canvas
    assert [v for s in out for v in (s.x, 0.5 + (s.y - 0.5) / band)] == pytest.approx(
        [v for s in raw for v in (s.x, s.y)], abs=1e-12)


FILE_CURVE = (0.0, 0.6, 0.4, 1.0)  # the calibration file's: soft
DRIVER_CURVE = (0.6, 0.0, 1.0, 0.4)  # the driver's --pressure-curve: hard


def test_a_device_gets_one_curve_and_the_session_log_names_it(tmp_path: Path) -> None:
    # A calibration with threshold, maximum and curve, and a curve on the command line:
    # the driver's curve replaces the file's (not applied on top of it), the file's
    # threshold and maximum stay, and both session logs say what shaped their samples.
    pressure = PressureSettings(0.1, 0.9, FILE_CURVE)
    write_file(Calibration(DeviceId(*INTUOS_PRO_M), pressure=pressure),
               default_path(DeviceId(*INTUOS_PRO_M)))
    r = run_driver(tmp_path, "--pressure-curve", ",".join(map(str, DRIVER_CURVE)))
    assert r.returncode == 0, r.stderr
    (header, _), (raw_header, _) = (read_session(tmp_path / n) for n in ("out.jsonl",
                                                                         "raw.jsonl"))
    assert header.extra["pressure"]["curve"] == list(DRIVER_CURVE)
    assert (header.extra["pressure"]["threshold"], header.extra["pressure"]["maximum"],
            header.extra["pressure"]["applied_by"]) == (0.1, 0.9, "calibration")
    assert "curve from --pressure-curve" in header.extra["pressure"]["from"]
    assert raw_header.extra["pressure"]["applied_by"] == "none"
    out, raw = pens(tmp_path / "out.jsonl"), pens(tmp_path / "raw.jsonl")
    assert len(out) == len(raw) > 20
    one = PressureSettings(0.1, 0.9, DRIVER_CURVE)
    touching = [(o, w) for o, w in zip(out, raw, strict=True) if w.touching]
    assert len(touching) > 10 and any(0.1 < w.pressure < 0.9 for _, w in touching)
    for o, w in touching:
        pressure, contact = one.shape(w.pressure, True)
        assert o.touching is contact and o.pressure == pytest.approx(pressure, abs=1e-12)


def test_without_calibration_the_normaliser_applies_the_drivers_curve(tmp_path: Path) -> None:
    r = run_driver(tmp_path, "--calibration", "none",
                   "--pressure-curve", ",".join(map(str, DRIVER_CURVE)))
    assert r.returncode == 0, r.stderr
    header = read_session(tmp_path / "out.jsonl")[0]
    assert header.extra["pressure"] == {"threshold": 0.0, "maximum": 1.0,
                                        "curve": list(DRIVER_CURVE),
                                        "applied_by": "normaliser", "from": "--pressure-curve"}
    # the raw samples come after the normaliser: the same curve shaped them
    assert read_session(tmp_path / "raw.jsonl")[0].extra["pressure"] == header.extra["pressure"]
    out, raw = pens(tmp_path / "out.jsonl"), pens(tmp_path / "raw.jsonl")
    assert [s.pressure for s in out] == [s.pressure for s in raw]
