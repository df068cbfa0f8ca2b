"""Generic descriptor-driven pen parser: classification, golden samples, skips, errors."""

from __future__ import annotations

import pytest
from station.drivers import synth as S
from station.drivers.hid import usages as U
from station.drivers.hid.descriptor import FLAG_VARIABLE, CollectionKind, parse_descriptor
from station.drivers.hid.errors import ReportError
from station.drivers.hid.pen import GenericPenParser, classify_reports, tilt_from_azimuth

from station.events import Button, Tool


def generic(raw: bytes) -> GenericPenParser:
    return GenericPenParser(parse_descriptor(raw))


def test_classification_of_built_descriptors():
    assert classify_reports(parse_descriptor(S.pth660_like_descriptor())) == {16: "pen",
                                                                              17: "pad"}
    assert classify_reports(parse_descriptor(S.huion_like_descriptor())) == {3: "other",
                                                                             10: "pen"}
    assert classify_reports(parse_descriptor(S.ntrig_like_descriptor())) == {2: "pen"}
    assert classify_reports(parse_descriptor(S.touch_descriptor())) == {3: "touch"}
    assert classify_reports(parse_descriptor(S.wacom_protocol_descriptor())) == {1: "other",
                                                                                 2: "other"}


def test_huion_like_golden_from_hand_written_bytes():
    p = generic(S.huion_like_descriptor())
    # 0a | 23: tip, barrel, in range | x 04d2 | y 0237 | pressure 012c | tilt d3 (-45) 1e (30)
    (s,) = p.parse(bytes.fromhex("0a 23 d2 04 37 02 2c 01 d3 1e"), 3.25)
    assert s.time == 3.25
    assert (s.x, s.y, s.pressure, s.tilt_x, s.tilt_y) == (1234, 567, 300, -45, 30)
    assert s.tip is True and s.proximity and s.valid and s.buttons == Button.STYLUS
    assert s.tool == Tool.PEN and s.serial is None and s.tool_id is None
    r = p.ranges
    assert (r.x.maximum, r.y.maximum, r.x.resolution, r.y.resolution) == (50800, 31750, 200.0,
                                                                          200.0)  # fmt: skip
    assert r.pressure is not None and r.pressure.maximum == 8191
    assert r.tilt_x is not None and (r.tilt_x.minimum, r.tilt_x.maximum) == (-60, 60)
    assert r.tilt_x.resolution == 1.0
    assert p.generic and p.is_pen and p.kind == "pen"


def test_huion_out_of_range_and_keyboard_skipped():
    p = generic(S.huion_like_descriptor())
    (s,) = p.parse(bytes.fromhex("0a 00 d2 04 37 02 00 00 00 00"), 0.0)
    assert not s.proximity and not s.valid and s.tip is False
    assert p.parse(bytes.fromhex("03 00 04 00 00 00 00 00"), 0.0) == []
    assert p.skipped == 1 and p.skipped_by_kind == {"other": 1}


def test_pth660_like_wacom_vendor_fields():
    raw = S.pth660_like_descriptor()
    d = parse_descriptor(raw)
    p = GenericPenParser(d)
    report = S.encode_report(d, 0x10, {
        U.GD_X: 44800, U.GD_Y: 29600, U.DG_TIP_PRESSURE: 8191, U.DG_TIP_SWITCH: 1,
        U.DG_IN_RANGE: 1, U.DG_X_TILT: -9000, U.DG_Y_TILT: 4500,
        U.DG_TRANSDUCER_SERIAL: 0x89ABCDEF, U.WD_SERIAL_HI: 0x12, U.WD_TOOL_TYPE: 0x0802,
        U.WD_DISTANCE: 0, U.DG_SECONDARY_BARREL_SWITCH: 1,
    })  # fmt: skip
    (s,) = p.parse(report, 0.0)
    assert (s.x, s.y, s.pressure, s.tilt_x, s.tilt_y, s.distance) == (44800, 29600, 8191, -9000,
                                                                       4500, 0)  # fmt: skip
    assert s.serial == (0x12 << 32) | 0x89ABCDEF and s.tool_id == 0x802 and s.tool == Tool.PEN
    assert s.buttons == Button.STYLUS2
    assert p.ranges.tilt_x is not None and p.ranges.tilt_x.resolution == 100.0
    assert p.ranges.distance is not None and p.ranges.distance.maximum == 63
    assert p.ranges.x.resolution == 200.0
    # the pad report of the same interface is recognised and skipped
    assert p.parse(S.encode_report(d, 0x11, {0x90001: 1}), 0.0) == []
    assert p.skipped_by_kind == {"pad": 1}


