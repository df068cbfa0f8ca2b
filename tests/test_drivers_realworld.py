"""Regressions for quirks of REAL tablets and REAL trace files (see docs/drivers-protocols.md,
"Real-world captures checked").

Each test is a minimal snippet written here from the HID spec, the kernel's
behaviour or the trace formats' documentation; it reproduces the *structure*
that broke (or could break) the drivers on a real capture, not the capture.
Descriptors are spelled out byte by byte with the item they encode.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from station.drivers.evdev import codes as c
from station.drivers.evdev.frames import AbsInfo, EvdevCaps, FrameAssembler, InputEvent
from station.drivers.hid import usages as U
from station.drivers.hid.descriptor import (
    ReportType,
    parse_descriptor,
    report_values,
    resolution,
)
from station.drivers.hid.errors import DescriptorError, ReportError
from station.drivers.hid.pen import GenericPenParser, compile_plan
from station.drivers.pipeline import TraceReplay
from station.drivers.registry import interface_from_phys, parser_for
from station.drivers.traces import read_trace, trace_format
from station.drivers.traces.evemu import parse_evemu
from station.drivers.traces.hidrecorder import parse_hid_recorder
from station.drivers.traces.libinput_record import parse_libinput_record
from station.drivers.wacom.bamboo import BambooParser
from station.drivers.wacom.common import WacomParams

from station.cli import main
from station.events import Button, Tool


def hexd(text: str) -> bytes:
    """Descriptor bytes from hex with ``;`` comments (one item per line below)."""
    return bytes.fromhex(" ".join(line.split(";")[0] for line in text.splitlines()))


# A small pen application: tip, barrel, eraser, invert, in range bits, X, Y, pressure.
PEN_APP = """
05 0d        ; Usage Page (Digitizer)
09 02        ; Usage (Pen)
a1 01        ; Collection (Application)
85 07        ;   Report ID (7)
09 20        ;   Usage (Stylus)
a1 00        ;   Collection (Physical)
09 42 09 44 09 45 09 3c 09 32  ; Tip, Barrel, Eraser, Invert, In Range
15 00 25 01 75 01 95 05 81 02  ;   5 x 1-bit Input (Var)
95 03 81 03  ;     3 bits padding
05 01 09 30 09 31              ; X, Y
26 ff 7f 75 10 95 02 81 02     ;   0..32767, 16 bits x 2
05 0d 09 30 26 ff 0f 95 01 81 02  ; Tip Pressure 0..4095
c0 c0
"""


def pen_report(x: int, y: int, pressure: int, tip: bool = False, in_range: bool = True,
               eraser: bool = False, invert: bool = False, barrel: bool = False) -> bytes:
    bits = tip | barrel << 1 | eraser << 2 | invert << 3 | in_range << 4
    return bytes([7, bits]) + x.to_bytes(2, "little") + y.to_bytes(2, "little") + \
        pressure.to_bytes(2, "little")


# -- descriptor limits as the kernel has them -----------------------------------------------------

def test_vendor_input_report_longer_than_4_kib_keeps_the_pen() -> None:
    # ELAN I2C screens (04f3:2fc4) declare vendor input reports of 7487 bytes next to the pen.
    vendor = """
    06 0b ff 09 0b a1 01   ; Usage Page (0xff0b), Usage, Collection (Application)
    75 08 15 00 26 ff 00   ;   8-bit bytes
    09 36 85 36 96 3f 1d   ;   Usage, Report ID (54), Report Count (7487)
    81 02 c0               ;   Input (Var), End Collection
    """
    desc = parse_descriptor(hexd(PEN_APP + vendor))
    assert desc.report(ReportType.INPUT, 54).length(True) == 7488
    parser = GenericPenParser(desc)
    assert parser.is_pen and parser.pen_report_ids == [7]
    (raw,) = parser.parse(pen_report(1000, 2000, 300, tip=True), 0.0)
    assert (raw.x, raw.y, raw.pressure, raw.tip) == (1000, 2000, 300, True)
    assert parser.parse(bytes([54]) + bytes(7487), 0.1) == []  # vendor blob: skipped
    # The kernel's buffer is 16 KiB: a report past that is still refused, with its offset.
    too_big = hexd("75 08 97 00 40 00 00 81 02")  # Report Count 16384 bytes
    with pytest.raises(DescriptorError, match="grows past 16383 bytes"):
        parse_descriptor(too_big)


def test_wide_vendor_fields_are_opaque_not_absurd() -> None:
    # Huion (256c:2009) interface 0: one 104-bit vendor field; Keydials use 88 bits.
    huion_vendor = hexd("""
    06 00 ff 09 01 a1 01   ; Vendor page, Collection (Application)
    85 08 75 68 95 01      ;   Report ID (8), Report Size (104), Report Count (1)
    09 01 81 02 c0         ;   Input (Var)
    """)
    desc = parse_descriptor(huion_vendor)
    (field,) = desc.report(ReportType.INPUT, 8).fields
    assert field.size == 104 and field.is_opaque
    assert any("opaque" in w for w in desc.warnings)
    assert report_values(desc, bytes([8]) + bytes(range(13))) == {}
    assert not GenericPenParser(desc).is_pen
    with pytest.raises(DescriptorError, match="Report Size 257 bits is absurd"):
        parse_descriptor(hexd("76 01 01"))


def test_unknown_device_with_only_a_vendor_interface_is_skipped_with_a_reason(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pen = hexd(PEN_APP)
    text = ("D: 0\nR: 18 06 00 ff 09 01 a1 01 85 08 75 68 95 01 09 01 81 02 c0\n"
            "N: HUION Huion Tablet\nI: 3 256c 6d\n"
            f"D: 1\nR: {len(pen)} {pen.hex(' ')}\nN: HUION Huion Tablet\nI: 3 256c 6d\n")
    text += "D: 0\nE: 000000.000000 14 08" + " 00" * 13 + "\n"
    text += "D: 1\nE: 000000.001000 7 07 11 10 00 20 00 00 00\n".replace(" 7 ", " 8 ")
    path = tmp_path / "huion.hid"
    path.write_text(text)
    assert main(["replay", str(path), "--jsonl", str(tmp_path / "o.jsonl")]) == 0
    err = capsys.readouterr().err
    assert "skipped device 0" in err and "no pen collection" in err
    rows = [json.loads(line) for line in (tmp_path / "o.jsonl").read_text().splitlines()[1:]]
    assert len(rows) >= 1 and rows[0]["x"] == pytest.approx(16 / 32767)


# -- proximity rules seen on real pens ----------------------------------------------------------

WACOM_SENSE_PEN = """
06 0d ff 09 01 a1 01   ; Wacom vendor digitizer page 0xff0d, Collection (Application)
85 10 09 20 a1 00      ;   Report ID (16), Stylus, Collection (Physical)
09 42 09 32 09 36 09 5d ; Tip, In Range, Wacom Sense (0x36), Barrel Switch 3 (0x5d)
15 00 25 01 75 01 95 04 81 02 95 04 81 03
0a 30 01 0a 31 01      ;   X, Y as Wacom sub-page 0x01 usages (0xff0d0130, 0xff0d0131)
26 ff 7f 75 10 95 02 81 02
09 30 26 ff 1f 95 01 81 02  ; Tip Pressure 0..8191
c0 c0
"""


def wacom_report(x: int, y: int, p: int, tip: bool, in_range: bool, sense: bool,
                 barrel3: bool = False) -> bytes:
    bits = tip | in_range << 1 | sense << 2 | barrel3 << 3
    return bytes([16, bits]) + x.to_bytes(2, "little") + y.to_bytes(2, "little") + \
        p.to_bytes(2, "little")


@pytest.mark.parametrize("compiled", [True, False])
def test_wacom_sense_without_in_range_is_proximity_without_data(compiled: bool) -> None:
    # Kernel wacom_wac_pen_report: Sense = tool near, In Range = data valid.
    parser = GenericPenParser(parse_descriptor(hexd(WACOM_SENSE_PEN)))
    plan = parser.plans[16]
    decode = compile_plan(plan) if compiled else (lambda r, t: parser.decode(plan, r, t))
    assert decode is not None
    far = decode(wacom_report(0, 0, 0, False, False, True), 0.0)
    assert far.proximity and not far.valid
    near = decode(wacom_report(500, 600, 0, False, True, True, barrel3=True), 0.0)
    assert near.proximity and near.valid and near.buttons == int(Button.STYLUS3)
    gone = decode(wacom_report(0, 0, 0, False, False, False), 0.0)
    assert not gone.proximity


@pytest.mark.parametrize("compiled", [True, False])
def test_in_range_dropping_while_the_tip_moves_keeps_the_pen_in(compiled: bool) -> None:
    # Goodix GXTP (27c6:0113): In Range reads 0 while the tip is down and moving.
    parser = GenericPenParser(parse_descriptor(hexd(PEN_APP)))
    plan = parser.plans[7]
    decode = compile_plan(plan) if compiled else (lambda r, t: parser.decode(plan, r, t))
    assert decode is not None
    moving = decode(pen_report(3000, 3000, 900, tip=True, in_range=False), 0.0)
    assert moving.proximity and moving.valid and moving.tip
    eraser = decode(pen_report(3000, 3000, 900, eraser=True, in_range=False), 0.0)
    assert eraser.proximity and eraser.tool == Tool.ERASER
    lifted = decode(pen_report(3000, 3000, 0, in_range=False), 0.0)
    assert not lifted.proximity


def test_a_stroke_with_in_range_dropouts_stays_one_stroke(tmp_path: Path) -> None:
    lines = [f"R: {len(hexd(PEN_APP))} {hexd(PEN_APP).hex(' ')}", "N: GXTP7386:00 27C6:0113",
             "I: 18 27c6 0113"]
    t = 10.0
    for i in range(20):
        tip = 3 <= i < 17
        rep = pen_report(1000 + 100 * i, 1000, 2000 if tip else 0, tip=tip,
                         in_range=not (tip and i % 2))
        lines.append(f"E: {t:.6f} {len(rep)} {rep.hex(' ')}")
        t += 0.005
    rep = pen_report(0, 0, 0, in_range=False)
    lines.append(f"E: {t:.6f} {len(rep)} {rep.hex(' ')}")
    path = tmp_path / "gxtp.hid"
    path.write_text("\n".join(lines) + "\n")
    samples = list(TraceReplay(read_trace(path)).samples())
    assert [s.proximity for s in samples].count(False) == 1  # one proximity-out, at the end
    touching = [s.touching for s in samples]
    assert sum(touching) == 14 and touching[3:17] == [True] * 14


# -- Wacom vendor usages and protocol reports as the kernel has them -------------------------------

def test_wacom_vendor_usages_follow_the_kernel() -> None:
    assert U.WD_BARREL_SWITCH3 == 0xFF0D005D
    assert U.equivalent_usage(0xFF0D005D) == 0xFF0D005D  # kept, not Digitizer 0x5d
    assert U.equivalent_usage(0xFF0D0130) == U.GD_X
    assert U.equivalent_usage(0xFF0D0042) == U.DG_TIP_SWITCH
    assert U.equivalent_usage(0xFF0D0410) == 0xFF0D0410  # pad sub-page 0x04 stays Wacom's
    assert U.equivalent_usage(0xFF0D0138) == 0xFF0D0138  # touch ring is not GD Wheel
    assert U.equivalent_usage(0xFF0D1130) == 0x00110030  # sub-page 0x11 is not special


def test_intuos_ht_touch_switch_report_192_is_not_a_bad_report() -> None:
    # Kernel wacom_bpt_pen: report 192 (WACOM_REPORT_USB) carries the touch on/off switch.
    params = WacomParams(15200, 9500, 1023, 31, 100.0, 100.0)
    parser = BambooParser(params)
    assert parser.parse(bytes([192, 0, 0, 0, 0, 0, 0, 0, 0x40, 0]), 0.0) == []
    assert parser.skipped_by_kind["status"] == 1
    with pytest.raises(ReportError):
        parser.parse(bytes([0x37]) + bytes(9), 0.0)


def test_wacom_touch_interface_is_ignored_by_its_frame_length_and_by_its_path() -> None:
    touch = hexd("""
    06 00 ff 09 01 a1 01 85 02  ; vendor application, Report ID (2)
    75 08 95 3f 15 00 26 ff 00 09 01 81 02 c0  ; 63 bytes: a 64-byte touch frame
    """)
    parser = parser_for(0x056A, 0x0315, touch)
    assert not parser.is_pen and parser.kind == "touch"
    pen = hexd("06 00 ff 09 01 a1 01 85 02 75 08 95 09 15 00 26 ff 00 09 01 81 02 c0")
    assert parser_for(0x056A, 0x0315, pen).is_pen
    assert interface_from_phys("usb-0000:00:14.0-2/input1") == 1
    assert interface_from_phys("i2c-WCOM508E:00") is None
    by_number = parser_for(0x056A, 0x0315, pen, interface=interface_from_phys("usb-x-2/input1"))
    assert not by_number.is_pen


def test_generic_report_longer_than_declared_reads_the_declared_fields() -> None:
    parser = GenericPenParser(parse_descriptor(hexd(PEN_APP)))
    (raw,) = parser.parse(pen_report(10, 20, 30, tip=True) + b"\xaa\xbb", 0.0)
    assert (raw.x, raw.y, raw.pressure) == (10, 20, 30) and parser.long_reports == 1
    with pytest.raises(ReportError, match="is 7 bytes, the descriptor says 8"):
        parser.parse(pen_report(10, 20, 30)[:7], 0.0)


# -- descriptor structures from real pens ----------------------------------------------------------

def test_pop_restores_the_usage_page_before_tip_pressure() -> None:
    # XP-Pen Artist (28bd:093a): Push on the Digitizer page, X/Y on Desktop, Pop, then 09 30.
    desc = parse_descriptor(hexd("""
    05 0d 09 02 a1 01 85 07 09 20 a1 00
    09 42 09 32 15 00 25 01 75 01 95 02 81 02 95 06 81 03
    75 10 95 01 35 00 a4     ; Push (usage page Digitizer saved)
    05 01 09 30 65 13 55 0d 46 f0 50 26 ff 7f 81 02  ; X: inch, exponent -3, 20.72 in
    09 31 46 91 2d 26 ff 7f 81 02
    b4                       ; Pop: back to the Digitizer page, no unit
    09 30 45 00 26 ff 1f 81 42  ; Tip Pressure (Null State)
    09 3d 15 81 25 7f 75 08 81 02 09 3e 81 02  ; tilt -127..127, no unit
    c0 c0
    """))
    parser = GenericPenParser(desc)
    r = parser.ranges
    assert r.pressure is not None and r.pressure.maximum == 8191 and r.pressure.resolution is None
    assert r.x.resolution == pytest.approx(32767 / (20.72 * 25.4), rel=1e-6)
    assert r.tilt_x is not None and (r.tilt_x.minimum, r.tilt_x.maximum) == (-127, 127)
    (raw,) = parser.parse(bytes([7, 3, 0x10, 0x27, 0x20, 0x4e, 0x00, 0x10, 0x81, 0x7f]), 0.0)
    assert (raw.x, raw.y, raw.pressure, raw.tilt_x, raw.tilt_y) == (10000, 20000, 4096, -127, 127)


def test_count_two_with_one_usage_and_report_id_inside_the_stylus_collection() -> None:
    # Atmel (03eb:840b): X declared with Report Count 2 and one usage (X, X), same for Y.
    # Goodix USI (27c6:0e00): the Report ID item comes after Collection (Physical) opens.
    desc = parse_descriptor(hexd("""
    05 0d 09 02 a1 01 09 20 a1 00 85 03   ; Report ID inside the Stylus collection
    15 00 25 01 75 01 95 01 09 42 81 02 09 32 81 02 95 06 81 03
    05 01 75 10 95 02 26 ff 0f 09 30 81 02 26 ff 0f 09 31 81 02  ; X,X then Y,Y
    05 0d 09 30 15 01 26 ff 00 75 08 95 01 81 02  ; Tip Pressure 1..255
    c0 c0
    """))
    parser = GenericPenParser(desc)
    assert parser.pen_report_ids == [3] and parser.lengths[3] == 11
    rep = bytes([3, 3]) + (100).to_bytes(2, "little") * 2 + (200).to_bytes(2, "little") * 2
    rep += b"\x80"
    (raw,) = parser.parse(rep, 0.0)
    assert (raw.x, raw.y, raw.pressure, raw.tip) == (100, 200, 128, True)
    assert parser.ranges.pressure is not None and parser.ranges.pressure.minimum == 1


def test_nested_application_inch_cubed_unit_and_centidegree_tilt() -> None:
    # Huion Kamvas (256c:006b): the Stylus is a nested *Application* collection and X/Y say
    # "in^3" (unit 0x33): no length unit, so no resolution (the kernel reports 0 too).
    huion = parse_descriptor(hexd("""
    05 0d 09 02 a1 01 85 0a 09 20 a1 01     ; Collection (Application) inside the Pen app
    09 42 09 32 15 00 25 01 75 01 95 02 81 02 95 06 81 03
    05 01 09 30 09 31 55 0d 65 33 26 ff 7f 35 00 46 00 08 75 10 95 02 81 02
    c0 c0
    """))
    parser = GenericPenParser(huion)
    assert parser.is_pen and parser.ranges.x.resolution is None
    assert not parser.ranges.has_resolution
    # ELAN 04f3:2fc4 tilt: unit Degrees, exponent -2, -9000..9000 -> 100 units per degree.
    elan = parse_descriptor(hexd("""
    05 0d 09 02 a1 01 85 07 09 20 a1 00 09 42 09 32 15 00 25 01 75 01 95 02 81 02
    95 06 81 03 05 01 09 30 09 31 26 ff 7f 75 10 95 02 81 02
    05 0d 09 3d 65 14 55 0e 36 d8 dc 46 28 23 16 d8 dc 26 28 23 95 01 81 02
    c0 c0
    """))
    tilt = next(f for f in elan.fields if U.DG_X_TILT in f.usages)
    assert resolution(tilt) == pytest.approx(100.0)


def test_usi_64_bit_serial_with_a_small_logical_range_reads_unsigned() -> None:
    # USI pens (Elan 04f3:2a49) declare Transducer Serial Number as 64 bits with the logical
    # range left at 1..255 from an earlier item: the value is an identifier, read unsigned.
    desc = parse_descriptor(hexd("""
    05 0d 09 02 a1 01 85 07 09 20 a1 00 09 42 09 32 15 00 25 01 75 01 95 02 81 02
    95 06 81 03 05 01 09 30 09 31 26 ff 7f 75 10 95 02 81 02
    05 0d 15 01 25 ff 09 5b 75 40 95 01 81 02  ; serial: 64 bits, logical 1..255
    c0 c0
    """))
    serial = 0xF123456789ABCDEF
    (raw,) = GenericPenParser(desc).parse(bytes([7, 2, 1, 0, 2, 0]) + serial.to_bytes(8, "little"),
                                          0.0)
    assert raw.serial == serial


# -- trace files as the tools write them -----------------------------------------------------------

def test_hid_recorder_descriptor_wrapped_onto_several_lines(tmp_path: Path) -> None:
    desc = hexd(PEN_APP)
    first, rest = desc[:24], desc[24:]
    text = (f"# pasted from a bug report\nR: {len(desc)} {first.hex(' ')}\n"
            f"{rest[:30].hex(' ')}\n{rest[30:].hex(' ')}\nN: pen\nI: 3 1234 5678\n"
            f"E: 0.000000 8 {pen_report(5, 6, 7).hex(' ')}\n")
    (dev,) = parse_hid_recorder(text.splitlines(), "wrapped.hid").devices
    assert dev.descriptor == desc and len(dev.reports) == 1
    short = text.replace(f"{rest[30:].hex(' ')}\n", "")
    from station.drivers.traces import TraceError

    with pytest.raises(TraceError, match=f"says {len(desc)} bytes") as info:
        parse_hid_recorder(short.splitlines(), "short.hid")
    assert info.value.where == "short.hid:2"


def test_new_hid_recorder_layout_and_sniffing_past_a_long_comment_header(tmp_path: Path) -> None:
    desc = hexd(PEN_APP)
    lines = ["# HUION Huion Tablet", f"# Report descriptor length: {len(desc)} bytes"]
    lines += [f"# 0x{b:02x},   // item {i}" for i, b in enumerate(desc * 20)]  # long dump
    lines += ["#   ┅ ░ comment lines in UTF-8", "D: 0", f"R: {len(desc)} {desc.hex(' ')}",
              "N: HUION Huion Tablet", "P: usb-0000:00:14.0-3/input1",
              "I: 3 256c 69"]  # hid-recorder >= 0.8 writes ids without zero padding
    lines += ["# Recorded events below in format:",
              "# E: <seconds>.<microseconds> <length-in-bytes> [bytes ...]"]
    for i in range(5):
        lines.append(f"# ReportID: 7 / Tip Switch: {int(i < 4)} | ...")
        lines.append(f"E: 000512.{8300 * i:06d} 8 "
                     f"{pen_report(100 * i, 50, 400, tip=i < 4, in_range=i < 4).hex(' ')}")
    path = tmp_path / "capture.txt"  # no telling suffix
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    assert trace_format(path) == "hid-recorder"
    (dev,) = read_trace(path).devices
    assert (dev.vid, dev.pid, dev.phys[-7:]) == (0x256C, 0x69, "/input1")
    assert [r.time for r in dev.reports][:2] == [512.0, 512.0083]


EVEMU_INTUOS4_OLD_KERNEL = """\
# EVEMU 1.3
# Kernel: 2.6.35
# Input device name: "Wacom Intuos4 6x9"
# Input device ID: bus 0x03 vendor 0x56a product 0xb9 version 0x104
N: Wacom Intuos4 6x9
I: 0003 056a 00b9 0104
P: 00 00 00 00 00 00 00 00
B: 00 0b 00 00 00 00 00 00 00
B: 01 00 00 00 00 00 00 00 00
B: 01 00 00 00 00 00 00 00 00
B: 01 00 00 00 00 00 00 00 00
B: 01 00 00 00 00 00 00 00 00
B: 01 ff 01 00 00 00 00 00 00
B: 01 ff 1c 00 00 00 00 00 00
B: 01 00 00 00 00 00 00 00 00
B: 01 00 00 00 00 00 00 00 00
B: 03 03 00 00 03 00 00 00 00
B: 03 00 00 00 00 00 00 00 00
B: 04 01 00 00 00 00 00 00 00
A: 00 0 44704 4 0 0
A: 01 0 27940 4 0 0
A: 18 0 2047 0 0 0
A: 19 0 63 0 0 0
A: 1a 0 127 0 0 0
A: 1b 0 127 0 0 0
A: 28 0 0 0 0 0
################################
#      Waiting for events      #
################################
E: 0.000001 0003 0000 32329\t# EV_ABS / ABS_X
E: 0.000001 0003 0001 17794
E: 0.000001 0003 001a 0061
E: 0.000001 0003 0028 2058
E: 0.000001 0001 0141 0001\t# EV_KEY / BTN_TOOL_RUBBER 1
E: 0.000001 0004 0000 -1719661676\t# EV_MSC / MSC_SERIAL (a u32 printed as s32)
E: 0.000001 0000 0000 0000\t# ------------ SYN_REPORT (0) ---------- +0ms
E: 0.008000 0001 0107 0001\t# BTN_7 1 (a pad button: same node on old kernels)
E: 0.008000 0001 0145 0001\t# BTN_TOOL_FINGER 1
E: 0.008000 0003 0028 0015\t# ABS_MISC 15 (PAD_DEVICE_ID)
E: 0.008000 0004 0000 -001\t# MSC_SERIAL -1
E: 0.008000 0000 0000 0000
E: 0.016000 0003 0000 32446
E: 0.016000 0003 0018 1084
E: 0.016000 0001 014a 0001
E: 0.016000 0000 0000 0000
E: 0.024000 0003 0018 0000
E: 0.024000 0001 014a 0000
E: 0.024000 0000 0000 0000
E: 0.032000 0003 0000 0000
E: 0.032000 0003 0028 0000
E: 0.032000 0001 0141 0000
E: 0.032000 0004 0000 -1719661676
E: 0.032000 0000 0000 0000
"""


def test_evemu_record_of_an_old_kernel_with_the_pad_on_the_pen_node() -> None:
    trace = parse_evemu(EVEMU_INTUOS4_OLD_KERNEL.splitlines(), "i4.evemu")
    (dev,) = trace.devices
    caps = dev.caps
    assert caps is not None and caps.name == "Wacom Intuos4 6x9"
    # 13 'B: 01' lines concatenate into one key mask (evemu writes 8 bytes a line)
    assert {c.BTN_TOOL_PEN, c.BTN_TOOL_RUBBER, c.BTN_TOOL_FINGER, c.BTN_TOUCH} <= caps.keys
    assert {0x100, 0x107} <= caps.keys and caps.absinfo[c.ABS_MISC].maximum == 0
    replay = TraceReplay(trace)
    samples = list(replay.samples())
    serial = (-1719661676) & 0xFFFFFFFF
    assert {s.serial for s in samples} == {serial}  # the pad's -1 never leaks into the pen
    assert {s.tool for s in samples} == {Tool.ERASER}
    assert {s.tool_id for s in samples} == {2058}
    assert [s.touching for s in samples] == [False, True, False, False]
    assert not samples[-1].proximity and samples[-1].x == samples[-2].x > 0.7  # not 0,0
    (drv,) = replay.drivers
    assembler = drv.source.assembler
    assert assembler.stats.pad_frames == 1


def test_pad_frame_inside_a_stroke_does_not_touch_the_pen_state() -> None:
    keys = frozenset({c.BTN_TOOL_PEN, c.BTN_TOOL_FINGER, c.BTN_TOUCH, 0x100})
    caps = EvdevCaps("old wacom", {c.ABS_X: AbsInfo(0, 1000), c.ABS_Y: AbsInfo(0, 1000),
                                   c.ABS_MISC: AbsInfo(0, 0), c.ABS_WHEEL: AbsInfo(0, 71)},
                     keys, msc=frozenset({c.MSC_SERIAL}))
    fa = FrameAssembler(caps)
    events = [(3, c.ABS_X, 500), (1, c.BTN_TOOL_PEN, 1), (3, c.ABS_MISC, 0x802), (4, 0, 77),
              (0, 0, 0),
              (1, 0x100, 1), (3, c.ABS_WHEEL, 30), (3, c.ABS_MISC, 15), (4, 0, -1), (0, 0, 0),
              (3, c.ABS_X, 510), (0, 0, 0)]
    out = [fa.feed(InputEvent(0.01 * i, *e)) for i, e in enumerate(events)]
    samples = [s for s in out if s is not None]
    assert len(samples) == 2
    assert [(s.x, s.serial, s.tool_id, s.wheel) for s in samples] == [(500, 77, 0x802, 0),
                                                                      (510, 77, 0x802, 0)]


LIBINPUT_RECORD = """\
# libinput record
version: 1
ndevices: 2
libinput:
  version: "1.22.1"
  git: "unknown"
