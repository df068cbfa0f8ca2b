"""Wacom protocol parsers: golden samples from hand-written report bytes, state, errors."""

from __future__ import annotations

import pytest
from station.drivers import synth as S
from station.drivers.hid.errors import ReportError
from station.drivers.registry import find_device, parser_for
from station.drivers.wacom.intuos import decode_rotation
from station.drivers.wacom.tools import tool_from_id

from station.events import Button, Tool

INTUOS_PRO = (0x056A, 0x0315)
INTUOS4 = (0x056A, 0x00B8)


def intuos(pid: int = 0x0315):
    return parser_for(0x056A, pid, None)


def h(text: str) -> bytes:
    return bytes.fromhex(text)


# 02 c2 80 20 a1 b2 c3 d1 00 00: Grip Pen 0x10802, serial 0x0A1B2C3D (worked by hand
# from the byte layout: tool id = d2<<4 | d3>>4 | (d7&0xf)<<16 | (d8&0xf0)<<8).
PROX_IN_GRIP = h("02 c2 80 20 a1 b2 c3 d1 00 00")
# 02 e3 50 a8 36 00 80 c8 c0 2a: pen packet, x = 0x50a8<<1 | 1 = 41297, y = 0x3600<<1 = 27648,
# pressure = 0x80<<3 | 0xc0>>5 | 1 = 1031, tilt x = (0x10 | 1) - 64 = -47, tilt y = 0x40 - 64 = 0,
# distance = 0x2a >> 2 = 10, first side button.
PEN_PACKET = h("02 e3 50 a8 36 00 80 c8 c0 2a")


def test_intuos_proximity_in_identifies_tool():
    p = intuos()
    (s,) = p.parse(PROX_IN_GRIP, 1.5)
    assert s.time == 1.5 and s.proximity and not s.valid
    assert s.tool_id == 0x10802 and s.serial == 0x0A1B2C3D and s.tool == Tool.PEN
    assert s.distance == 63 and s.pressure == 0


def test_intuos_pen_packet_golden():
    p = intuos()
    p.parse(PROX_IN_GRIP, 0.0)
    (s,) = p.parse(PEN_PACKET, 0.005)
    assert (s.x, s.y, s.pressure, s.tilt_x, s.tilt_y, s.distance) == (41297, 27648, 1031, -47, 0,
                                                                       10)  # fmt: skip
    assert s.buttons == Button.STYLUS
    assert s.tip is True and s.valid and s.proximity
    assert (s.tool, s.tool_id, s.serial, s.eraser) == (Tool.PEN, 0x10802, 0x0A1B2C3D, False)
    assert s.rotation is None and s.wheel is None


def test_intuos_pressure_halved_below_11_bits():
    model = dict(find_device(*INTUOS_PRO) or {})
    model["max_pressure"] = 1023
    from station.drivers.registry import PARSERS

    p = PARSERS["wacom-intuos"](model, None)
    p.parse(PROX_IN_GRIP, 0.0)
    (s,) = p.parse(PEN_PACKET, 0.005)
    assert s.pressure == 1031 >> 1 == 515
    assert p.ranges.pressure is not None and p.ranges.pressure.maximum == 1023


def test_intuos_tip_threshold_is_the_kernels():
    p = intuos()
    p.parse(PROX_IN_GRIP, 0.0)
    low = p.parse(S.intuos_pen(100, 100, 10), 0.01)[0]
    high = p.parse(S.intuos_pen(100, 100, 11), 0.02)[0]
    assert (low.pressure, low.tip) == (10, False)
    assert (high.pressure, high.tip) == (11, True)


def test_intuos_data_before_proximity_is_dropped():
    p = intuos()
    assert p.parse(PEN_PACKET, 0.0) == []
    assert p.parse(S.intuos_prox_out(), 0.001) == []
    assert p.dropped == 2 and p.skipped == 0


