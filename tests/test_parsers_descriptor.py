"""HID report-descriptor parser: items, global/local state, layouts, extraction, errors."""

from __future__ import annotations

import pytest
from station.drivers.hid import usages as U
from station.drivers.hid.descriptor import (
    FLAG_CONSTANT,
    FLAG_VARIABLE,
    MAX_DESCRIPTOR_BYTES,
    CollectionKind,
    ItemType,
    ReportType,
    Unit,
    decode_unit_exponent,
    extract_bits,
    field_values,
    iter_items,
    kernel_resolution,
    parse_descriptor,
    report_values,
    resolution,
)
from station.drivers.hid.errors import DescriptorError, ReportError
from station.drivers.synth import (
    DescriptorBuilder,
    huion_like_descriptor,
    ntrig_like_descriptor,
    pth660_like_descriptor,
)

from station.errors import BadInput

# HID 1.11 Appendix E.10: the boot mouse report descriptor, written out by hand.
BOOT_MOUSE = bytes.fromhex(
    "05 01 09 02 a1 01 09 01 a1 00 05 09 19 01 29 03 15 00 25 01 95 03 75 01 81 02"
    " 95 01 75 05 81 01 05 01 09 30 09 31 15 81 25 7f 75 08 95 02 81 06 c0 c0"
)
# HID 1.11 Appendix E.6: the boot keyboard report descriptor (input, LED output, key array).
BOOT_KEYBOARD = bytes.fromhex(
    "05 01 09 06 a1 01 05 07 19 e0 29 e7 15 00 25 01 75 01 95 08 81 02 95 01 75 08 81 01"
    " 95 05 75 01 05 08 19 01 29 05 91 02 95 01 75 03 91 01 95 06 75 08 15 00 25 65"
    " 05 07 19 00 29 65 81 00 c0"
)


def test_boot_mouse_layout():
    d = parse_descriptor(BOOT_MOUSE)
    assert not d.numbered
    assert len(d.items) == 26
    assert [c.kind for c in d.collections] == [CollectionKind.APPLICATION, CollectionKind.PHYSICAL]
    assert [c.usage for c in d.collections] == [U.GD_MOUSE, U.GD_POINTER]
    buttons, pad, xy = d.fields
    assert (buttons.bit_offset, buttons.size, buttons.count) == (0, 1, 3)
    assert buttons.usages == (0x90001, 0x90002, 0x90003)
    assert pad.is_constant and (pad.bit_offset, pad.size) == (3, 5)
    assert (xy.bit_offset, xy.size, xy.count) == (8, 8, 2)
    assert xy.usages == (U.GD_X, U.GD_Y)
    assert (xy.logical_min, xy.logical_max) == (-127, 127)
    assert xy.is_relative and xy.signed
    assert xy.application == U.GD_MOUSE
    rep = d.input_reports()
    assert len(rep) == 1 and rep[0].bits == 24 and rep[0].length(False) == 3
    # buttons 1 and 3, dx = -1, dy = +5
    values = report_values(d, bytes([0b101, 0xFF, 0x05]))
    assert values[0x90001] == 1 and values[0x90002] == 0 and values[0x90003] == 1
    assert values[U.GD_X] == -1 and values[U.GD_Y] == 5


def test_boot_keyboard_arrays_and_output():
    d = parse_descriptor(BOOT_KEYBOARD)
    inp = d.report(ReportType.INPUT, 0)
    out = d.report(ReportType.OUTPUT, 0)
    assert inp is not None and out is not None
    assert inp.bits == 64 and out.bits == 8
    keys = inp.fields[-1]
    assert keys.is_array and keys.count == 6 and keys.size == 8
    assert keys.usages[0] == 0x70000 and keys.usages[-1] == 0x70065 and len(keys.usages) == 0x66
    leds = out.fields[0]
    assert leds.usages == tuple(0x80000 + i for i in range(1, 6))
    report = bytes([0x02, 0x00, 0x04, 0x05, 0, 0, 0, 0])  # left shift, 'a', 'b'
    values = report_values(d, report)
    assert values[0x700E1] == 1 and values[0x700E0] == 0
    assert values[0x70004] is True and values[0x70005] is True
    assert 0x70006 not in values


