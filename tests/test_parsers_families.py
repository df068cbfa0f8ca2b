"""Wacom protocol families beyond Intuos3+/Bamboo/Graphire, from the kernel's byte facts.

Every report here is written byte by byte from the protocol facts (wacom_wac.c)
or with the synth encoders; no third-party captures.
"""

from __future__ import annotations

import json

import pytest
from station.drivers import registry
from station.drivers import synth as S
from station.drivers.hid.descriptor import ReportType, parse_descriptor
from station.drivers.hid.errors import ReportError
from station.drivers.wacom.legacy import dtus, penpartner, pl, ptu, tpc

from station.cli import main
from station.events import Button, Tool

WACOM = 0x056A


def parser(pid: int, bus: int = 3):
    return registry.parser_for(WACOM, pid, None, bus)


# -- the device table as data ------------------------------------------------------------------
@pytest.mark.parametrize(
    ("pid", "bus", "name", "family", "numbers"),
    [(0x0044, 3, "wacom-intuos1", "Intuos/Intuos2", (30480, 31680, 1023, 31, 100)),
     (0x00B1, 3, "wacom-intuos", "Intuos3", (40640, 30480, 1023, 63, 200)),
     (0x003F, 3, "wacom-intuos", "Cintiq", (87200, 65600, 1023, 63, 200)),
     (0x00CC, 3, "wacom-intuos", "Cintiq 21UX2", (87200, 65600, 2047, 63, 200)),
     (0x00F4, 3, "wacom-intuos", "Cintiq 24HD", (104480, 65600, 2047, 63, 200)),
     (0x0304, 3, "wacom-intuos", "Cintiq 13HD", (59552, 33848, 1023, 63, 200)),
     (0x033B, 3, "wacom-intuos", "Intuos (CTL/CTH-490/690)", (15200, 9500, 2047, 63, 100)),
     (0x00BD, 5, "wacom-intuos4wl", "Intuos4 wireless (Bluetooth)", (40640, 25400, 2047, 63, 200)),
     (0x0360, 5, "wacom-intuos-bt", "Intuos Pro 2 (Bluetooth)", (44800, 29600, 8191, 63, 200)),
     (0x0377, 5, "wacom-intuos-bt", "Intuos CTL-4100/6100 (Bluetooth)",
      (15200, 9500, 4095, 63, 100)),
     (0x00F0, 3, "wacom-dtu", "DTU pen display", (34623, 19553, 511, 0, 100)),
     (0x0030, 3, "wacom-pl", "PL / DTF / DTU pen display", (5408, 4056, 255, 0, 20)),
     (0x0003, 3, "wacom-ptu", "Cintiq Partner (PTU)", (20480, 15360, 511, 0, 20)),
     (0x0000, 3, "wacom-penpartner", "PenPartner", (5040, 3780, 255, 0, 40)),
     (0x0060, 3, "wacom-graphire", "Graphire/Volito/Bamboo1", (5104, 3712, 511, 63, 50)),
     (0x0065, 3, "wacom-graphire4", "Bamboo Fun (MO)", (14760, 9225, 511, 63, 100)),
     (0x00D6, 3, "wacom-bamboo", "Bamboo Pen & Touch", (14720, 9200, 1023, 31, 100)),
     (0x0093, 3, "wacom-tpc", "ISDv4 Tablet PC", (26202, 16325, 255, 0, 100))],
)  # fmt: skip
def test_kernel_table_facts_reach_the_parser(pid, bus, name, family, numbers):
    m = registry.find_device(WACOM, pid, bus)
    assert m is not None and m["parser"] == name and m["family"] == family
    assert (m["max_x"], m["max_y"], m["max_pressure"], m["max_distance"],
            m["resolution"]["x"]) == numbers  # fmt: skip
    assert m["provenance"]["sources"][0]["path"] == "4.18/wacom_wac.c"
    p = parser(pid, bus)
    assert p.name == name and p.is_pen
    assert (p.ranges.x.maximum, p.ranges.y.maximum) == numbers[:2]


def test_mode_switches_follow_the_kernel():
    # USB protocol pens: feature 2 = 2; Bluetooth Intuos4 WL: 03 00 (high speed);
    # Tablet PC pens and the Pro 2 over Bluetooth: none.
    assert parser(0x0044).init_features == [b"\x02\x02"]
    assert parser(0x00BD, 5).init_features == [b"\x03\x00"]
    assert parser(0x0093).init_features == []
    assert parser(0x0360, 5).init_features == []