def test_intuos_in_range_and_proximity_out():
    p = intuos()
    p.parse(PROX_IN_GRIP, 0.0)
    p.parse(PEN_PACKET, 0.005)
    (r,) = p.parse(h("02 20 00 00 00 00 00 00 00 00"), 0.010)
    assert r.proximity and not r.valid and r.pressure == 0 and r.tip is False
    assert r.distance == 63 and r.tool_id == 0x10802
    (out,) = p.parse(h("02 80 00 00 00 00 00 00 00 00"), 0.015)
    assert not out.proximity and not out.valid
    assert out.tool_id == 0x10802 and out.serial == 0x0A1B2C3D and out.pressure == 0
    # the tool is forgotten: the next data packet is dropped
    assert p.parse(PEN_PACKET, 0.020) == [] and p.dropped == 1
    assert p.state.tool_id == 0


@pytest.mark.parametrize(
    ("d6", "d7", "rotation"),
    [(0x40, 0x20, 706), (0xF0, 0x20, -390), (0x40, 0x00, 194), (0x00, 0x00, 450)],
)
def test_art_pen_rotation_packet(d6, d7, rotation):
    p = intuos(0x00B8)
    p.parse(S.intuos_prox_in(0x10804, 77), 0.0)
    p.parse(PEN_PACKET, 0.005)
    report = bytes([0x02, 0xEA, 0x50, 0xA8, 0x36, 0x00, d6, d7, 0x00, 0x2A])
    (s,) = p.parse(report, 0.010)
    assert s.rotation == rotation
    assert s.tool == Tool.PEN and s.tool_id == 0x10804
    # a rotation packet carries no pressure: the last pen packet's values stay
    assert (s.pressure, s.tilt_x, s.x) == (1031, -47, 41297)


def test_rotation_encoder_inverts_every_value():
    for rot in range(-900, 900):
        t = S.rotation_code(rot)
        d = bytes([2, 0xEA, 0, 0, 0, 0, t >> 3, (t & 7) << 5, 0, 0])
        assert decode_rotation(d) == rot


def test_airbrush_wheel_packet():
    p = intuos()
    p.parse(S.intuos_prox_in(0x902, 5), 0.0)
    (s,) = p.parse(h("02 f4 00 10 00 10 80 45 50 00"), 0.01)
    assert s.tool == Tool.AIRBRUSH
    assert s.wheel == 513 and (s.tilt_x, s.tilt_y) == (-54, 16)
    assert (s.x, s.y) == (32, 32)


def test_mouse_and_lens_pass_as_cursor_tools():
    p = intuos()
    p.parse(S.intuos_prox_in(0x806, 9), 0.0)
    (m,) = p.parse(S.intuos_mouse(1000, 2000, left=True, right=True), 0.01)
    assert m.tool == Tool.MOUSE and m.pressure is None and m.tip is False
    assert m.buttons == Button.STYLUS | Button.STYLUS2 and (m.x, m.y) == (1000, 2000)
    p.parse(S.intuos_prox_out(), 0.02)
    p.parse(S.intuos_prox_in(0x096, 10), 0.03)
    (lens,) = p.parse(S.intuos_lens(30, 40, middle=True), 0.04)
    assert lens.tool == Tool.LENS and lens.buttons == Button.STYLUS3 and lens.tilt_x is None


@pytest.mark.parametrize(
    ("tool_id", "tool"),
    [(0x802, Tool.PEN), (0x80A, Tool.ERASER), (0x812, Tool.PENCIL), (0x801, Tool.PENCIL),
     (0x12802, Tool.PENCIL), (0x832, Tool.BRUSH), (0x902, Tool.AIRBRUSH),
     (0x10902, Tool.AIRBRUSH), (0x806, Tool.MOUSE), (0x007, Tool.MOUSE), (0x017, Tool.MOUSE),
     (0x096, Tool.LENS), (0x006, Tool.LENS), (0x10802, Tool.PEN), (0x10804, Tool.PEN),
     (0x1234A, Tool.ERASER), (0x12340, Tool.PEN)],
)  # fmt: skip
def test_tool_id_table(tool_id, tool):
    assert tool_from_id(tool_id) is tool