def test_item_splitting_short_and_long():
    data = bytes.fromhex("05 0d fe 03 42 aa bb cc 27 ff ff 00 00")
    items = iter_items(data)
    assert [(i.offset, i.type, i.tag, i.data) for i in items] == [
        (0, ItemType.GLOBAL, 0, b"\x0d"),
        (2, ItemType.LONG, 0x42, b"\xaa\xbb\xcc"),
        (8, ItemType.GLOBAL, 2, b"\xff\xff\x00\x00"),
    ]
    assert items[2].unsigned == 0xFFFF and items[2].signed == 0xFFFF
    assert items[1].name == "Long Item 0x42" and items[0].name == "Usage Page"


def test_long_item_is_tolerated_with_a_warning():
    raw = BOOT_MOUSE[:4] + bytes([0xFE, 0x02, 0x10, 0x01, 0x02]) + BOOT_MOUSE[4:]
    d = parse_descriptor(raw)
    assert len(d.fields) == 3
    assert any("long item" in w for w in d.warnings)


@pytest.mark.parametrize(
    ("item", "expected"),
    [
        (b"\x15\x81", -127),  # 1-byte logical minimum is signed
        (b"\x16\x80\x00", 128),  # 2-byte 0x0080 is +128
        (b"\x16\x00\x80", -32768),
        (b"\x17\xff\xff\xff\xff", -1),
    ],
)
def test_logical_minimum_is_signed(item, expected):
    raw = b"\x05\x01\x09\x30" + item + b"\x25\x00\x75\x08\x95\x01\x81\x02"
    (f,) = parse_descriptor(raw).fields
    assert f.logical_min == expected


def test_logical_maximum_signedness_follows_minimum():
    unsigned = parse_descriptor(b"\x09\x30\x15\x00\x25\xff\x75\x08\x95\x01\x81\x02").fields[0]
    assert unsigned.logical_max == 255 and not unsigned.signed
    signed = parse_descriptor(b"\x09\x30\x15\x80\x25\x7f\x75\x08\x95\x01\x81\x02").fields[0]
    assert (signed.logical_min, signed.logical_max) == (-128, 127) and signed.signed
    phys = parse_descriptor(b"\x09\x30\x35\xc4\x46\x3c\x00\x75\x08\x95\x01\x81\x02").fields[0]
    assert (phys.physical_min, phys.physical_max) == (-60, 60)
    phys_u = parse_descriptor(b"\x09\x30\x35\x00\x45\xf0\x75\x08\x95\x01\x81\x02").fields[0]
    assert phys_u.physical_max == 240


@pytest.mark.parametrize(
    ("raw", "exponent"),
    [(0x0E, -2), (0x0D, -3), (0x08, -8), (0x07, 7), (0x00, 0), (-2, -2), (-20, -20), (20, 20)],
)
def test_unit_exponent_nibble(raw, exponent):
    assert decode_unit_exponent(raw) == exponent


def test_unit_exponent_items():
    nibble = parse_descriptor(b"\x09\x30\x55\x0e\x75\x08\x95\x01\x81\x02").fields[0]
    assert nibble.unit_exponent == -2
    wide = parse_descriptor(b"\x09\x30\x56\xfd\xff\x75\x08\x95\x01\x81\x02").fields[0]
    assert wide.unit_exponent == -3


def test_unit_decoding():
    cm = Unit.decode(0x11)
    assert (cm.system, cm.length, cm.mass, cm.time) == (1, 1, 0, 0)
    per_second = Unit.decode(0xF011)  # cm / s: time exponent -1
    assert (per_second.length, per_second.time) == (1, -1)
    assert Unit.decode(0x14).system == 4