def test_pth660_like_tool_type_pencil_and_eraser_invert():
    d = parse_descriptor(S.pth660_like_descriptor())
    p = GenericPenParser(d)
    (pencil,) = p.parse(S.encode_report(d, 0x10, {U.DG_IN_RANGE: 1, U.WD_TOOL_TYPE: 0x812}), 0)
    assert pencil.tool == Tool.PENCIL and pencil.tip is False
    (inv,) = p.parse(S.encode_report(d, 0x10, {U.DG_IN_RANGE: 1, U.DG_INVERT: 1}), 0.0)
    assert inv.tool == Tool.ERASER and inv.eraser and inv.tip is False
    (rub,) = p.parse(S.encode_report(d, 0x10, {U.DG_IN_RANGE: 1, U.DG_INVERT: 1,
                                                U.DG_ERASER: 1}), 0.0)  # fmt: skip
    assert rub.tool == Tool.ERASER and rub.tip is True  # the eraser end touching


def test_ntrig_like_odd_packing_golden():
    d = parse_descriptor(S.ntrig_like_descriptor())
    p = GenericPenParser(d)
    values = {U.GD_X: 9600, U.GD_Y: 7199, U.DG_TIP_PRESSURE: 1023, U.DG_X_TILT: -60,
              U.DG_Y_TILT: 59, U.DG_TWIST: 359, U.DG_TRANSDUCER_SERIAL: 0x7FFFFFFF,
              U.DG_TIP_SWITCH: 1, U.DG_IN_RANGE: 1, U.DG_BARREL_SWITCH: 1}  # fmt: skip
    report = S.encode_report(d, 2, values)
    assert len(report) == 15
    (s,) = p.parse(report, 0.0)
    assert (s.x, s.y, s.pressure, s.tilt_x, s.tilt_y, s.rotation, s.serial) == (
        9600, 7199, 1023, -60, 59, 359, 0x7FFFFFFF)
    assert s.buttons == Button.STYLUS and s.tip
    assert p.ranges.x.resolution == 37.5 and p.ranges.rotation is not None
    assert p.ranges.rotation.resolution == 1.0


def test_ntrig_like_fields_do_not_bleed_into_neighbours():
    d = parse_descriptor(S.ntrig_like_descriptor())
    p = GenericPenParser(d)
    # every field at its maximum except X: X must read 0 while its neighbours are all ones
    (s,) = p.parse(S.encode_report(d, 2, {U.GD_X: 0, U.GD_Y: 0x7FFF, U.DG_IN_RANGE: 1,
                                          U.DG_TIP_SWITCH: 1, U.DG_INVERT: 1, U.DG_ERASER: 1,
                                          U.DG_BARREL_SWITCH: 1}), 0.0)  # fmt: skip
    assert s.x == 0 and s.y == 0x7FFF