# -- Intuos / Intuos2: two tool slots, no extra coordinate bit -----------------------------------
def _slot(report: bytes, slot: int) -> bytes:
    return bytes([report[0], report[1] | slot]) + report[2:]


def test_intuos1_halves_coordinates_and_keeps_two_tools_apart():
    p = parser(0x0044)  # Intuos2 12x12: pressure max 1023, distance max 31
    assert p.ranges.rotation is None
    pen_in = p.parse(_slot(S.intuos_prox_in(0x022, 0x111), 0), 0.0)
    puck_in = p.parse(_slot(S.intuos_prox_in(0x094, 0x222), 1), 0.001)
    assert pen_in[0].tool == Tool.PEN and pen_in[0].serial == 0x111
    assert puck_in[0].tool == Tool.MOUSE and puck_in[0].serial == 0x222
    # The encoder writes Intuos3-style coordinates (x << 1 | low bit); the original
    # protocol has no low bit, so a coordinate X is encoded as 2X and read back as X.
    (s,) = p.parse(S.intuos_pen(2 * 12345, 2 * 6789, 700, 10, -20, 4 * 2, 0, 1023), 0.002)
    assert (s.x, s.y, s.pressure, s.tilt_x, s.tilt_y, s.distance) == (12345, 6789, 700, 10, -20, 4)
    assert s.tool == Tool.PEN and s.serial == 0x111 and s.tip
    # 4D mouse throttle packet (type 5) on slot 1: the puck's sample, no Art Pen rotation
    rot = bytearray(S.intuos_rotation(2 * 100, 2 * 200, 300))
    (m,) = p.parse(_slot(bytes(rot), 1), 0.003)
    assert m.tool == Tool.MOUSE and m.serial == 0x222 and m.rotation is None
    assert (m.x, m.y) == (100, 200)
    (out,) = p.parse(_slot(S.intuos_prox_out(), 1), 0.004)
    assert not out.proximity and out.tool == Tool.MOUSE
    (still,) = p.parse(S.intuos_pen(2 * 10, 2 * 20, 0, 0, 0, 0, 0, 1023), 0.005)
    assert still.tool == Tool.PEN and still.serial == 0x111  # the pen slot is untouched


# -- quirks of the Intuos3+ family, as data ------------------------------------------------
def test_first_cintiq_sends_data_only_with_the_ready_bit():
    p = parser(0x003F)
    assert registry.find_device(WACOM, 0x3F)["protocol_quirks"] == ["ready-bit"]
    p.parse(S.intuos_prox_in(0x802, 7), 0.0)
    ready = S.intuos_pen(1000, 2000, 300, max_pressure=1023)
    not_ready = bytes([ready[0], ready[1] & ~0x40]) + ready[2:]
    assert p.parse(not_ready, 0.001) == [] and p.dropped == 1
    assert p.parse(ready, 0.002)[0].x == 1000


def test_21ux2_drops_styli_of_the_older_generation():
    p = parser(0x00CC)
    p.parse(S.intuos_prox_in(0x802, 1), 0.0)  # Intuos4-era Grip Pen: bit 16 clear
    assert p.parse(S.intuos_pen(10, 10, 100), 0.001) == []
    p.parse(S.intuos_prox_in(0x10802, 2), 0.002)
    assert p.parse(S.intuos_pen(10, 10, 100), 0.003)[0].pressure == 100


def test_small_intuos3_drops_the_lens_cursor_but_the_large_one_keeps_it():
    small, large = parser(0x00B1), parser(0x00B3)
    for p in (small, large):
        p.parse(S.intuos_prox_in(0x097, 5), 0.0)
    assert small.parse(S.intuos_lens(500, 600, left=True), 0.001) == []
    (s,) = large.parse(S.intuos_lens(500, 600, left=True), 0.001)
    assert s.tool == Tool.LENS and s.buttons & Button.STYLUS


def test_intuos_ht2_has_no_tilt_and_counts_distance_from_the_surface():
    p = parser(0x033B)
    assert p.ranges.tilt_x is None
    p.parse(S.intuos_prox_in(0x802, 3), 0.0)
    (s,) = p.parse(S.intuos_pen(300, 400, 50, 20, 20, distance=13), 0.001)
    assert s.tilt_x is None and s.distance == 63 - 13


def test_intuos_tool_query_answers_on_reports_5_and_6():
    p = parser(0x00B1)
    (s,) = p.parse(S.intuos_prox_in(0x823, 9, report_id=5), 0.0)
    assert s.proximity and s.serial == 9
    assert p.parse(S.intuos_pen(1, 1, 0, report_id=5), 0.001) == []  # data only on 2/16
    assert p.parse(bytes([6, 0x01]) + bytes(8), 0.002) == [] and p.skipped_by_kind["status"] == 2