def test_report_ids_offsets_and_lengths():
    d = parse_descriptor(ntrig_like_descriptor())
    assert d.numbered
    rep = d.report(ReportType.INPUT, 2)
    assert rep is not None
    offsets = {f.usages[0]: (f.bit_offset, f.size) for f in rep.fields if f.usages}
    assert offsets[U.GD_X] == (8, 15)
    assert offsets[U.GD_Y] == (23, 15)
    assert offsets[U.DG_TIP_PRESSURE] == (40, 10)
    assert offsets[U.DG_X_TILT] == (50, 7)
    assert offsets[U.DG_Y_TILT] == (57, 7)
    assert offsets[U.DG_TWIST] == (64, 9)
    assert offsets[U.DG_TRANSDUCER_SERIAL] == (73, 32)
    assert rep.bits == 105 and rep.length(True) == 1 + 14


def test_push_pop_restore_globals():
    d = parse_descriptor(ntrig_like_descriptor())
    rep = d.report(ReportType.INPUT, 2)
    assert rep is not None
    by_usage = {f.usages[0]: f for f in rep.fields if f.usages}
    tilt = by_usage[U.DG_X_TILT]
    twist = by_usage[U.DG_TWIST]
    assert tilt.unit == 0x14 and (tilt.physical_min, tilt.physical_max) == (-60, 60)
    # the tilt's physical range was pushed/popped: the twist does not inherit -60
    assert (twist.physical_min, twist.physical_max) == (0, 359)
    assert by_usage[U.DG_TIP_PRESSURE].unit == 0


def test_usage_page_after_usages_applies_to_them():
    # Usage (0x30) declared while the page is Button, then Usage Page (Generic Desktop)
    raw = b"\x05\x09\x09\x30\x09\x31\x05\x01\x15\x00\x25\x7f\x75\x08\x95\x02\x81\x02"
    (f,) = parse_descriptor(raw).fields
    assert f.usages == (U.GD_X, U.GD_Y)


def test_extended_usage_keeps_its_page():
    raw = b"\x05\x01\x0b\x42\x00\x0d\x00\x09\x30\x15\x00\x25\x01\x75\x01\x95\x02\x81\x02"
    (f,) = parse_descriptor(raw).fields
    assert f.usages == (U.DG_TIP_SWITCH, U.GD_X)


def test_variable_slots_repeat_last_usage():
    raw = b"\x05\x09\x09\x01\x09\x02\x15\x00\x25\x01\x75\x01\x95\x04\x81\x02"
    (f,) = parse_descriptor(raw).fields
    assert f.usages == (0x90001, 0x90002, 0x90002, 0x90002)


def test_delimiter_keeps_first_usage_set():
    raw = (b"\x05\x01\xa9\x01\x09\x30\xa9\x00\xa9\x01\x09\x31\xa9\x00"
           b"\x15\x00\x25\x7f\x75\x08\x95\x01\x81\x02")
    (f,) = parse_descriptor(raw).fields
    assert f.usages == (U.GD_X,)


def test_builder_descriptors_parse_with_expected_applications():
    for raw, app in ((pth660_like_descriptor(), U.DG_PEN), (huion_like_descriptor(), U.DG_PEN)):
        d = parse_descriptor(raw)
        assert d.application_usages()[0] == app
        assert d.warnings == []


def test_wacom_vendor_usage_equivalents():
    assert U.equivalent_usage(0xFF0D0042) == U.DG_TIP_SWITCH
    assert U.equivalent_usage(0xFF0D0130) == U.GD_X
    assert U.equivalent_usage(0xFF0D0131) == U.GD_Y
    assert U.equivalent_usage(U.WD_TOOL_TYPE) == U.WD_TOOL_TYPE
    assert U.equivalent_usage(U.WD_DISTANCE) == U.WD_DISTANCE
    assert U.equivalent_usage(0xFF0D1001) == 0xFF0D1001  # pad sub-page kept
    assert U.equivalent_usage(U.GD_X) == U.GD_X
    assert U.usage_name(U.DG_TIP_PRESSURE) == "Tip Pressure"
    assert U.usage_name(0xFF420001) == "0xff42:0001"  # a page no table names


# -- extraction --------------------------------------------------------------------


