"""Every reader validates values (issue 25 item 4): a DOCTYPE or a non-finite number in
a profile, a brush shape nested 100k deep, an absurd calibration matrix, oversized or
duplicate device data, an out-of-range `station send`, a hidraw: path that is not a
hidraw node: each is one line and exit 2, never a traceback or a silent acceptance."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from station.calibration.errors import CalibrationError
from station.calibration.model import Calibration, DeviceId, FitInfo
from station.drivers.registry import DEVICES_DIR, parse_device_data, read_device_dir

from station.canvas.errors import CanvasInputError
from station.canvas.profiles import load_profile_file
from station.cli import main
from station.errors import BadInput

WATERCOLOR = Path(__file__).parents[1] / "station/data/profiles/watercolor.xml"


@pytest.mark.parametrize("value, says", [("INF", "not a finite number"),
                                         ("NaN", "not a finite number"),
                                         ("1e308", "out of range")])
def test_profile_numbers_are_finite_and_in_range(tmp_path: Path, value: str, says: str) -> None:
    p = tmp_path / "p.xml"
    p.write_text(WATERCOLOR.read_text().replace('radius="6.0"', f'radius="{value}"'))
    with pytest.raises(CanvasInputError, match=f"radius='{value}' is {says}"):
        load_profile_file(p)


def test_profile_with_a_doctype_is_refused(tmp_path: Path) -> None:
    text = WATERCOLOR.read_text()
    head, body = text.split("\n", 1)
    p = tmp_path / "p.xml"
    p.write_text(f'{head}\n<!DOCTYPE profile [<!ENTITY lol "lol">]>\n{body}')
    with pytest.raises(CanvasInputError, match="DOCTYPE"):
        load_profile_file(p)


def test_brush_shape_nested_deep_is_one_line(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000)
    assert main(["brush-sheet", "--shape", str(deep), "-o", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nested too deeply" in err[0], err


def test_absurd_calibration_matrices_are_refused() -> None:
    dev = DeviceId(0x056A, 0x0315)
    for m in ([[1e308, 0, 0], [0, 1e308, 0], [0, 0, 1]], [[1e-6, 0, 0], [0, 1e-6, 0], [0, 0, 1]],
              [[5e3, 0, 0], [0, 1, 0], [0, 0, 1]]):
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # no numpy warning leaks either
            with pytest.raises(CalibrationError):
                Calibration(dev, fit=FitInfo("affine", tuple(map(tuple, np.array(m, float)))))
    ok = [[0.9, 0.01, 0.05], [0.0, 1.1, -0.02], [0, 0, 1]]
    Calibration(dev, fit=FitInfo("affine", tuple(map(tuple, np.array(ok)))))


def test_device_data_sizes_and_duplicate_ids(tmp_path: Path) -> None:
    good = json.loads(next(DEVICES_DIR.glob("elan-2072*.json")).read_text())
    for bad, says in (({**good, "init_feature_reports": ["02" * 1000]}, "longer than"),
                      ({**good, "name": "x" * 2_000_000}, "more than"),
                      ({**good, "notes": "y" * 10_000}, "at most")):
        with pytest.raises(BadInput, match=says):
            parse_device_data(json.dumps(bad), "t.json")
    (tmp_path / "a.json").write_text(json.dumps(good))
    (tmp_path / "b.json").write_text(json.dumps({**good, "name": "another"}))
    with pytest.raises(BadInput, match="also in"):
        read_device_dir(tmp_path)


def test_send_checks_ranges_before_sending(capsys: pytest.CaptureFixture[str]) -> None:
    for args, says in ((['{"seconds": 1e9}'], "seconds"), (["x=2"], "x"),
                       (['{"radius": -1}'], "radius")):
        assert main(["send", "hairdryer", *args, "--timeout", "0.2"]) == 2, args
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and says in err[0], err


def test_transports_refuse_nodes_of_another_kind(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    plain = tmp_path / "plain"
    plain.write_text("x")
    for spec, says in (("hidraw:/dev/null", "not hidraw"),
                       (f"hidraw:{plain}", "not a character device"),
                       ("evdev:/dev/null", "not an evdev node"),
                       (f"evdev:{plain}", "not an evdev node")):
        code = main(["driver", "--device", spec, "--bus", "@ipc:lan-hidraw"])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and says in err[0], (spec, err)


def test_trace_axis_ranges_must_fit_32_bits() -> None:
    """Found by `station bench fuzz` at 100,000 inputs: an absinfo maximum of 2**70 went
    through to the normaliser's float() (OverflowError)."""
    from station.bench.fuzz import evdev_seeds, read_evemu, read_libinput

    evemu, yaml_ = evdev_seeds()
    assert "44704" in yaml_[0] and "44704" in evemu[0]
    with pytest.raises(BadInput, match="32 bits"):
        read_libinput(yaml_[0].replace("44704", str(2 ** 70), 1))
    with pytest.raises(BadInput, match="32 bits"):
        read_evemu(evemu[0].replace("44704", str(2 ** 70), 1))


def test_deep_yaml_is_refused_before_the_parser() -> None:
    """Found by `station bench fuzz` at 100,000 inputs on a loaded machine: 50,000 levels
    of flow nesting kept the pure-Python YAML parser busy past the fuzzer's 10 s alarm."""
    import random

    from station.bench.fuzz import Tally, evdev_seeds, mutate_text, read_libinput

    _evemu, yaml_ = evdev_seeds()
    tally = Tally()
    for k in (245, 1544):  # the two seeds that hung
        rng = random.Random(f"benchlibinput-record-{k}")
        tally.run("libinput-record", read_libinput, mutate_text(rng, rng.choice(yaml_), yaml_), k)
    assert tally.kinds == {} and tally.counts["libinput-record"]["bad_input"] == 2
    for deep in ("[" * 50_000, "- " * 50_000, "{a: " * 50_000):
        with pytest.raises(BadInput, match="nested more than 64"):
            read_libinput("devices:\n  - " + deep)