# -- Intuos4 WL over Bluetooth: Intuos packets bundled ---------------------------------------------
def test_intuos4_wireless_unbundles_two_or_three_packets():
    p = parser(0x00BD, 5)
    pin, pen = S.intuos_prox_in(0x802, 0xABC), S.intuos_pen(4000, 5000, 1500, 5, 6)
    two = bytes([0x03]) + pin + pen + bytes([0x07])  # + power byte
    samples = p.parse(two, 0.0)
    assert [s.valid for s in samples] == [False, True]
    assert samples[1].x == 4000 and samples[1].pressure == 1500 and samples[1].serial == 0xABC
    pad = bytes([12]) + bytes(9)
    three = bytes([0x04]) + pen + pad + S.intuos_prox_out() + bytes([0x05])
    out = p.parse(three, 0.01)
    assert [s.proximity for s in out] == [True, False] and p.skipped_by_kind["pad"] == 1
    with pytest.raises(ReportError, match="at least 22"):
        p.parse(two[:21], 0.02)
    with pytest.raises(ReportError, match="unknown"):
        p.parse(bytes([0x05]) + bytes(31), 0.03)


# -- Intuos Pro 2 / Intuos CTL over Bluetooth ---------------------------------------------------
def _bt_frame_pro2(x, y, p, tx, ty, rot, wheel, dist, prox=True, rng=True, invert=False, tip=False):
    f0 = 0x80 | (0x40 if prox else 0) | (0x20 if rng else 0) | (0x10 if invert else 0)
    f0 |= 0x01 if tip else 0
    return (bytes([f0]) + x.to_bytes(2, "little") + y.to_bytes(2, "little")
            + p.to_bytes(2, "little") + bytes([tx & 0xFF, ty & 0xFF])
            + (rot - 450).to_bytes(2, "little", signed=True) + wheel.to_bytes(2, "little")
            + bytes([dist]))  # fmt: skip


def test_intuos_pro2_bluetooth_frames():
    p = parser(0x0360, 5)
    frames = [_bt_frame_pro2(1000 + i, 2000, 100 * i, -10, 20, 300, 0, 5, tip=i > 0)
              for i in range(3)]
    body = b"".join(frames) + bytes(14 * 4)
    serial = (1 << 52) | (0x00842 << 32) | 0x1234
    report = bytes([0x81]) + body + serial.to_bytes(8, "little") + (0x0802).to_bytes(2, "little")
    out = p.parse(report, 0.0)
    assert len(out) == 3
    s = out[2]
    assert (s.x, s.y, s.pressure, s.tilt_x, s.tilt_y, s.rotation, s.distance) == (
        1002, 2000, 200, -10, 20, 300, 5)
    assert s.tip and s.serial == serial and s.tool_id == 0x0802 | 0x00842
    assert s.tool == Tool.PEN
    gone = bytes([0x81]) + bytes([0x80]) + bytes(14 * 7 - 1) + report[99:]
    (o,) = p.parse(gone, 0.01)
    assert not o.proximity
    with pytest.raises(ReportError, match="at least 109"):
        p.parse(report[:100], 0.02)


def test_intuos_ctl_bluetooth_frames_have_distance_at_7():
    p = parser(0x0377, 5)
    f = bytes([0xE1]) + (500).to_bytes(2, "little") + (600).to_bytes(2, "little") + \
        (2000).to_bytes(2, "little") + bytes([9])
    report = bytes([0x80]) + f + bytes(8 * 3) + (77).to_bytes(8, "little") + bytes([2, 8])
    (s,) = p.parse(report, 0.0)
    assert (s.x, s.y, s.pressure, s.distance, s.tilt_x) == (500, 600, 2000, 9, None)
    assert s.tool == Tool.PEN and s.tip and s.serial == 77