def test_extract_bits_little_endian_across_bytes():
    data = bytes([0xAB, 0xCD, 0xEF])
    assert extract_bits(data, 0, 8) == 0xAB
    assert extract_bits(data, 4, 12) == (0xEFCDAB >> 4) & 0xFFF == 0xCDA
    assert extract_bits(data, 20, 4) == 0xE
    assert extract_bits(data, 20, 4, signed=True) == 0xE - 16
    assert extract_bits(data, 3, 1) == 1 and extract_bits(data, 2, 1) == 0
    assert extract_bits(data, 16, 16) == 0xEF  # bits past the end read as 0


def test_field_values_signed_7_bit_tilt():
    d = parse_descriptor(ntrig_like_descriptor())
    rep = d.report(ReportType.INPUT, 2)
    assert rep is not None
    tilt = next(f for f in rep.fields if f.usages and f.usages[0] == U.DG_X_TILT)
    report = bytearray(15)
    report[0] = 2
    # write -45 as 7-bit two's complement at payload bit 50 (report bit 58)
    value = (-45) & 0x7F
    acc = int.from_bytes(report, "little") | (value << 58)
    report = bytearray(acc.to_bytes(15, "little"))
    assert field_values(d, tilt, bytes(report)) == [-45]


def test_report_values_checks_id_and_length():
    d = parse_descriptor(ntrig_like_descriptor())
    with pytest.raises(ReportError, match="unknown input report ID 9"):
        report_values(d, bytes([9] + [0] * 14))
    with pytest.raises(ReportError, match="is 14 bytes, the descriptor says 15"):
        report_values(d, bytes([2] + [0] * 13))
    with pytest.raises(ReportError):
        report_values(d, b"")


# -- resolution ---------------------------------------------------------------------


def _field_with(lo, hi, plo, phi, unit, exp):
    b = DescriptorBuilder().value(U.PAGE_GENERIC_DESKTOP, 0x30, 16, lo, hi, phys=(plo, phi),
                                  unit=unit, exponent=exp)  # fmt: skip
    return parse_descriptor(b.to_bytes()).fields[0]


def test_resolution_like_the_kernel():
    cm = _field_with(0, 44800, 0, 2240, 0x11, -2)  # 22.4 cm
    assert resolution(cm) == 200.0 and kernel_resolution(cm, angular=False) == 200
    inch = _field_with(0, 50800, 0, 10000, 0x13, -3)  # 10 inches
    assert resolution(inch) == 200.0 and kernel_resolution(inch, angular=False) == 200
    deg = _field_with(-60, 60, -60, 60, 0x14, 0)
    assert resolution(deg) == 1.0
    assert kernel_resolution(deg, angular=True) == 57  # units per radian, rounded
    rad = _field_with(0, 6283, 0, 6283, 0x12, -3)  # 0..2*pi rad in milliradians
    assert resolution(rad) == pytest.approx(1000 / 57.29577951308232, rel=1e-6)
    none = _field_with(0, 1000, 0, 0, 0x11, 0)
    assert resolution(none) is None and kernel_resolution(none, angular=False) == 0
    unitless = _field_with(0, 1000, 0, 100, 0, 0)
    assert resolution(unitless) is None
    assert kernel_resolution(cm, angular=True) == 0  # cm is not an angle


# -- errors ---------------------------------------------------------------------------


def _err(raw: bytes) -> DescriptorError:
    with pytest.raises(DescriptorError) as info:
        parse_descriptor(raw)
    assert isinstance(info.value, BadInput)
    return info.value