def test_array_encoded_switches():
    b = S.DescriptorBuilder()
    b.usage_page(U.PAGE_DIGITIZER).usage(0x02).collection(CollectionKind.APPLICATION)
    b.report_id(5).usage(0x20).collection(CollectionKind.PHYSICAL)
    b.usage(0x42).usage(0x44).usage(0x3C).usage(0x32).logical(1, 4).report_size(8)
    b.report_count(2).input(0)  # an array of two slots: 0 = none
    b.value(U.PAGE_GENERIC_DESKTOP, 0x30, 16, 0, 1000)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x31, 16, 0, 1000)
    b.end_collection().end_collection()
    d = parse_descriptor(b.to_bytes())
    p = GenericPenParser(d)
    assert p.is_pen
    (s,) = p.parse(bytes([5, 1, 4, 0x10, 0, 0x20, 0]), 0.0)  # tip + in range
    assert s.tip and s.proximity and (s.x, s.y) == (16, 32) and s.buttons == 0
    (h,) = p.parse(bytes([5, 4, 0, 0, 0, 0, 0]), 0.0)  # in range only
    assert h.proximity and not h.tip
    (o,) = p.parse(bytes([5, 9, 0, 0, 0, 0, 0]), 0.0)  # out-of-range array value: none
    assert not o.proximity and not o.tip
    assert S.encode_report(d, 5, {U.DG_TIP_SWITCH: True, U.DG_IN_RANGE: True})[:3] == bytes(
        [5, 1, 4])


def test_pen_without_in_range_is_in_proximity_while_reporting():
    b = S.DescriptorBuilder()
    b.usage_page(U.PAGE_DIGITIZER).usage(0x02).collection(CollectionKind.APPLICATION)
    b.bits(U.PAGE_DIGITIZER, [0x42]).padding(7)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x30, 16, 0, 100)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x31, 16, 0, 100)
    b.end_collection()
    p = generic(b.to_bytes())
    assert not p.descriptor.numbered
    (s,) = p.parse(bytes([1, 5, 0, 6, 0]), 0.0)
    assert s.proximity and s.tip and (s.x, s.y) == (5, 6)
    with pytest.raises(ReportError, match="is 4 bytes"):
        p.parse(bytes([1, 5, 0, 6]), 0.0)


def test_touch_only_descriptor_is_not_a_pen():
    p = generic(S.touch_descriptor())
    assert not p.is_pen and p.kind == "touch"
    assert p.parse(bytes([3] + [0] * 13), 0.0) == []
    assert p.skipped_by_kind == {"touch": 1}


@pytest.mark.parametrize(
    ("report", "text"),
    [(b"", "empty report"), (bytes([0x0B] + [0] * 9), "unknown input report ID 11"),
     (bytes([0x0A] + [0] * 8), "is 9 bytes, the descriptor says 10"),
     (bytes([0x03] + [0] * 3), "is 4 bytes")],
)  # fmt: skip
def test_generic_malformed_reports(report, text):
    with pytest.raises(ReportError, match=text):
        generic(S.huion_like_descriptor()).parse(report, 0.0)


def test_describe_lists_report_kinds():
    info = generic(S.pth660_like_descriptor()).describe()
    assert info["report_kinds"] == {"16": "pen", "17": "pad"} and info["pen_reports"] == [16]
    assert info["max_pressure"] == 8191 and info["tilt"] is True


def test_tilt_from_azimuth():
    tx, ty = tilt_from_azimuth(0.0, 45.0)
    assert tx == pytest.approx(45.0) and ty == pytest.approx(0.0, abs=1e-9)
    tx, ty = tilt_from_azimuth(90.0, 60.0)
    assert tx == pytest.approx(0.0, abs=1e-9) and ty == pytest.approx(30.0)
    assert tilt_from_azimuth(123.0, 90.0) == (0.0, 0.0)
    assert FLAG_VARIABLE == 2