def test_eraser_tool_sets_eraser_flag():
    p = intuos()
    (s,) = p.parse(S.intuos_prox_in(0x80A, 0x55), 0.0)
    assert s.tool == Tool.ERASER and s.eraser


def test_intuos_encoders_round_trip():
    p = intuos()
    p.parse(S.intuos_prox_in(0x802, 0xFFFFFFFF), 0.0)
    for x, y, pr, tx, ty, dist, b in [(0, 0, 0, -64, -64, 0, 0),
                                      (44704, 27940, 2047, 63, 63, 63, 3),
                                      (12345, 23456, 1000, -5, 7, 20, 1)]:  # fmt: skip
        (s,) = p.parse(S.intuos_pen(x, y, pr, tx, ty, dist, b), 0.1)
        assert (s.x, s.y, s.pressure, s.tilt_x, s.tilt_y, s.distance, s.buttons) == (
            x, y, pr, tx, ty, dist, b)
        assert s.serial == 0xFFFFFFFF


def test_intuos_skips_mouse_mode_and_pad_reports():
    p = intuos()
    assert p.parse(h("01 01 05 fb 00"), 0.0) == []  # boot-mouse report before the switch
    assert p.parse(bytes([12] + [0] * 9), 0.0) == []  # pad
    assert p.skipped == 2 and p.skipped_by_kind == {"mouse": 1, "pad": 1}
    assert p.init_features == [b"\x02\x02"]


@pytest.mark.parametrize(
    ("report", "text"),
    [(bytes([7] + [0] * 9), "unknown Intuos report ID 7"),
     (bytes([2] + [0] * 8), "is 9 bytes, expected 10..16"),
     (bytes([2] + [0] * 16), "is 17 bytes, expected 10..16"),
     (b"", "unknown Intuos report ID 0")],
)  # fmt: skip
def test_intuos_malformed(report, text):
    with pytest.raises(ReportError, match=text):
        intuos().parse(report, 0.0)


# -- Bamboo / Intuos-HT ----------------------------------------------------------------


def bamboo(pid: int = 0x00D4):
    return parser_for(0x056A, pid, None)


def test_bamboo_pen_golden():
    p = bamboo()
    # 02 f1 10 27 88 13 00 02 05: range, prox, ready, tip; x 10000, y 5000, pressure 512,
    # distance = 31 - 5 = 26
    (s,) = p.parse(h("02 f1 10 27 88 13 00 02 05"), 2.0)
    assert (s.x, s.y, s.pressure, s.distance) == (10000, 5000, 512, 26)
    assert s.tip is True and s.proximity and s.valid
    assert (s.tool, s.tool_id, s.eraser, s.buttons) == (Tool.PEN, 0x02, False, 0)


def test_bamboo_pressure_without_tip_bit_and_buttons():
    p = bamboo(0x030E)
    (s,) = p.parse(h("02 e6 10 00 20 00 10 00 20 00"), 0.0)
    assert s.pressure == 16 and s.tip is False
    assert s.buttons == Button.STYLUS | Button.STYLUS2
    assert s.distance == 0


def test_bamboo_eraser_and_proximity_out():
    p = bamboo()
    (e,) = p.parse(S.bamboo_pen(300, 400, 0, eraser=True, raw_distance=10), 0.0)
    assert e.tool == Tool.ERASER and e.eraser and e.tool_id == 0x0A and e.distance == 21
    (out,) = p.parse(S.bamboo_pen(0, 0, in_range=False, prox=False, ready=False), 0.01)
    assert not out.proximity and not out.valid and (out.x, out.y) == (0, 0)
    assert out.tool_id is None
    # in range but too far for coordinates, before any proximity: dropped
    assert p.parse(S.bamboo_pen(0, 0, prox=False, ready=False), 0.02) == []
    assert p.dropped == 1


