"""Pen interfaces the sweep of real descriptors found refused or mis-assigned (issue 9),
held by tests built from the protocol facts; the sweep tool on a small generated
collection; and the sweep over the public collection where it is on this machine.

Facts: hid-input maps In Range inside a *physical* Pen collection to BTN_TOOL_PEN (the
Huion H580X / Gaomon 1080Pro, 256c:0064, declare their pen interface that way, with no
application collection); hid-core drops undeclared report IDs before any driver, so an
interface declaring only a boot mouse (the third interface of the Intuos CTL/CTH-490,
056a:033c) carries no pen; wacom_tpc_irq reads any 8-byte report as pen (the Fujitsu
T904's ISDv5 5002 declares its pen as report 6).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from station.drivers import synth as S
from station.drivers.hid import usages as U
from station.drivers.hid.descriptor import CollectionKind, parse_descriptor
from station.drivers.hid.pen import classify_reports
from station.drivers.registry import parser_for

ROOT = Path(__file__).resolve().parents[1]
SWEEP = ROOT / "tools" / "sweep_descriptors.py"
COLLECTION = Path(os.environ.get("STATION_HID_DESCRIPTORS", "/tmp/whd"))


def physical_pen_descriptor() -> bytes:
    """An unnumbered pen inside a physical Pen collection and no application: tip,
    barrel, eraser, invert, in range; x, y 0..32767; pressure 0..8191; tilt +-127."""
    b = S.DescriptorBuilder()
    b.usage_page(U.PAGE_DIGITIZER).usage(0x02).collection(CollectionKind.PHYSICAL)
    b.bits(U.PAGE_DIGITIZER, [0x42, 0x44, 0x45, 0x3C]).padding(2)
    b.bits(U.PAGE_DIGITIZER, [0x32]).padding(1)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x30, 16, 0, 32767)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x31, 16, 0, 32767)
    b.value(U.PAGE_DIGITIZER, 0x30, 16, 0, 8191)
    b.value(U.PAGE_DIGITIZER, 0x3D, 8, -127, 127)
    b.value(U.PAGE_DIGITIZER, 0x3E, 8, -127, 127)
    b.end_collection()
    return b.to_bytes()


def boot_mouse_descriptor() -> bytes:
    """Report 1: three buttons and relative x, y in a Generic Desktop Mouse application."""
    b = S.DescriptorBuilder()
    b.usage_page(U.PAGE_GENERIC_DESKTOP).usage(0x02).collection(CollectionKind.APPLICATION)
    b.report_id(0x01).usage(0x01).collection(CollectionKind.PHYSICAL)
    b.bits(U.PAGE_BUTTON, [1, 2, 3]).padding(5)
    b.usage_page(U.PAGE_GENERIC_DESKTOP).usage(0x30).usage(0x31).logical(-127, 127)
    b.report_size(8).report_count(2).input(0x02 | 0x04)
    b.end_collection().end_collection()
    return b.to_bytes()


def test_a_pen_in_a_physical_pen_collection_without_application_is_a_pen() -> None:
    desc = physical_pen_descriptor()
    assert classify_reports(parse_descriptor(desc)) == {0: "pen"}
    p = parser_for(0x256C, 0x0064, desc, interface=1)  # a UC-Logic id: the descriptor path
    assert p.is_pen and p.name == "uclogic"
    assert (p.ranges.x.maximum, p.ranges.pressure.maximum) == (32767, 8191)
    report = S.encode_report(parse_descriptor(desc), 0, {
        U.GD_X: 20000, U.GD_Y: 9000, U.DG_TIP_PRESSURE: 4000, U.DG_TIP_SWITCH: 1,
        U.DG_IN_RANGE: 1, U.DG_X_TILT: -30, U.DG_Y_TILT: 12})  # fmt: skip
    (s,) = p.parse(report, 0.5)
    assert (s.x, s.y, s.pressure, s.tip, s.proximity, s.tilt_x, s.tilt_y) == (
        20000, 9000, 4000, True, True, -30, 12)


def test_a_stylus_collection_without_coordinates_stays_no_pen() -> None:
    """A remote's battery report inside a Stylus collection (XP-Pen ACK05) is no pen."""
    b = S.DescriptorBuilder()
    b.usage_page(U.PAGE_GENERIC_DESKTOP).usage(0x07).collection(CollectionKind.APPLICATION)
    b.report_id(0xF2).usage_page(U.PAGE_DIGITIZER).usage(0x20)
    b.collection(CollectionKind.PHYSICAL).value(0x85, 0x65, 8, 0, 100)
    b.end_collection().end_collection()
    assert classify_reports(parse_descriptor(b.to_bytes())) == {0xF2: "other"}


