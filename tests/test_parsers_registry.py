"""Device data (schema, ids, numbers) and the registry's parser choice."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import jsonschema
import pytest
from station.drivers import registry
from station.drivers import synth as S
from station.drivers.hid.base import IgnoredInterface
from station.drivers.hid.errors import DescriptorError
from station.drivers.hid.pen import GenericPenParser

from station.errors import BadInput

SCHEMA = json.loads(registry.SCHEMA_PATH.read_text())


def models():
    return registry.load_devices()


def clean(model):
    return {k: v for k, v in model.items() if not k.startswith("_")}


def test_every_model_validates_against_the_schema():
    validator = jsonschema.Draft202012Validator(SCHEMA)
    assert len(models()) >= 8
    for m in models():
        errors = list(validator.iter_errors(clean(m)))
        assert errors == [], (m["_path"], [e.message for e in errors])
        assert Path(m["_path"]).stem == m["id"]


def test_schema_rejects_unknown_keys_and_bad_values():
    validator = jsonschema.Draft202012Validator(SCHEMA)
    base = clean(registry.find_device(0x056A, 0x0315))
    extra = dict(base, colour="blue")
    assert any("colour" in e.message for e in validator.iter_errors(extra))
    for key, bad in [("vendor_id", "56A"), ("bus", "serial"), ("max_x", 0),
                     ("init_feature_reports", ["0g"]), ("drawing_area_mm", [10])]:  # fmt: skip
        assert list(validator.iter_errors(dict(base, **{key: bad}))), key
    nested = copy.deepcopy(base)
    nested["resolution"]["z"] = 3
    assert list(validator.iter_errors(nested))
    missing = dict(base)
    del missing["parser"]
    assert list(validator.iter_errors(missing))


def test_parser_names_exist_and_ids_are_unique():
    names = set(registry.parser_names())
    seen = set()
    for m in models():
        assert m["parser"] in names, m["id"]
        key = registry.device_ids(m)
        assert key not in seen, f"duplicate vid/pid/bus {key}"
        seen.add(key)
    assert len({m["id"] for m in models()}) == len(models())


def test_drawing_area_matches_max_over_resolution():
    for m in models():
        if "drawing_area_mm" not in m:
            assert m["parser"] in ("hid-generic", "uclogic"), m["id"]  # numbers from the device
            continue
        w, h = m["drawing_area_mm"]
        assert abs(w - m["max_x"] / m["resolution"]["x"]) < 0.5, m["id"]
        assert abs(h - m["max_y"] / m["resolution"]["y"]) < 0.5, m["id"]


@pytest.mark.parametrize(
    ("pid", "bus", "max_x", "max_y", "pressure", "parser", "res"),
    [(0x0315, 3, 44704, 27940, 2047, "wacom-intuos", 200),
     (0x00B8, 3, 31496, 19685, 2047, "wacom-intuos", 200),
     (0x00FA, 3, 95840, 54260, 2047, "wacom-intuos", 200),
     (0x030E, 3, 15200, 9500, 1023, "wacom-bamboo", 100),
     (0x00D4, 3, 14720, 9200, 1023, "wacom-bamboo", 100),
     (0x0081, 3, 16704, 12064, 511, "wacom-graphire", 80),
     (0x0081, 5, 16704, 12064, 511, "wacom-graphire-bt", 80),
     (0x0357, 3, 44800, 29600, 8191, "hid-generic", 200)],
)  # fmt: skip
def test_models_from_the_spec(pid, bus, max_x, max_y, pressure, parser, res):
    m = registry.find_device(0x056A, pid, bus)
    assert m is not None
    assert (m["max_x"], m["max_y"], m["max_pressure"], m["parser"]) == (max_x, max_y, pressure,
                                                                        parser)  # fmt: skip
    assert m["resolution"] == {"x": res, "y": res}
    assert m["screen_tablet"] is (pid == 0x00FA)
    if bus == 3 and parser != "hid-generic":
        assert m["init_feature_reports"] == ["0202"]


def test_find_device_bus_preference():
    assert registry.find_device(0x056A, 0x0081)["bus"] == "usb"
    assert registry.find_device(0x056A, 0x0081, 5)["bus"] == "bluetooth"
    assert registry.find_device(0x056A, 0x0315, 5)["bus"] == "usb"  # only one: any bus
    assert registry.find_device(0x1234, 0x5678) is None


def test_protocol_parser_ranges_from_device_data():
    p = registry.parser_for(0x056A, 0x0315, None)
    assert p.name == "wacom-intuos" and not p.generic and p.is_pen
    assert p.model is not None and p.model["id"] == "wacom-intuos-pro-m"
    assert (p.ranges.x.maximum, p.ranges.y.maximum, p.ranges.x.resolution) == (44704, 27940, 200)
    assert p.ranges.distance is not None and p.ranges.distance.maximum == 63
    assert p.init_features == [b"\x02\x02"]


def test_protocol_device_with_its_descriptor():
    p = registry.parser_for(0x056A, 0x00D4, S.wacom_protocol_descriptor(8))
    assert p.name == "wacom-bamboo" and p.is_pen


def test_protocol_device_touch_interface_is_ignored():
    p = registry.parser_for(0x056A, 0x0315, S.touch_descriptor())
    assert isinstance(p, IgnoredInterface) and not p.is_pen and p.kind == "touch"
    assert p.parse(b"\x03\x00", 0.0) == [] and p.skipped == 1
    by_number = registry.parser_for(0x056A, 0x0315, None, interface=1)
    assert not by_number.is_pen and by_number.kind == "touch"
    assert registry.parser_for(0x056A, 0x0315, None, interface=0).is_pen


def test_protocol_device_with_malformed_descriptor_still_works(caplog):
    p = registry.parser_for(0x056A, 0x0315, b"\x05\x01\xc0")
    assert p.name == "wacom-intuos"
    assert "descriptor ignored" in caplog.text


def test_generic_model_uses_its_descriptor():
    p = registry.parser_for(0x056A, 0x0357, S.pth660_like_descriptor())
    assert isinstance(p, GenericPenParser)
    assert p.name == "hid-generic" and not p.generic and p.model is not None
    assert p.ranges.x.maximum == 44800 and p.ranges.pressure.maximum == 8191
    touch = registry.parser_for(0x056A, 0x0357, S.touch_descriptor())
    assert not touch.is_pen
    with pytest.raises(BadInput, match="needs its report descriptor"):
        registry.parser_for(0x056A, 0x0357, None)


def test_unknown_devices():
    p = registry.parser_for(0x1234, 0x5678, S.huion_like_descriptor())
    assert p.generic and p.model is None and p.is_pen and p.name == "hid-generic"
    assert p.warning is None  # an unknown non-Wacom digitizer is simply descriptor-driven
    with pytest.raises(BadInput, match="no pen collection"):
        registry.parser_for(0x1234, 0x5678, S.touch_descriptor())
    with pytest.raises(BadInput, match="needs its report descriptor"):
        registry.parser_for(0x1234, 0x5678, None)
    with pytest.raises(DescriptorError, match="descriptor byte 2"):
        registry.parser_for(0x1234, 0x5678, b"\x05\x01\xc0")


def test_api_surface():
    p = registry.parser_for(0x056A, 0x00B8, None)
    for attr in ("name", "model", "generic", "ranges", "init_features", "is_pen", "skipped"):
        assert hasattr(p, attr)
    assert registry.ReportError.__mro__[1] is BadInput
    assert p.describe()["parser"] == "wacom-intuos"


def test_device_data_copies_do_not_leak_mutations():
    m = registry.find_device(0x056A, 0x0315)
    m["resolution"]["x"] = 1
    m["init_feature_reports"].append("ff")
    again = registry.find_device(0x056A, 0x0315)
    assert again["resolution"]["x"] == 200 and again["init_feature_reports"] == ["0202"]