def test_bamboo_hover_keeps_last_position():
    p = bamboo()
    p.parse(S.bamboo_pen(500, 600, 0), 0.0)
    (s,) = p.parse(S.bamboo_pen(0, 0, prox=False, ready=False, raw_distance=3), 0.01)
    assert s.proximity and not s.valid and (s.x, s.y) == (500, 600) and s.distance == 28


def test_bamboo_touch_reports_skipped_and_errors():
    p = bamboo()
    assert p.parse(bytes([2] + [0] * 19), 0.0) == []
    assert p.parse(bytes([2] + [0] * 63), 0.0) == []
    assert p.skipped_by_kind == {"touch": 2}
    with pytest.raises(ReportError, match="is 8 bytes"):
        p.parse(bytes([2] + [0] * 7), 0.0)
    with pytest.raises(ReportError, match="unknown Bamboo report ID 5"):
        p.parse(bytes([5] + [0] * 8), 0.0)


# -- Graphire -------------------------------------------------------------------------------


def test_graphire_usb_golden():
    p = parser_for(0x056A, 0x0081, None, bus=3)
    assert p.name == "wacom-graphire" and p.init_features == [b"\x02\x02"]
    # 02 81 e8 03 d0 07 2c 01: prox, pen, tip; x 1000, y 2000, pressure 0x2c | 1<<8 = 300
    (s,) = p.parse(h("02 81 e8 03 d0 07 2c 01"), 0.0)
    assert (s.x, s.y, s.pressure, s.tip, s.tool, s.tool_id) == (1000, 2000, 300, True, Tool.PEN,
                                                                  0x02)  # fmt: skip
    assert p.ranges.x.resolution == 80 and p.ranges.pressure.maximum == 511


def test_graphire_bluetooth_pressure_msb_in_d1():
    p = parser_for(0x056A, 0x0081, None, bus=5)
    # the kernel's Bluetooth set-up (wacom_bt_query_tablet_data): 03 00, then 06 00 (high speed)
    assert p.name == "wacom-graphire-bt" and p.init_features == [b"\x03\x00", b"\x06\x00"]
    (s,) = p.parse(h("03 89 e8 03 d0 07 2c 00"), 0.0)
    assert s.pressure == 300 and s.tip is True
    with pytest.raises(ReportError, match="unknown Graphire report ID 2"):
        p.parse(h("02 81 e8 03 d0 07 2c 01"), 0.0)


def test_graphire_eraser_mouse_and_out():
    p = parser_for(0x056A, 0x0081, None)
    (e,) = p.parse(h("02 a4 01 00 02 00 00 00"), 0.0)
    assert e.tool == Tool.ERASER and e.eraser and e.buttons == Button.STYLUS2 and not e.tip
    (out,) = p.parse(h("02 00 00 00 00 00 00 00"), 0.01)
    assert not out.proximity and out.tool == Tool.ERASER
    assert p.parse(h("02 00 00 00 00 00 00 00"), 0.02) == [] and p.dropped == 1
    (m,) = p.parse(h("02 c1 10 00 20 00 00 15"), 0.03)
    assert m.tool == Tool.MOUSE and m.buttons == Button.STYLUS and m.distance == 21
    assert m.pressure is None


def test_graphire_encoders_round_trip():
    for bt in (False, True):
        p = parser_for(0x056A, 0x0081, None, bus=5 if bt else 3)
        for pressure in (0, 1, 255, 256, 511):
            (s,) = p.parse(S.graphire_report(16704, 12064, pressure, tip=pressure > 0,
                                             bluetooth=bt), 0.0)  # fmt: skip
            assert (s.x, s.y, s.pressure, s.tip) == (16704, 12064, pressure, pressure > 0)
        (m,) = p.parse(S.graphire_report(5, 6, tool=S.GRAPHIRE_MOUSE, mouse_distance=17,
                                         bluetooth=bt), 0.0)  # fmt: skip
        assert m.tool == Tool.MOUSE and m.distance == 17