system:
  os: "fedora:38"
  kernel: "6.2.9-300.fc38.x86_64"
  dmi: "dmi:bvnLENOVO:bvrN2HET70W"
devices:
- node: /dev/input/event14
  evdev:
    # Name: Wacom Intuos Pro M Pen
    # ID: bus 0x3 vendor 0x56a product 0x357 version 0x110
    name: "Wacom Intuos Pro M Pen"
    id: [3, 1386, 855, 272]
    codes:
      0: [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15] # EV_SYN
      1: [320, 321, 330, 331, 332] # EV_KEY
      3: [0, 1, 24, 26, 27, 40] # EV_ABS
      4: [0] # EV_MSC
    absinfo:
      0: [0, 44800, 4, 0, 200]
      1: [0, 29600, 4, 0, 200]
      24: [0, 8191, 0, 0, 0]
      26: [-64, 63, 0, 0, 57]
      27: [-64, 63, 0, 0, 57]
      40: [-2147483648, 2147483647, 0, 0, 0]
    properties: [0]
  hid: [5, 1, 9, 2, 161, 1, 133, 1, 9, 1, 161, 0, 192, 192]
  udev:
    properties:
    - ID_INPUT=1
    - ID_INPUT_TABLET=1
  quirks:
  - AttrPressureRange=100:50
  events:
  # Current time is 10:24:38
  - evdev:
    - [  0,      0,   3,   0,   22400] # EV_ABS / ABS_X   22400
    - [  0,      0,   3,   1,   14800] # EV_ABS / ABS_Y   14800
    - [  0,      0,   3,  26,      10]
    - [  0,      0,   3,  40,  526402]
    - [  0,      0,   1, 320,       1] # EV_KEY / BTN_TOOL_PEN 1
    - [  0,      0,   4,   0, -1960047337]
    - [  0,      0,   0,   0,       0] # ------------ SYN_REPORT (0) ---------- +0ms
    libinput:
    - {type: TABLET_TOOL_PROXIMITY, time: 0.0, proximity: in}
  - evdev:
    - [  0,   5000,   3,  24,    4000]
    - [  0,   5000,   1, 330,       1]
    - [  0,   5000,   0,   0,       0]
  - libinput:
    - {type: TABLET_TOOL_TIP, time: 0.005, tip: down}
  - hid:
      hidraw2: [ 0x10, 0x20, 0x00 ]  # `libinput record --with-hidraw` report, ignored
  - evdev:
    - [  0,  10000,   3,  24,       0]
    - [  0,  10000,   1, 330,       0]
    - [  0,  10000,   1, 320,       0]
    - [  0,  10000,   0,   0,       0]
