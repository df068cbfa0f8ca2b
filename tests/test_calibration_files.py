"""Calibration files, schema validation, the store, and libinput / tslib round trips."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from station.calibration.area import Area, AreaSettings, DeviceGeometry, Rect
from station.calibration.errors import CalibrationFileError, DeviceMismatch, ExportError
from station.calibration.export import (
    libinput_line,
    parse_libinput,
    parse_tslib,
    to_tslib,
    tslib_line,
)
from station.calibration.files import (
    CalibrationStore,
    dumps,
    load_for_device,
    loads,
    read_file,
    to_json,
    write_file,
)
from station.calibration.geometry import project
from station.calibration.model import Calibration, DeviceId, FitInfo
from station.calibration.pressure import PressureSettings, TiltSettings

from station.events import PenSample, Tool

CINTIQ = DeviceId(0x056A, 0x00FA, "8BX00123", "Cintiq 22HD")
GEOM = DeviceGeometry(0, 95840, 0, 54260, 200.0, 200.0)


def full_calibration(matrix: tuple | None = None) -> Calibration:
    m = matrix or ((1.0123456789012345, 0.0132, -0.0071), (-0.0093, 0.987654321, 0.0123),
                   (0.0, 0.0, 1.0))
    return Calibration(
        device=CINTIQ,
        geometry=GEOM,
        fit=FitInfo("affine", m, (0.0021, -0.0013), 0.0004, 0.0009, 0.0006, 9),
        area=AreaSettings(Area(0.5, 0.5, 0.8, 0.7, 90.0), left_handed=True, lock_aspect=True,
                          outside="drop", output=Rect(0.1, 0.05, 0.8, 0.9),
                          output_pixels=(1920, 1080)),
        pressure=PressureSettings(0.04, 0.85, (0.3, 0.1, 0.7, 0.95)),
        tilt=TiltSettings(1.5, -2.25),
        created="2026-11-22T03:00:00+00:00",
        notes="test",
    )


def affine_only(matrix: tuple | None = None) -> Calibration:
    m = matrix or ((1.0123456789012345, 0.0132, -0.0071), (-0.0093, 0.987654321, 0.0123),
                   (0.0, 0.0, 1.0))
    return Calibration(device=CINTIQ, geometry=GEOM, fit=FitInfo("affine", m),
                       created="2026-11-22T03:00:00+00:00")


def test_json_round_trip_is_exact(tmp_path: Path) -> None:
    cal = full_calibration()
    path = write_file(cal, tmp_path / "cal.json")
    back = read_file(path, expect=CINTIQ)
    assert to_json(back) == to_json(cal)
    assert np.array_equal(back.matrix, cal.matrix)  # bit-exact composed matrix
    assert dumps(back) == dumps(cal)
    # random doubles survive too (repr is the shortest round-trip form)
    rng = np.random.default_rng(0)
    m = rng.normal(size=(3, 3))
    cal2 = Calibration(CINTIQ, fit=FitInfo("homography", tuple(map(tuple, m))), created="x")
    assert np.array_equal(loads(dumps(cal2)).fit.array, m)


def test_schema_refuses_corrupt_and_foreign_files(tmp_path: Path) -> None:
    good = to_json(full_calibration())
    cases = {
        "not json": "{ this is not json",
        "nan": dumps(full_calibration()).replace("0.0004", "NaN"),
        "format": json.dumps({**good, "format": "something-else"}),
        "version": json.dumps({**good, "version": 2}),
        "matrix shape": json.dumps({**good, "mapping": {**good["mapping"], "matrix": [[1, 0]]}}),
        "extra key": json.dumps({**good, "surprise": 1}),
        "bad vid": json.dumps({**good, "device": {**good["device"], "vid": 70000}}),
        "singular": json.dumps({**good, "mapping": {**good["mapping"],
                                                    "matrix": [[1, 2, 0], [2, 4, 0], [0, 0, 1]]}}),
        "pressure order": json.dumps({**good, "pressure": {"threshold": 0.9, "maximum": 0.5}}),
    }
    for name, text in cases.items():
        p = tmp_path / f"{name.replace(' ', '_')}.json"
        p.write_text(text)
        with pytest.raises(CalibrationFileError) as info:
            read_file(p)
        assert str(p) in str(info.value), name


def test_wrong_device_refused_and_store_keeps_last_good(tmp_path: Path) -> None:
    good = write_file(full_calibration(), tmp_path / "good.json")
    other = full_calibration()
    other.device = DeviceId(0x056A, 0x0315)  # an Intuos Pro, not this Cintiq
    wrong = write_file(other, tmp_path / "wrong.json")
    serial = full_calibration()
    serial.device = DeviceId(0x056A, 0x00FA, "OTHERSERIAL")
    wrong_serial = write_file(serial, tmp_path / "serial.json")
    corrupt = tmp_path / "corrupt.json"
    corrupt.write_text(good.read_text()[:200])

    store = CalibrationStore(CINTIQ)
    store.load(good)
    kept = store.current
    assert kept is not None
    for bad, err in ((wrong, DeviceMismatch), (wrong_serial, DeviceMismatch),
                     (corrupt, CalibrationFileError)):
        with pytest.raises(err):
            store.load(bad)
        assert store.current is kept  # the last good calibration stays in use
        assert store.try_load(bad) is False and store.last_error is not None
    s = PenSample(t=0.0, device="pen-0", tool=Tool.PEN, x=0.5, y=0.5)
    assert store.apply(s) == kept.apply(s)
    assert store.loads == 1


def test_load_for_device_uses_config_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("STATION_CONFIG_DIR", str(tmp_path))
    assert load_for_device(0x056A, 0x00FA) is None
    generic = affine_only()
    generic.device = DeviceId(0x056A, 0x00FA)
    write_file(generic, tmp_path / "calibration" / "056a-00fa.json")
    specific = full_calibration()
    write_file(specific, tmp_path / "calibration" / "056a-00fa-8BX00123.json")
    found = load_for_device(0x056A, 0x00FA, "8BX00123")
    assert found is not None and found.device.serial == "8BX00123"
    other_pen = load_for_device(0x056A, 0x00FA, "ANOTHER")
    assert other_pen is not None and other_pen.device.serial is None  # the generic file
    assert load_for_device(0x056A, 0x0315) is None
    # a file under the device's name but holding another device is refused
    (tmp_path / "calibration" / "056a-0315.json").write_text(
        (tmp_path / "calibration" / "056a-00fa.json").read_text())
    with pytest.raises(DeviceMismatch):
        load_for_device(0x056A, 0x0315)


# -- libinput -----------------------------------------------------------------------------


def test_libinput_round_trips_exactly() -> None:
    rng = np.random.default_rng(2)
    for _ in range(50):
        m = np.eye(3)
        # normalised matrices (issue 24.5: exports refuse one that sends the tablet off
        # the screen): near the identity, any bits
        m[:2, :] += rng.normal(scale=0.15, size=(2, 3))
        cal = affine_only(tuple(map(tuple, m)))
        line = libinput_line(cal)
        assert line.startswith('ENV{LIBINPUT_CALIBRATION_MATRIX}="')
        back = parse_libinput(line, CINTIQ)
        assert np.array_equal(back.matrix, cal.matrix)  # float64 bits preserved
        assert libinput_line(back) == line  # the line itself is a fixed point
    # the hwdb form and bare numbers are read too
    assert parse_libinput("LIBINPUT_CALIBRATION_MATRIX=1 0 0 0 1 0", CINTIQ).fit.model == "affine"
    back = parse_libinput("  0 1 0 -1 0 1\n", CINTIQ)
    assert back.matrix.tolist() == [[0, 1, 0], [-1, 0, 1], [0, 0, 1]]


def test_libinput_refuses_what_it_cannot_express() -> None:
    with pytest.raises(ExportError, match="parallax"):
        libinput_line(full_calibration())
    proj = Calibration(CINTIQ, fit=FitInfo("homography", ((1, 0, 0), (0, 1, 0), (0.1, 0, 1))))
    with pytest.raises(ExportError, match="projective"):
        libinput_line(proj)
    for bad in ('ENV{LIBINPUT_CALIBRATION_MATRIX}="1 0 0 0 1"', "hello", "1 0 nan 0 1 0"):
        with pytest.raises(CalibrationFileError):
            parse_libinput(bad, CINTIQ)


# -- tslib --------------------------------------------------------------------------------


def test_tslib_integer_round_trip_is_exact() -> None:
    rng = np.random.default_rng(4)
    for _ in range(200):
        ints = [int(v) for v in rng.integers(-3000, 3000, 2)] + [int(rng.integers(-2**26, 2**26))]
        ints += [int(v) for v in rng.integers(-3000, 3000, 2)] + [int(rng.integers(-2**26, 2**26))]
        if ints[0] * ints[4] - ints[1] * ints[3] == 0:
            continue
        line = " ".join(map(str, [*ints, 65536, 1920, 1080]))
        cal = parse_tslib(line, CINTIQ, GEOM)
        assert tslib_line(cal, 1920, 1080) == line


def test_tslib_export_quantisation_is_bounded_and_a_fixed_point() -> None:
    cal = affine_only()
    first = to_tslib(cal, 1920, 1080)
    again = parse_tslib(" ".join(map(str, first)), CINTIQ, GEOM)
    assert to_tslib(again, 1920, 1080) == first  # export → import → export is stable
    # pixel error of the quantised mapping: at most 0.5 (1 + |X| + |Y|) / 65536 px
    xs = np.array([[0, 0], [95840, 54260], [95840, 0], [0, 54260], [40000, 20000]], float)
    a, b, c, d, e, f, s = first[:7]
    px = np.column_stack([(c + a * xs[:, 0] + b * xs[:, 1]) / s,
                          (f + d * xs[:, 0] + e * xs[:, 1]) / s])
    exact = project(cal.matrix, xs / np.array([95840, 54260])) * np.array([1920, 1080])
    bound = 0.5 * (1 + np.abs(xs).sum(axis=1)) / 65536
    assert (np.abs(px - exact).max(axis=1) <= bound + 1e-9).all()


def test_tslib_format_errors() -> None:
    for bad in ("1 2 3", "1 2 3 4 5 6 x 800 600", "1 0 0 0 1 0 0 800 600",
                "1 0 0 0 1 0 65536 800 600 1"):
        with pytest.raises(CalibrationFileError):
            parse_tslib(bad, CINTIQ, GEOM)
    with pytest.raises(CalibrationFileError, match="screen size"):
        parse_tslib("1 0 0 0 1 0 65536", CINTIQ, GEOM)
    seven = parse_tslib("1 0 0 0 1 0 65536", CINTIQ, GEOM, xres=800, yres=600)
    assert tslib_line(seven, 800, 600) == "1 0 0 0 1 0 65536 800 600"