def test_tilt_derived_from_azimuth_and_altitude():
    b = S.DescriptorBuilder()
    b.usage_page(U.PAGE_DIGITIZER).usage(0x02).collection(CollectionKind.APPLICATION)
    b.report_id(7).bits(U.PAGE_DIGITIZER, [0x42, 0x32]).padding(6)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x30, 16, 0, 1000)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x31, 16, 0, 1000)
    # azimuth 0..6283 milliradians, altitude 0..1571 milliradians
    b.value(U.PAGE_DIGITIZER, 0x3F, 16, 0, 6283, phys=(0, 6283), unit=0x12, exponent=-3)
    b.value(U.PAGE_DIGITIZER, 0x40, 16, 0, 1571, phys=(0, 1571))
    b.end_collection()
    d = parse_descriptor(b.to_bytes())
    p = GenericPenParser(d)
    assert p.ranges.tilt_x is not None and p.ranges.tilt_x.resolution == 100.0
    # azimuth 0 (leaning to +x), altitude 45 degrees (785 mrad): tilt x about +45 degrees
    (s,) = p.parse(S.encode_report(d, 7, {U.DG_IN_RANGE: 1, U.DG_AZIMUTH: 0,
                                          U.DG_ALTITUDE: 785}), 0.0)  # fmt: skip
    assert s.tilt_x == pytest.approx(4502, abs=3) and s.tilt_y == 0
    # upright pen: no tilt
    (u,) = p.parse(S.encode_report(d, 7, {U.DG_IN_RANGE: 1, U.DG_AZIMUTH: 1000,
                                          U.DG_ALTITUDE: 1571}), 0.0)  # fmt: skip
    assert abs(u.tilt_x) <= 2 and abs(u.tilt_y) <= 2


def test_compiled_decoder_agrees_with_the_plan_walker():
    import random

    from station.drivers.hid.pen import compile_plan

    rng = random.Random(5)
    for raw in (S.pth660_like_descriptor(), S.huion_like_descriptor(),
                S.ntrig_like_descriptor()):  # fmt: skip
        p = generic(raw)
        for rid, plan in p.plans.items():
            compiled = compile_plan(plan)
            assert compiled is not None
            for _ in range(300):
                body = bytes(rng.getrandbits(8) for _ in range(plan.length - 1))
                report = bytes([rid]) + body
                assert compiled(report, 1.0) == p.decode(plan, report, 1.0)


def test_64_bit_serial_plus_high_word_stays_64_bit():
    b = S.DescriptorBuilder()
    b.usage_page(U.PAGE_DIGITIZER).usage(0x02).collection(CollectionKind.APPLICATION)
    b.report_id(3).bits(U.PAGE_DIGITIZER, [0x42, 0x32]).padding(6)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x30, 16, 0, 1000)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x31, 16, 0, 1000)
    b.usage_page(U.PAGE_DIGITIZER).usage(0x5B).logical(0, 1).report_size(64).report_count(1)
    b.input(FLAG_VARIABLE)
    b.value(U.PAGE_WACOM_DIGITIZER, 0x5C, 32, 0, 0x7FFFFFFF)
    b.end_collection()
    d = parse_descriptor(b.to_bytes())
    p = GenericPenParser(d)
    report = bytes([3, 3, 0, 0, 0, 0]) + b"\xff" * 12
    (s,) = p.parse(report, 0.0)
    assert s.serial == (1 << 64) - 1
    assert p.decode(p.plans[3], report, 0.0) == s


def test_report_zero_of_a_numbered_descriptor_is_unknown():
    raw = (b"\x05\x0d\x09\x02\xa1\x01\x09\x42\x09\x32\x15\x00\x25\x01\x75\x01\x95\x02\x81\x02"
           b"\x75\x06\x95\x01\x81\x01\x05\x01\x09\x30\x09\x31\x26\xff\x00\x75\x08\x95\x02\x81\x02"
           b"\x85\x04\x09\x30\x81\x02\xc0")  # fmt: skip
    p = generic(raw)
    assert p.descriptor.numbered and 0 not in p.lengths and 0 not in p.plans
    with pytest.raises(ReportError, match="unknown input report ID 0"):
        p.parse(bytes([0, 3, 1, 2]), 0.0)