- node: /dev/input/event3
  evdev:
    name: "AT Translated Set 2 keyboard"
    id: [17, 1, 1, 43841]
    codes:
      1: [1, 2, 3]
    absinfo:
    properties: []
  udev:
    properties:
    - ID_INPUT=1
    - ID_INPUT_KEYBOARD=1
  events:
"""


def test_libinput_record_with_every_section_of_a_real_recording() -> None:
    trace = parse_libinput_record(LIBINPUT_RECORD, "rec.yml")
    assert [d.name for d in trace.devices] == ["Wacom Intuos Pro M Pen",
                                               "AT Translated Set 2 keyboard"]
    pen, kbd = trace.devices
    assert pen.descriptor is not None and len(pen.descriptor) == 14 and not kbd.events
    replay = TraceReplay(trace)
    assert [s["device"] for s in replay.skipped] == [1]
    samples = list(replay.samples())
    assert [(s.proximity, s.touching) for s in samples] == [(True, False), (True, True),
                                                            (False, False)]
    first = samples[0]
    assert (first.x, first.y) == (0.5, 0.5)
    assert first.tilt_x == pytest.approx(10 * 180 / (57 * 3.141592653589793), rel=1e-6)
    assert first.serial == (-1960047337) & 0xFFFFFFFF and first.tool_id == 526402
    assert samples[1].pressure > 0 and samples[2].pressure == 0.0


def test_graphire4_mouse_distance_is_in_byte_6() -> None:
    # Kernel wacom_graphire_irq: WACOM_G4/WACOM_MO read the mouse distance from d[6] & 0x3f
    # (older Graphires from d[7] & 0x3f, where the G4 keeps its wheel and pad bits).
    g4 = parser_for(0x056A, 0x0015, None)
    older = parser_for(0x056A, 0x0081, None)
    assert g4.name == "wacom-graphire4" and older.name == "wacom-graphire"
    mouse = bytes([2, 0x80 | 0x40 | 0x01, 0x10, 0x00, 0x20, 0x00, 0x17, 0x2A])  # wheel mouse
    (a,) = g4.parse(mouse, 0.0)
    (b,) = older.parse(mouse, 0.0)
    assert a.tool == Tool.MOUSE and (a.distance, b.distance) == (0x17, 0x2A)
    pen = bytes([2, 0x80 | 0x01, 0x10, 0x00, 0x20, 0x00, 0x2C, 0x01])  # pressure 0x12c
    assert g4.parse(pen, 0.1)[0].pressure == older.parse(pen, 0.1)[0].pressure == 0x12C


def test_flipping_to_the_eraser_in_proximity_makes_the_pen_leave_first(tmp_path: Path) -> None:
    # Microsoft-style pens (N-trig, USI): Invert comes up while the pen is still in range.
    lines = [f"R: {len(hexd(PEN_APP))} {hexd(PEN_APP).hex(' ')}", "N: pen", "I: 18 1b96 0c01"]
    reps = [pen_report(100, 100, 0), pen_report(110, 100, 0), pen_report(120, 100, 0, invert=True),
            pen_report(130, 100, 500, eraser=True), pen_report(0, 0, 0, in_range=False)]
    lines += [f"E: {i * 0.005:.6f} 8 {r.hex(' ')}" for i, r in enumerate(reps)]
    path = tmp_path / "flip.hid"
    path.write_text("\n".join(lines) + "\n")
    samples = list(TraceReplay(read_trace(path)).samples())
    assert [(s.tool, s.proximity, s.touching) for s in samples] == [
        (Tool.PEN, True, False), (Tool.PEN, True, False), (Tool.PEN, False, False),
        (Tool.ERASER, True, False), (Tool.ERASER, True, True), (Tool.ERASER, False, False)]


def test_a_wacom_pad_node_is_not_a_pen() -> None:
    # `libinput record --all` / evemu of a Wacom: the pad node declares ABS_X/ABS_Y (0..1)
    # and BTN_STYLUS next to BTN_0…BTN_8 (kernel wacom_setup_pad_capabilities).
    from station.drivers.evdev.frames import is_pen_device

    xy = {c.ABS_X: AbsInfo(0, 1), c.ABS_Y: AbsInfo(0, 1), c.ABS_WHEEL: AbsInfo(0, 71),
          c.ABS_MISC: AbsInfo(0, 0)}
    pad = EvdevCaps("Wacom Intuos Pro M Pad", xy,
                    frozenset({c.BTN_STYLUS, *range(c.BTN_0, c.BTN_0 + 9)}))
    assert not is_pen_device(pad)
    pen_keys = frozenset({c.BTN_TOOL_PEN, c.BTN_TOUCH, c.BTN_STYLUS})
    assert is_pen_device(EvdevCaps("Wacom Intuos Pro M Pen", xy, pen_keys))
    # a pen that only says BTN_STYLUS (no BTN_TOOL_PEN) but has pressure stays a pen
    stylus_only = EvdevCaps("cheap pen", {**xy, c.ABS_PRESSURE: AbsInfo(0, 1023)},
                            frozenset({c.BTN_STYLUS, c.BTN_TOUCH, c.BTN_0}))
    assert is_pen_device(stylus_only)


def test_intuos_pro_pen_reports_of_16_bytes_are_read() -> None:
    # Intuos5 / Intuos Pro (056a:0314-0317) declare pen report 2 as 16 bytes; the kernel's
    # wacom_intuos_irq reads d[0..9] whatever the length. 64-byte frames are touch, report 192
    # is the USB/wireless status.
    from station.drivers import synth as S

    parser = parser_for(0x056A, 0x0315, None)
    pad = bytes(6)
    assert parser.parse(S.intuos_prox_in(0x802, 0x1234567) + pad, 0.0)[0].serial == 0x1234567
    (raw,) = parser.parse(S.intuos_pen(20000, 10000, 1500) + pad, 0.005)
    assert (raw.x, raw.y, raw.pressure, raw.tool) == (20000, 10000, 1500, Tool.PEN)
    assert parser.parse(bytes([2, 0x81]) + bytes(62), 0.01) == []  # touch frame
    assert parser.parse(bytes([192]) + bytes(9), 0.02) == []
    assert parser.skipped_by_kind == {"touch": 1, "status": 1}
    with pytest.raises(ReportError, match=r"is 17 bytes, expected 10\.\.16"):
        parser.parse(S.intuos_pen(1, 1, 1) + bytes(7), 0.03)


XPPEN_PEN = """
05 0d 09 02 a1 01 85 07 09 20 a1 00
09 42 09 44 09 45 09 3c 15 00 25 01 75 01 95 04 81 02  ; Tip, Barrel, Eraser, Invert
95 01 81 03 09 32 95 01 81 02 95 02 81 03            ; pad, In Range, pad
05 01 09 30 09 31 26 ff 7f 75 10 95 02 81 02         ; X, Y
05 0d 09 30 26 ff 3f 95 01 81 02 c0 c0                ; Tip Pressure
"""


def xppen_report(tip: int = 0, barrel: int = 0, eraser: int = 0, invert: int = 0,
                 pressure: int = 0) -> bytes:
    bits = tip | barrel << 1 | eraser << 2 | invert << 3 | 1 << 5
    return bytes([7, bits, 0x10, 0x27, 0x10, 0x27]) + pressure.to_bytes(2, "little")


def test_xppen_second_button_reported_as_eraser_is_a_button() -> None:
    # XP-Pen Artist Pro 16 Gen2 (28bd:095b) firmware, as the kernel's HID selftests emulate
    # it: the second barrel button sets Eraser; the eraser end sets Invert (+ Tip touching).
    parser = parser_for(0x28BD, 0x095B, hexd(XPPEN_PEN))
    (button,) = parser.parse(xppen_report(eraser=1), 0.0)
    assert button.buttons == int(Button.STYLUS2) and button.tool == Tool.PEN and not button.tip
    (erasing,) = parser.parse(xppen_report(tip=1, invert=1, pressure=900), 0.01)
    assert erasing.tool == Tool.ERASER and erasing.tip and erasing.pressure == 900
    # any other pen with the same descriptor: Eraser means the eraser touching
    (other,) = parser_for(0x1234, 0x5678, hexd(XPPEN_PEN)).parse(xppen_report(eraser=1), 0.0)
    assert other.tool == Tool.ERASER and other.tip
    # a descriptor the kernel already fixed (Secondary Barrel Switch declared) is read as is
    fixed = hexd(XPPEN_PEN.replace("09 42 09 44 09 45 09 3c", "09 42 09 44 09 5a 09 3c"))
    (fixed_button,) = parser_for(0x28BD, 0x095B, fixed).parse(xppen_report(eraser=1), 0.0)
    assert fixed_button.buttons == int(Button.STYLUS2)
    (fixed_eraser,) = parser_for(0x28BD, 0x095B, hexd(XPPEN_PEN.replace(
        "95 01 81 03 09 32", "09 5a 95 01 81 02 09 32"))).parse(
            bytes([7, 0x24 | 0x10, 0x10, 0x27, 0x10, 0x27, 0, 0]), 0.0)
    assert fixed_eraser.buttons == int(Button.STYLUS2) and fixed_eraser.tool == Tool.ERASER


def test_huion_secondary_tip_switch_is_the_second_button() -> None:
    # Huion firmware-mode pens (Kamvas Pro 19 256c:006b) say Secondary Tip Switch (0x43)
    # for the second barrel button.
    desc = hexd("""
    05 0d 09 02 a1 01 85 0a 09 20 a1 01 09 42 09 44 09 43 09 32 15 00 25 01 75 01 95 04 81 02
    95 04 81 03 05 01 09 30 09 31 26 ff 7f 75 10 95 02 81 02 c0 c0
    """)
    (raw,) = parser_for(0x256C, 0x006B, desc).parse(bytes([10, 0x04 | 0x08, 1, 0, 2, 0]), 0.0)
    assert raw.buttons == int(Button.STYLUS2) and not raw.tip
    (plain,) = parser_for(0x1234, 0x0001, desc).parse(bytes([10, 0x04 | 0x08, 1, 0, 2, 0]), 0.0)
    assert plain.buttons == 0


def test_art_pen_rotation_resolution_is_per_radian_on_evdev() -> None:
    # hid-wacom: ABS_Z -900..899 with resolution 287 (units per radian: 1800 a turn), the
    # same convention as tilt's 57 (xf86-input-wacom's PTH-660 test device lists both).
    from station.drivers.evdev.frames import ranges_from_caps

    caps = EvdevCaps("Wacom Intuos Pro M Pen",
                     {c.ABS_X: AbsInfo(0, 44800, 4, 0, 200), c.ABS_Y: AbsInfo(0, 29600, 4, 0, 200),
                      c.ABS_Z: AbsInfo(-900, 899, 0, 0, 287),
                      c.ABS_TILT_X: AbsInfo(-64, 63, 0, 0, 57)},
                     frozenset({c.BTN_TOOL_PEN, c.BTN_TOUCH}))
    r = ranges_from_caps(caps)
    assert r.rotation is not None and r.tilt_x is not None
    assert 450 / r.rotation.resolution == pytest.approx(89.84, abs=0.01)  # a quarter turn
    assert 63 / r.tilt_x.resolution == pytest.approx(63.33, abs=0.01)


def test_rust_hid_recorder_output_with_colours_and_bpf_lines(tmp_path: Path) -> None:
    # hidutils/hid-recorder: `I:` ids unpadded, `B:` lines for HID-BPF events (the device's
    # bytes before a BPF program), ANSI colours when --output-file is used from a terminal,
    # a trailing space after the last byte, `# Current time:` comments.
    desc = hexd(PEN_APP)
    red, off = "\x1b[31m", "\x1b[39m"
    rep = pen_report(100, 200, 300, tip=True)
    lines = ["# \x1b[35m##########\x1b[39m", f"{red}R: {len(desc)} {desc.hex(' ')}{off}",
             f"{red}N: UGTABLET 24 inch PenDisplay{off}", f"{red}I: 3 28bd 93a{off}",
             "# Current time: 10:24:38",
             f"{red}B: 000000.000100 8 {bytes([7, 1, 0, 0, 0, 0, 0, 0]).hex(' ')} {off}",
             f"{red}E: 000000.000100 8 {rep.hex(' ')} {off}"]
    path = tmp_path / "capture"  # no suffix: sniffed, and 'B:' must not mean evemu
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    assert trace_format(path) == "hid-recorder"
    (dev,) = read_trace(path).devices
    assert (dev.vid, dev.pid, dev.descriptor) == (0x28BD, 0x093A, desc)
    assert [r.data for r in dev.reports] == [rep]