@pytest.mark.parametrize(
    ("raw", "offset", "text"),
    [
        (b"", 0, "empty"),
        (b"\x05\x01\x26\xff", 2, "declares 2 data bytes, only 1 remain"),
        (b"\x05\x01\x27\x01\x02", 2, "declares 4 data bytes"),
        (b"\x05\x01\xfe\x05\x10\x01", 2, "long item declares 5"),
        (b"\x05\x01\xfe\x05", 2, "long item header truncated"),
        (b"\x05\x01\xc0", 2, "End Collection without"),
        (b"\x09\x02\xa1\x01\x09\x01\xa1\x00\xc0", 9, "1 collection(s) left open"),
        (b"\x05\x01\xb4", 2, "Pop without a matching Push"),
        (b"\x85\x00", 0, "Report ID 0 out of range"),
        (b"\x86\x00\x01", 0, "Report ID 256 out of range"),
        (b"\x76\x01\x01", 0, "Report Size 257 bits is absurd"),
        (b"\x75\x08\x96\x00\x40\x81\x01", 5, "grows past 16383 bytes"),
        (b"\x19\x10\x29\x01", 2, "below Usage Minimum"),
        (b"\x19\x00\x2a\xff\xff", 2, "usage range of 65536 usages is absurd"),
        (b"\x29\x05", 0, "Usage Maximum without a Usage Minimum"),
        (b"\xa9\x01\xa9\x01", 2, "nested Delimiter"),
        (b"\xa9\x00", 0, "Delimiter close without"),
        (b"\xa9\x01\x09\x30", 4, "Delimiter set left open"),
    ],
)
def test_malformed_descriptors_name_the_offset(raw, offset, text):
    err = _err(raw)
    assert err.offset == offset
    assert text in str(err)
    assert f"descriptor byte {offset}" in str(err)


def test_push_and_collection_depth_limits():
    assert "Push nested deeper" in str(_err(b"\xa4" * 17))
    assert "nested deeper than 32" in str(_err(b"\xa1\x00" * 33 + b"\xc0" * 33))


def test_descriptor_too_long():
    raw = b"\x05\x01" * (MAX_DESCRIPTOR_BYTES // 2 + 1)
    assert "more than the 4096 allowed" in str(_err(raw))


def test_wide_constant_and_64_bit_serial_are_allowed():
    pad = parse_descriptor(b"\x75\x40\x95\x01\x81\x01")
    assert pad.fields[0].is_constant and pad.fields[0].size == 64
    serial = parse_descriptor(b"\x05\x0d\x09\x5b\x75\x40\x95\x01\x81\x02")
    assert serial.fields[0].size == 64 and serial.fields[0].flags == FLAG_VARIABLE
    assert FLAG_CONSTANT == 1


def test_fields_before_first_report_id_warned():
    raw = b"\x09\x30\x75\x08\x95\x01\x81\x02\x85\x02\x09\x31\x81\x02"
    d = parse_descriptor(raw)
    assert d.numbered and {f.report_id for f in d.fields} == {0, 2}
    assert any("unreachable" in w for w in d.warnings)


def test_extreme_unit_exponents_do_not_overflow_or_hang():
    for exp_item in (b"\x57\xff\xff\xff\x7f", b"\x57\x00\x00\x00\x80", b"\x55\x7f"):
        raw = (b"\x05\x01\x09\x30\x15\x00\x26\xff\x0f\x35\x00\x46\xff\x0f\x65\x11" + exp_item
               + b"\x75\x10\x95\x01\x81\x02")  # fmt: skip
        (f,) = parse_descriptor(raw).fields
        assert abs(f.unit_exponent) >= 100
        assert resolution(f) is None
        assert kernel_resolution(f, angular=False) == 0


def test_format_items_listing():
    from station.drivers.hid.descriptor import format_items

    lines = format_items(BOOT_MOUSE)
    assert len(lines) == 26
    assert lines[0] == "   0: 05 01           Usage Page (0x1)"
    assert lines[2] == "   4: a1 01           Collection (Application)"
    assert lines[3] == "   6: 09 01             Usage (0x1)"
    assert lines[12].endswith("    Input (Data, Var, Abs)")
    assert lines[18].endswith("      Usage (0x31)")
    assert lines[19].endswith("      Logical Minimum (-127)")
    assert lines[-1] == "  49: c0              End Collection"
    broken = format_items(b"\x05\x01\x26\xff")
    assert broken[0].startswith("   0: 05 01") and broken[-1].startswith("2: error:")
