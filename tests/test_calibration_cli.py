"""``station calibrate`` scripted modes: --fit, --from-trace, export/import, --check, exit codes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from station.calibration.files import read_file
from station.calibration.fit import PointSet
from station.calibration.geometry import project
from station.calibration.points import format_points, parse_points
from station.calibration.taps import detect_taps

from station.cli import main
from station.events import PenSample, Tool
from station.sessionlog import SessionHeader, SessionLogWriter

TRUTH = np.array([[0.97, 0.04, 0.012], [-0.03, 1.02, -0.018], [0.0, 0.0, 1.0]])


def grid9() -> np.ndarray:
    g = (0.1, 0.5, 0.9)
    return np.array([(x, y) for y in g for x in g])


def write_points(path: Path, noise: float = 0.0004, misclick: int | None = 5,
                 tilt: bool = False) -> PointSet:
    rng = np.random.default_rng(0)
    can = grid9()
    dev = project(np.linalg.inv(TRUTH), can) + rng.normal(0, noise, (9, 2))
    if misclick is not None:
        dev[misclick] += (0.06, -0.05)
    pts = PointSet(dev * 44704, can, np.zeros((9, 2)) if tilt else None)
    path.write_text(format_points(pts))
    return pts


def run_cli(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(["calibrate", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_fit_json_contract(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    f = tmp_path / "points.csv"
    write_points(f)
    code, out, _ = run_cli(capsys, "--fit", str(f), "--json", "--resolution", "200")
    assert code == 0
    rep = json.loads(out)
    for key in ("model", "matrix", "rms", "max", "outliers", "loo_rms", "residuals", "rms_mm"):
        assert key in rep
    assert rep["model"] == "affine"
    assert rep["outliers"] == [5]
    assert rep["outlier_where"] == [f"{f}:7"]  # header is line 1, row 5 is line 7
    m = np.array(rep["matrix"])
    assert m.shape == (3, 3) and m[2].tolist() == [0, 0, 1]
    # the matrix maps CSV device units to canvas: compare with the truth
    probe = np.random.default_rng(1).uniform(0.1, 0.9, (50, 2))
    assert np.abs(project(m, probe * 44704) - project(TRUTH, probe)).max() < 0.0015
    assert rep["rms"] < 0.001 and rep["max"] < 0.002
    assert len(rep["residuals"]) == 9 and rep["residuals"][5]["outlier"] is True


def test_fit_text_and_auto(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    f = tmp_path / "points.csv"
    write_points(f, misclick=None)
    code, out, _ = run_cli(capsys, "--fit", str(f), "--model", "auto")
    assert code == 0
    assert "model: affine" in out and "leave-one-out" in out and "auto chose" in out


def test_fit_writes_a_calibration_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    f = tmp_path / "points.csv"
    write_points(f)
    out_file = tmp_path / "cal.json"
    code, _, _ = run_cli(capsys, "--fit", str(f), "--device-max", "44704,27940",
                         "--id", "056a:0315:SER1", "-o", str(out_file))
    assert code == 0
    cal = read_file(out_file)
    assert (cal.device.vid, cal.device.pid, cal.device.serial) == (0x56A, 0x315, "SER1")
    # the file maps device-normalised → canvas; the points had device x in units of 44704
    # for both axes, so the y column scales by 27940 / 44704
    d = np.array([[0.3, 0.4]])
    expect = project(TRUTH, d * np.array([[1.0, 27940 / 44704]]))
    assert np.abs(cal.map_points(d)[0] - expect).max() < 0.0015


@pytest.mark.parametrize("content, message", [
    ("device_x,device_y,canvas_x,canvas_y\n1,1,0.1,0.1\n2,2,0.2,0.2\n3,3,0.3,0.3\n4,4,0.4,0.4\n",
     "collinear"),
    ("device_x,device_y,canvas_x,canvas_y\n1,1,0.1,0.1\n2,5,0.2,0.5\n", "needs at least 3"),
    ("device_x,device_y,canvas_x,canvas_y\n1,1,0.1,0.1\n2,nan,0.2,0.5\n3,9,0.7,0.9\n",
     "pts.csv:3: device_y is nan"),
    ("device_x,device_y,canvas_x,canvas_y\n1,1,0.1,0.1\n2,oops,0.2,0.5\n", "pts.csv:3"),
    ("device_x,device_y,canvas_x\n1,1,0.1\n", "pts.csv:1: header lacks canvas_y"),
    ("device_x,device_y,canvas_x,canvas_y\n1,1,0.1,0.1\n1,1,0.1,0.1\n5,1,0.5,0.1\n1,5,0.1,0.5\n",
     "duplicate point"),
    ("device_x,device_y,canvas_x,canvas_y\n1,1,0.1\n", "pts.csv:2: 3 fields"),
    ("", "empty file"),
])
def test_bad_points_exit_2_with_one_line(tmp_path: Path, content: str, message: str) -> None:
    f = tmp_path / "pts.csv"
    f.write_text(content)
    proc = subprocess.run([sys.executable, "-m", "station", "calibrate", "--fit", str(f)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr
    assert message in lines[0]


def test_points_csv_round_trip_is_exact(tmp_path: Path) -> None:
    pts = write_points(tmp_path / "p.csv", tilt=True)
    back = parse_points((tmp_path / "p.csv").read_text(), "p.csv")
    assert np.array_equal(back.device, pts.device) and np.array_equal(back.canvas, pts.canvas)
    assert back.tilt is not None and back.labels[0] == "p.csv:2"


def test_fit_reports_parallax_from_tilt_columns(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    rng = np.random.default_rng(2)
    five = np.array([(0.1, 0.1), (0.9, 0.1), (0.9, 0.9), (0.1, 0.9), (0.5, 0.5)])
    can = np.vstack([grid9(), five, five])
    tilt = np.vstack([np.zeros((9, 2)), np.tile([[-35.0, 25.0]], (5, 1)),
                      np.tile([[30.0, -30.0]], (5, 1))]) + rng.normal(0, 3, (19, 2))
    h = np.array([0.006, 0.004])  # device-normalised per tan(tilt)
    dev = project(np.linalg.inv(TRUTH), can) - h * np.tan(np.radians(tilt))
    dev += rng.normal(0, 0.0003, dev.shape)
    f = tmp_path / "tilt.csv"
    f.write_text(format_points(PointSet(dev, can, tilt)))
    code, out, _ = run_cli(capsys, "--fit", str(f), "--json")
    rep = json.loads(out)
    assert code == 0 and "parallax" in rep
    assert rep["parallax"]["x"] == pytest.approx(0.006, abs=0.0008)
    assert rep["parallax"]["y"] == pytest.approx(0.004, abs=0.0008)
    code, out, _ = run_cli(capsys, "--fit", str(f), "--json", "--parallax", "off")
    assert json.loads(out)["rms"] > 3 * rep["rms"]


# -- from a recorded session -----------------------------------------------------------------


def record_session(path: Path) -> None:
    """A session log of a calibration: 9 taps, a stroke, a misclick followed by its re-tap."""
    rng = np.random.default_rng(3)
    can = grid9()
    dev = project(np.linalg.inv(TRUTH), can)
    t = 0.0
    with SessionLogWriter(path, SessionHeader()) as w:
        def tap(x: float, y: float, tilt: tuple[float, float] = (5.0, 8.0)) -> None:
            nonlocal t
            for k in range(25):  # 125 ms at 200 Hz
                jx, jy = rng.normal(0, 0.0003, 2) if k > 2 else (0.004, -0.003)
                w.write(PenSample(t=t, device="pen-0", tool=Tool.PEN, x=x + jx, y=y + jy,
                                  pressure=0.4, tilt_x=tilt[0], tilt_y=tilt[1], touching=True))
                t += 0.005
            w.write(PenSample(t=t, device="pen-0", tool=Tool.PEN, x=x, y=y, touching=False))
            t += 0.4

        for i, (x, y) in enumerate(dev):
            if i == 4:  # a stroke (the user drew instead of tapping): skipped
                for k in range(40):
                    w.write(PenSample(t=t, device="pen-0", tool=Tool.PEN, x=0.2 + k * 0.01,
                                      y=0.6, pressure=0.5, touching=True))
                    t += 0.005
                w.write(PenSample(t=t, device="pen-0", tool=Tool.PEN, x=0.6, y=0.6))
                t += 0.3
            if i == 6:  # a misclick, then the real tap
                tap(x + 0.07, y - 0.05)
            tap(float(x), float(y))


def test_from_trace_detects_taps_and_fits(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "session.jsonl"
    record_session(log)
    targets = tmp_path / "targets.csv"
    targets.write_text("canvas_x,canvas_y\n" + "".join(f"{x},{y}\n" for x, y in grid9()))
    from station.calibrate.samples import iter_samples

    taps, strokes = detect_taps(iter_samples(log))
    assert len(taps) == 10 and strokes == 1
    code, out, _ = run_cli(capsys, "--from-trace", str(log), "--targets", str(targets), "--json")
    assert code == 0
    rep = json.loads(out)
    assert rep["taps"] == 10 and rep["strokes_skipped"] == 1 and rep["taps_unmatched"] == [6]
    m = np.array(rep["matrix"])
    probe = np.random.default_rng(1).uniform(0.1, 0.9, (50, 2))
    assert np.abs(project(m, probe) - project(TRUTH, probe)).max() < 0.001


def test_from_trace_needs_targets_and_enough_taps(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "session.jsonl"
    record_session(log)
    code, _, err = run_cli(capsys, "--from-trace", str(log))
    assert code == 2 and "--targets" in err
    many = tmp_path / "many.csv"
    many.write_text("canvas_x,canvas_y\n" + "0.5,0.5\n" * 14)
    code, _, err = run_cli(capsys, "--from-trace", str(log), "--targets", str(many))
    assert code == 2 and "10 taps but there are 14 targets" in err


# -- export / import / check -------------------------------------------------------------------


def test_export_import_check_via_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    f = tmp_path / "points.csv"
    write_points(f, misclick=None)
    cal_file = tmp_path / "cal.json"
    assert run_cli(capsys, "--fit", str(f), "--device-max", "44704,44704", "--id", "056a:0315",
                   "-o", str(cal_file))[0] == 0
    code, line, _ = run_cli(capsys, "--export", "libinput", "--calibration", str(cal_file))
    assert code == 0 and line.startswith("ENV{LIBINPUT_CALIBRATION_MATRIX}=")
    (tmp_path / "li.txt").write_text(line)
    back = tmp_path / "back.json"
    code, _, _ = run_cli(capsys, "--import", "libinput", "--input", str(tmp_path / "li.txt"),
                         "--id", "056a:0315", "-o", str(back))
    assert code == 0
    assert np.array_equal(read_file(back).matrix, read_file(cal_file).matrix)
    code, ts, _ = run_cli(capsys, "--export", "tslib", "--calibration", str(cal_file),
                          "--screen", "1920x1080")
    assert code == 0 and len(ts.split()) == 9 and ts.split()[6] == "65536"
    (tmp_path / "pointercal").write_text(ts)
    code, out, _ = run_cli(capsys, "--import", "tslib", "--input", str(tmp_path / "pointercal"),
                           "--id", "056a:0315", "--device-max", "44704,44704")
    assert code == 0 and json.loads(out)["format"] == "station-calibration"
    code, out, _ = run_cli(capsys, "--check", str(cal_file), "--id", "056a:0315")
    assert code == 0 and "ok" in out
    code, _, err = run_cli(capsys, "--check", str(cal_file), "--id", "056a:00fa")
    assert code == 2 and "not 056a:00fa" in err


def test_edit_sets_area_pressure_and_tilt(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    from station.calibration.area import DeviceGeometry
    from station.calibration.files import write_file
    from station.calibration.model import Calibration, DeviceId
    from station.calibration.pressure import bezier_eval

    f = tmp_path / "intuos.json"
    write_file(Calibration(DeviceId(0x56A, 0x315), DeviceGeometry(0, 44704, 0, 27940, 200, 200),
                           created="x"), f)
    code, _, _ = run_cli(capsys, "--edit", str(f), "--area", "80,50,100,60", "--area-units",
                         "mm", "--left-handed", "--outside", "drop", "--pressure-range",
                         "0.05,0.9", "--pressure-targets", "0.25:0.1,0.5:0.35,0.75:0.7",
                         "--tilt-offset", "1.5,-1")
    assert code == 0
    cal = read_file(f)
    a = cal.area.area
    assert a is not None and (a.cx, a.cy, a.width, a.height, a.units) == (80, 50, 100, 60, "mm")
    assert cal.area.left_handed and cal.area.outside == "drop"
    assert (cal.pressure.threshold, cal.pressure.maximum) == (0.05, 0.9)
    got = bezier_eval(cal.pressure.curve, np.array([0.25, 0.5, 0.75]))
    assert np.abs(got - [0.1, 0.35, 0.7]).max() < 0.01
    assert (cal.tilt.offset_x, cal.tilt.offset_y) == (1.5, -1.0)
    # left-handed: the area's top-left corner (30, 20) mm is now the output's bottom-right
    pt = np.array([[30 * 200 / 44704, 20 * 200 / 27940]])
    assert np.allclose(cal.map_points(pt)[0], [[1.0, 1.0]], atol=1e-9)

    # a setting that cannot be applied is refused and the file stays as it was
    g = tmp_path / "nores.json"
    write_file(Calibration(DeviceId(0x56A, 0x315), DeviceGeometry(0, 100, 0, 100), created="x"),
               g)
    before = g.read_text()
    code, _, err = run_cli(capsys, "--edit", str(g), "--area", "1,1,2,2", "--area-units", "mm")
    assert code == 2 and "no resolution" in err and g.read_text() == before
    code, _, err = run_cli(capsys, "--edit", str(g), "--pressure-range", "0.9,0.5")
    assert code == 2 and "threshold" in err and g.read_text() == before


def test_residuals_in_mm_from_the_device_size(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    # normalised device coordinates of a 223.52 × 139.7 mm tablet: a tap 2 mm off in x
    can = grid9()
    dev = project(np.linalg.inv(TRUTH), can)
    dev[4, 0] += 2.0 / 223.52
    f = tmp_path / "p.csv"
    f.write_text(format_points(PointSet(dev, can)))
    code, out, _ = run_cli(capsys, "--fit", str(f), "--json", "--no-robust",
                           "--device-size", "223.52,139.7")
    rep = json.loads(out)
    via_size = [r["norm_mm"] for r in rep["residuals"]]
    code2, out2, _ = run_cli(capsys, "--fit", str(f), "--json", "--no-robust",
                             "--resolution", f"{1 / 223.52},{1 / 139.7}")
    via_res = [r["norm_mm"] for r in json.loads(out2)["residuals"]]
    assert code == code2 == 0 and via_size == pytest.approx(via_res, rel=1e-12)
    # least squares keeps 8/9 of the slip at the centre tap (its leverage is 1/9)
    assert via_size[4] == pytest.approx(2.0 * 8 / 9, rel=0.02)
