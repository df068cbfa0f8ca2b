"""Calibration that guides (issue 24.5): --fit refuses pixels unless told, exports check."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from station.calibration.export import ExportError, check_normalised
from station.calibration.fit import PointSet
from station.calibration.points import format_points

from station.cli import main


def _points(path: Path, scale: tuple[float, float] = (1.0, 1.0)) -> None:
    g = (0.1, 0.5, 0.9)
    can = np.array([(x, y) for y in g for x in g])
    dev = (can * 0.98 + 0.01) * 44704
    path.write_text(format_points(PointSet(dev, can * np.array(scale), None)))


def test_pixels_are_refused_with_file_and_line(tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    pts = tmp_path / "px.csv"
    _points(pts, (1920.0, 1080.0))
    assert main(["calibrate", "--fit", str(pts), "--json"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert f"{pts}:2: canvas_x 192 is outside [0, 1]" in err[0] and "--units px" in err[0]


def test_pixels_with_their_canvas_fit_as_normalised(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    px, norm = tmp_path / "px.csv", tmp_path / "n.csv"
    _points(px, (1920.0, 1080.0))
    _points(norm)
    assert main(["calibrate", "--fit", str(px), "--units", "px", "--canvas", "1920x1080",
                 "--json"]) == 0
    a = capsys.readouterr().out
    assert main(["calibrate", "--fit", str(norm), "--json"]) == 0
    b = capsys.readouterr().out
    import json

    ma, mb = np.array(json.loads(a)["matrix"]), np.array(json.loads(b)["matrix"])
    assert np.abs(ma - mb).max() < 1e-9
    assert main(["calibrate", "--fit", str(px), "--units", "px", "--json"]) == 2
    assert "--units px needs --canvas WxH" in capsys.readouterr().err


def test_exports_refuse_a_matrix_that_is_not_normalised(tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]
                                                        ) -> None:
    good = np.array([[0.98, 0.0, 0.01], [0.0, 1.02, -0.01], [0.0, 0.0, 1.0]])
    check_normalised(good, "libinput")
    bad = np.array([[815.7, 0.0, 3.0], [0.0, 459.0, 1.0], [0.0, 0.0, 1.0]])
    with pytest.raises(ExportError, match=r"sends corner \(0, 0\) to \(3, 1\)|corner"):
        check_normalised(bad, "libinput")
    # end to end: a calibration file fitted (the old way) to pixels exports nothing
    pts = tmp_path / "px.csv"
    _points(pts, (1.0, 1.0))
    cal = tmp_path / "cal.json"
    assert main(["calibrate", "--fit", str(pts), "--id", "056a:0315", "-o", str(cal)]) == 0
    capsys.readouterr()
    import json

    doc = json.loads(cal.read_text())
    # without --device-max the fit is in device units: 2.3e-05 per unit, the whole
    # tablet on a spot of the screen; refused too
    code = main(["calibrate", "--export", "libinput", "--calibration", str(cal)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "a spot 2.28e-05 wide" in err[0]
    doc["mapping"]["matrix"] = [[815.7, 0.0, 3.0], [0.0, 459.0, 1.0], [0.0, 0.0, 1.0]]
    cal.write_text(json.dumps(doc))
    code = main(["calibrate", "--export", "libinput", "--calibration", str(cal)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "expects a normalised 3x3 matrix" in err[0]
    assert "sends corner (0, 0) to (3, 1)" in err[0]
    good_cal = tmp_path / "good.json"
    assert main(["calibrate", "--fit", str(pts), "--id", "056a:0315", "--device-max",
                 "44704,44704", "-o", str(good_cal)]) == 0
    capsys.readouterr()
    assert main(["calibrate", "--export", "libinput", "--calibration", str(good_cal)]) == 0
    assert "LIBINPUT_CALIBRATION_MATRIX" in capsys.readouterr().out