def test_a_protocol_tablets_boot_mouse_interface_is_ignored() -> None:
    mouse = parser_for(0x056A, 0x033C, boot_mouse_descriptor())
    assert not mouse.is_pen and mouse.kind == "other"
    pen = parser_for(0x056A, 0x033C, S.wacom_protocol_descriptor(9))
    assert pen.is_pen and pen.name == "wacom-intuos"
    # a protocol pen interface that also declares the boot mouse stays the pen
    graphire = parser_for(0x056A, 0x0061, S.wacom_protocol_descriptor(7))
    assert graphire.is_pen and graphire.name == "wacom-graphire"


def test_a_tablet_pc_pen_declared_under_another_id_keeps_the_tpc_protocol() -> None:
    b = S.DescriptorBuilder()
    b.usage_page(U.PAGE_DIGITIZER).usage(0x02).collection(CollectionKind.APPLICATION)
    b.report_id(0x06).usage(0x20).collection(CollectionKind.PHYSICAL)
    b.bits(U.PAGE_DIGITIZER, [0x42, 0x44, 0x45, 0x3C]).padding(1)
    b.bits(U.PAGE_DIGITIZER, [0x32]).padding(2)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x30, 16, 0, 29576)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x31, 16, 0, 16724)
    b.value(U.PAGE_DIGITIZER, 0x30, 16, 0, 1023)
    b.end_collection().end_collection()
    p = parser_for(0x056A, 0x5002, b.to_bytes())
    assert p.is_pen and p.name == "wacom-tpc"
    # d1: in range 0x20 | tip 0x01; x, y, pressure little-endian (wacom_tpc_pen)
    (s,) = p.parse(bytes([6, 0x21, 0x10, 0x27, 0x20, 0x4E, 0x00, 0x02]), 0.0)
    assert (s.x, s.y, s.pressure, s.tip, s.proximity) == (10000, 20000, 512, True, True)


def _sweep(root: Path) -> dict:
    out = subprocess.run([sys.executable, str(SWEEP), str(root)], capture_output=True,
                         text=True, check=True, timeout=120).stdout
    return json.loads(out)


def test_the_sweep_tool_reads_every_name_variant(tmp_path: Path) -> None:
    (tmp_path / "a" / "sysinfo.x").mkdir(parents=True)
    (tmp_path / "a" / "sysinfo.x" / "0003:256C:0064.0005.hid.bin").write_bytes(
        physical_pen_descriptor())
    (tmp_path / "a" / "0003:056A:033C.000C.hid.bin").write_bytes(boot_mouse_descriptor())
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "056a:033c_0.hid.bin").write_bytes(S.wacom_protocol_descriptor(9))
    (tmp_path / "b" / "0018:04F3:2C1B.hid.bin").write_bytes(S.ntrig_like_descriptor())
    (tmp_path / "b" / "0003:1234:5678.0001.hid.bin").write_bytes(b"")
    (tmp_path / "b" / "0003:1234:5679.0002.hid.bin").write_bytes(boot_mouse_descriptor())
    (tmp_path / "b" / "notes.hid.bin").write_bytes(b"\x05\x01")  # not a device file name
    s = _sweep(tmp_path)
    assert s["descriptors"] == 6
    assert s["by_outcome"] == {"pen": 3, "ignored": 1, "empty": 1, "refused": 1}
    assert s["served_by_family"] == {"uclogic": 1, "wacom-intuos": 1, "hid-generic": 1}
    assert (s["roundtrip_checked"], s["roundtrip_ok"]) == (2, 2)
    assert s["flagged"] == []


@pytest.mark.skipif(not COLLECTION.is_dir(), reason=f"{COLLECTION} absent (the public "
                    "descriptor collection is not shipped; set STATION_HID_DESCRIPTORS)")
def test_every_pen_descriptor_of_the_public_collection_is_served() -> None:
    s = _sweep(COLLECTION)
    assert s["descriptors"] >= 800
    assert s["flagged"] == []
    assert s["served_as_pen"] == s["pen_devices"] >= 470
    assert s["roundtrip_ok"] == s["roundtrip_checked"] >= 440