# -- single-tool protocols ----------------------------------------------------------------------
def test_legacy_decoders_follow_the_byte_facts():
    # (proximity, x, y, pressure, tip, buttons, eraser)
    # PL: 7-bit coordinate groups, signed pressure around the middle of the range
    prox, x, y, p, tip, buttons, eraser = pl(bytes([2, 0x41, 0x05, 0x10, 0x0A, 0x03, 0x22, 0x10]),
                                             511)
    assert prox and x == 0x10 | (0x05 << 7) | (1 << 14) and y == 0x22 | (3 << 7) | (2 << 14)
    assert p == ((0x10 << 1) << 1) + 256 and tip and not eraser and buttons == 0
    # PTU: eraser bit, tip from bit 3 then
    assert ptu(bytes([2, 0x20 | 0x04 | 0x08, 1, 0, 2, 0, 44, 1]), 511) == (
        True, 1, 2, 300, True, 0, True)
    # DTUS: big-endian coordinates, 10-bit pressure, pen when (d1 >> 3) & 3 == 2
    assert dtus(bytes([17, 0x80 | 0x10 | 0x02, 0x20, 0x12, 0x34, 0x05, 0x06]), 1023) == (
        True, 0x1234, 0x0506, 0x220, True, 0, False)
    # Tablet PC: 11-bit pressure
    assert tpc(bytes([2, 0x20 | 0x01, 0x10, 0x27, 0x20, 0x4E, 0xFF, 0x03]), 1023)[1:5] == (
        10000, 20000, 0x3FF, True)
    # PenPartner: signed pressure + 127, barrel on d5 & 0x40
    assert penpartner(bytes([1, 0x10, 0x00, 0x20, 0x00, 0x80 | 0x40, 0x10]), 255) == (
        True, 16, 32, 16 + 127, True, int(Button.STYLUS), False)


def test_dtu_parser_keeps_the_tool_and_ends_the_stroke():
    p = parser(0x00F0)
    s1 = p.parse(bytes([2, 0x20 | 0x01, 0x10, 0x00, 0x20, 0x00, 0x80, 0x01]), 0.0)
    assert s1[0].tool == Tool.PEN and s1[0].pressure == 0x180 and s1[0].tip
    (out,) = p.parse(bytes([2, 0x00, 0, 0, 0, 0, 0, 0]), 0.01)
    assert not out.proximity and out.tool == Tool.PEN
    assert p.parse(bytes([2, 0x00, 0, 0, 0, 0, 0, 0]), 0.02) == [] and p.dropped == 1
    assert p.parse(bytes([1, 0, 0, 0]), 0.03) == [] and p.skipped_by_kind["mouse"] == 1
    with pytest.raises(ReportError, match="expected 8"):
        p.parse(bytes([2, 0x20]), 0.04)


def test_pl_eraser_misdetection_hands_over_to_the_pen():
    p = parser(0x0030)
    e = p.parse(bytes([2, 0x40, 0, 0, 0x20, 0, 0, 0]), 0.0)  # eraser in (STYLUS2 set)
    assert e[0].tool == Tool.ERASER
    out = p.parse(bytes([2, 0x40, 0, 0, 0x00, 0, 0, 0]), 0.01)  # STYLUS2 gone: it was the pen
    assert [(s.tool, s.proximity) for s in out] == [(Tool.ERASER, False), (Tool.PEN, True)]
    p.parse(bytes([2, 0x00, 0, 0, 0, 0, 0, 0]), 0.02)  # out
    (first,) = p.parse(bytes([2, 0x40, 0, 0, 0x00, 0, 0, 0]), 0.03)  # a fresh entry: the pen
    assert first.tool == Tool.PEN and first.proximity


# -- fallbacks for ids the data does not know ---------------------------------------------------
def test_unknown_wacom_with_a_pen_collection_uses_the_generic_path_with_a_warning(caplog):
    p = registry.parser_for(WACOM, 0x0FFE, S.pth660_like_descriptor())
    assert p.name == "hid-generic" and p.generic and p.is_pen
    assert "unknown Wacom tablet 056a:0ffe" in p.warning and "please report" in p.warning
    assert "lsusb -v -d 056a:0ffe" in caplog.text


def test_unknown_wacom_with_a_vendor_pen_report_gets_the_implied_protocol():
    p = registry.parser_for(WACOM, 0x0FFD, S.wacom_protocol_descriptor(9))  # report 2, 10 bytes
    assert p.name == "wacom-intuos" and p.generic and "implies the wacom-intuos" in p.warning
    assert p.init_features == [b"\x02\x02"]
    p.parse(S.intuos_prox_in(0x802, 1), 0.0)
    assert p.parse(S.intuos_pen(60000, 40000, 1000), 0.001)[0].x == 60000
    b = registry.parser_for(WACOM, 0x0FFC, S.wacom_protocol_descriptor(8))  # 9 bytes
    assert b.name == "wacom-bamboo"


def test_unknown_wacom_without_any_pen_report_says_how_to_report_it():
    with pytest.raises(Exception, match="please report it"):
        registry.parser_for(WACOM, 0x0FFB, S.touch_descriptor())
    with pytest.raises(Exception, match="please report it"):
        registry.parser_for(WACOM, 0x0FFB, None)


def test_generic_hid_wacom_gets_the_data_mode_switch_from_its_descriptor():
    # wacom_hid_usage_quirk: a feature field with WACOM_HID_WD_DATAMODE (0xff0d1002) makes
    # its report the mode report, value 2 (report length as the descriptor declares it).
    b = S.DescriptorBuilder()
    b.raw(S.pth660_like_descriptor())
    b.usage_page(0xFF0D).usage(0x01).collection(1).report_id(0x02)
    b.usage(0xFF0D1002, extended=True).logical(0, 255).report_size(8).report_count(1).feature()
    b.report_size(8).report_count(2).feature(1)
    b.end_collection()
    raw = b.to_bytes()
    declared = parse_descriptor(raw).report(ReportType.FEATURE, 2).length(True)
    want = b"\x02\x02" + bytes(declared - 2)
    p = registry.parser_for(WACOM, 0x0357, raw)
    assert p.name == "hid-generic" and p.init_features == [want] and declared >= 4
    unknown = registry.parser_for(WACOM, 0x0FFA, raw)
    assert unknown.init_features == [want]
    assert registry.parser_for(WACOM, 0x0357, S.pth660_like_descriptor()).init_features == []


# -- whole recordings through `station replay` -------------------------------------------------
def _stroke_times(n: int) -> list[float]:
    return [i * 0.005 + (0.001 if i % 2 else 0.0) for i in range(n)]


def _intuos2_reports() -> list[bytes]:
    out = [S.intuos_prox_in(0x022, 0x5EED)]
    for i in range(30):
        p = min(1023, i * 60)
        out.append(S.intuos_pen(2 * (3000 + 500 * i), 2 * (4000 + 300 * i), p, i - 15, 15 - i,
                                8, 0, 1023))  # fmt: skip
    return [*out, S.intuos_prox_out()]


def _i4wl_reports() -> list[bytes]:
    pens = [S.intuos_pen(2000 + 900 * i, 3000 + 500 * i, min(2047, 120 * i), 3, -3)
            for i in range(30)]  # fmt: skip
    out = [bytes([3]) + S.intuos_prox_in(0x802, 0x77) + pens[0] + b"\x07"]
    out += [bytes([3]) + pens[i] + pens[i + 1] + b"\x07" for i in range(1, 29, 2)]
    return [*out, bytes([3]) + S.intuos_prox_out() + bytes(10) + b"\x07"]


def _pl_reports() -> list[bytes]:
    out = []
    for i in range(30):
        x, y, on = 300 + 100 * i, 200 + 80 * i, i > 3
        out.append(bytes([2, 0x40 | (x >> 14), (x >> 7) & 0x7F, x & 0x7F,
                          (0x08 if on else 0) | (y >> 14), (y >> 7) & 0x7F, y & 0x7F,
                          (4 * i) & 0x7F]))  # fmt: skip
    return [*out, bytes([2, 0, 0, 0, 0, 0, 0, 0])]


@pytest.mark.parametrize(("pid", "bus", "make", "tool", "serial"), [
    (0x0044, 3, _intuos2_reports, "pen", 0x5EED),
    (0x00BD, 5, _i4wl_reports, "pen", 0x77),
    (0x0030, 3, _pl_reports, "pen", None),
])  # fmt: skip
def test_recorded_strokes_of_the_new_families_replay(tmp_path, pid, bus, make, tool, serial):
    reports = make()
    dev = S.RecordedDevice(f"Wacom {pid:04x}", WACOM, pid, S.wacom_protocol_descriptor(9),
                           list(zip(_stroke_times(len(reports)), reports, strict=True)), bus=bus)
    path = tmp_path / "stroke.hid"
    S.write_hid_recorder([dev], path)
    out = tmp_path / "out.jsonl"
    assert main(["replay", str(path), "--jsonl", str(out)]) == 0
    rows = [json.loads(ln) for ln in out.read_text().splitlines()[1:]]
    pens = [r for r in rows if r.get("type") == "pen"]
    assert len(pens) >= 25
    assert all(0.0 <= r["x"] <= 1.0 and 0.0 <= r["y"] <= 1.0 for r in pens)
    assert all(r["tool"] == tool and r["serial"] == serial for r in pens if r["proximity"])
    touching = [r for r in pens if r["touching"]]
    assert len(touching) >= 10 and max(r["pressure"] for r in touching) > 0.3
    assert all(r["pressure"] == 0 for r in pens if not r["touching"])
    assert not pens[-1]["proximity"]  # the stroke ends with a proximity-out
