"""Synthetic tablets: report encoders, a HID descriptor builder, a hid-recorder writer.

Everything here is the exact inverse of a parser, so tests and mock devices
can write recordings of every supported protocol without third-party
captures:

- report encoders: :func:`intuos_prox_in`, :func:`intuos_pen`,
  :func:`intuos_rotation`, :func:`intuos_airbrush`, :func:`intuos_mouse`,
  :func:`intuos_lens`, :func:`intuos_in_range`, :func:`intuos_prox_out`,
  :func:`bamboo_pen`, :func:`graphire_report`, and :func:`encode_report` for
  any descriptor-defined report;
- :class:`DescriptorBuilder` writes report descriptors item by item, and
  :func:`pth660_like_descriptor`, :func:`huion_like_descriptor`,
  :func:`ntrig_like_descriptor`, :func:`touch_descriptor`,
  :func:`wacom_protocol_descriptor` build typical ones;
- :func:`write_hid_recorder` writes hid-recorder text (``D:``, ``R:``,
  ``N:``, ``P:``, ``I:``, ``E:``) with the format variants seen in the wild.

See docs/drivers-protocols.md for examples.
"""

from __future__ import annotations

import io
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

from station.drivers.hid import usages as U
from station.drivers.hid.descriptor import (
    FLAG_CONSTANT,
    FLAG_VARIABLE,
    CollectionKind,
    Descriptor,
    ReportType,
    parse_descriptor,
)
from station.drivers.traces.hidrecorder import HidRecorderWriter

from station.events import Button

# -- Wacom Intuos (10-byte report 2) ------------------------------------------------


def _report(report_id: int, n: int) -> bytearray:
    b = bytearray(n)
    b[0] = report_id
    return b


def intuos_prox_in(tool_id: int, serial: int, report_id: int = 2) -> bytes:
    """Proximity-in packet naming the tool (20-bit tool id, 32-bit serial)."""
    if not 0 <= tool_id < 1 << 20 or not 0 <= serial < 1 << 32:
        raise ValueError("tool id is 20 bits, serial 32 bits")
    d = _report(report_id, 10)
    d[1] = 0xC2
    d[2] = (tool_id >> 4) & 0xFF
    d[3] = ((tool_id & 0xF) << 4) | ((serial >> 28) & 0xF)
    d[4] = (serial >> 20) & 0xFF
    d[5] = (serial >> 12) & 0xFF
    d[6] = (serial >> 4) & 0xFF
    d[7] = ((serial & 0xF) << 4) | ((tool_id >> 16) & 0xF)
    d[8] = ((tool_id >> 12) & 0xF) << 4
    return bytes(d)


def intuos_in_range(report_id: int = 2) -> bytes:
    """'In range, no valid data' packet."""
    d = _report(report_id, 10)
    d[1] = 0x20
    return bytes(d)


def intuos_prox_out(report_id: int = 2) -> bytes:
    """Proximity-out packet."""
    d = _report(report_id, 10)
    d[1] = 0x80
    return bytes(d)


def _intuos_xy(d: bytearray, x: int, y: int, distance: int) -> None:
    if not 0 <= x < 1 << 17 or not 0 <= y < 1 << 17 or not 0 <= distance < 64:
        raise ValueError("x, y are 17 bits, distance 6 bits")
    d[2], d[3] = (x >> 9) & 0xFF, (x >> 1) & 0xFF
    d[4], d[5] = (y >> 9) & 0xFF, (y >> 1) & 0xFF
    d[9] = (distance << 2) | ((x & 1) << 1) | (y & 1)


def _tilt_bits(tilt_x: int, tilt_y: int) -> tuple[int, int]:
    if not -64 <= tilt_x <= 63 or not -64 <= tilt_y <= 63:
        raise ValueError("tilt is -64..63")
    tx, ty = tilt_x + 64, tilt_y + 64
    return (tx >> 1) & 0x3F, ((tx & 1) << 7) | (ty & 0x7F)


def intuos_pen(x: int, y: int, pressure: int, tilt_x: int = 0, tilt_y: int = 0,
               distance: int = 0, buttons: int = 0, max_pressure: int = 2047,
               report_id: int = 2) -> bytes:
    """General pen packet (type 0-3).

    ``pressure`` in device units: for devices with ``max_pressure < 2047`` the
    parser halves the 11-bit value, so it is doubled here.
    """
    t = pressure << 1 if max_pressure < 2047 else pressure
    if not 0 <= t < 2048:
        raise ValueError("pressure out of the 11-bit range")
    d = _report(report_id, 10)
    _intuos_xy(d, x, y, distance)
    d[1] = 0xE0 | (t & 1)
    if buttons & Button.STYLUS:
        d[1] |= 0x02
    if buttons & Button.STYLUS2:
        d[1] |= 0x04
    d[6] = t >> 3
    t7, d[8] = _tilt_bits(tilt_x, tilt_y)
    d[7] = (((t >> 1) & 3) << 6) | t7
    return bytes(d)


def rotation_code(rotation: int) -> int:
    """The 11-bit code of an Art Pen rotation (-900..899), inverse of the parser's formula."""
    if not -900 <= rotation <= 899:
        raise ValueError("rotation is -900..899")
    if rotation > 450:
        return 2 * (rotation - 450) + 1
    if rotation >= -573:
        return 2 * (450 - rotation)
    return 2 * (rotation + 1350) + 1


def intuos_rotation(x: int, y: int, rotation: int, distance: int = 0,
                    report_id: int = 2) -> bytes:
    """Art Pen rotation packet (type 5)."""
    d = _report(report_id, 10)
    _intuos_xy(d, x, y, distance)
    d[1] = 0xE0 | (0x5 << 1)
    t = rotation_code(rotation)
    d[6], d[7] = t >> 3, (t & 7) << 5
    return bytes(d)


def intuos_airbrush(x: int, y: int, wheel: int, tilt_x: int = 0, tilt_y: int = 0,
                    distance: int = 0, report_id: int = 2) -> bytes:
    """Airbrush second packet (type 0xa): finger wheel 0..1023 and tilt."""
    if not 0 <= wheel < 1024:
        raise ValueError("wheel is 0..1023")
    d = _report(report_id, 10)
    _intuos_xy(d, x, y, distance)
    d[1] = 0xE0 | (0xA << 1)
    t7, d[8] = _tilt_bits(tilt_x, tilt_y)
    d[6], d[7] = wheel >> 2, ((wheel & 3) << 6) | t7
    return bytes(d)


def intuos_mouse(x: int, y: int, left: bool = False, right: bool = False,
                 middle: bool = False, distance: int = 0, report_id: int = 2) -> bytes:
    """Intuos4 mouse packet (type 6); buttons in d[6]."""
    d = _report(report_id, 10)
    _intuos_xy(d, x, y, distance)
    d[1] = 0xE0 | (0x6 << 1)
    d[6] = (1 if left else 0) | (2 if middle else 0) | (4 if right else 0)
    d[7], d[8] = 0x20, 0x40  # tilt 0, 0
    return bytes(d)


def intuos_lens(x: int, y: int, left: bool = False, right: bool = False,
                middle: bool = False, distance: int = 0, report_id: int = 2) -> bytes:
    """Lens cursor packet (type 8); buttons in d[8]."""
    d = _report(report_id, 10)
    _intuos_xy(d, x, y, distance)
    d[1] = 0xE0 | (0x8 << 1)
    d[8] = (1 if left else 0) | (2 if middle else 0) | (4 if right else 0)
    return bytes(d)


# -- Bamboo / Intuos-HT, Graphire ---------------------------------------------------------


def bamboo_pen(x: int, y: int, pressure: int = 0, tip: bool = False, buttons: int = 0,
               eraser: bool = False, in_range: bool = True, prox: bool = True,
               ready: bool = True, raw_distance: int = 0, length: int = 9) -> bytes:
    """Bamboo/Intuos-HT pen report; ``raw_distance`` is d[8] (the parser reports max - d[8])."""
    if length not in (9, 10):
        raise ValueError("Bamboo pen reports are 9 or 10 bytes")
    d = _report(2, length)
    d[1] = ((0x80 if in_range else 0) | (0x40 if prox else 0) | (0x20 if ready else 0)
            | (0x08 if eraser else 0) | (0x01 if tip else 0)
            | (0x02 if buttons & Button.STYLUS else 0) | (0x04 if buttons & Button.STYLUS2 else 0))
    d[2:4] = x.to_bytes(2, "little")
    d[4:6] = y.to_bytes(2, "little")
    d[6:8] = pressure.to_bytes(2, "little")
    d[8] = raw_distance
    return bytes(d)


GRAPHIRE_PEN, GRAPHIRE_ERASER, GRAPHIRE_WHEEL_MOUSE, GRAPHIRE_MOUSE = 0, 1, 2, 3


def graphire_report(x: int, y: int, pressure: int = 0, tool: int = GRAPHIRE_PEN,
                    tip: bool = False, buttons: int = 0, prox: bool = True,
                    bluetooth: bool = False, mouse_distance: int = 0) -> bytes:
    """Graphire 8-byte report (USB ID 2, Bluetooth ID 3).

    Pressure is 10 bits on USB (d[6], d[7] & 3) and 9 bits on Bluetooth
    (d[6], d[1] & 0x08).  ``mouse_distance`` is d[7] & 0x3f (USB) or, over
    Bluetooth, encoded in d[6] so that ``44 - (d[6] >> 2)`` gives it back.
    """
    d = _report(3 if bluetooth else 2, 8)
    d[1] = (0x80 if prox else 0) | ((tool & 3) << 5)
    d[2:4] = x.to_bytes(2, "little")
    d[4:6] = y.to_bytes(2, "little")
    if tool in (GRAPHIRE_PEN, GRAPHIRE_ERASER):
        d[1] |= (0x01 if tip else 0) | (0x02 if buttons & Button.STYLUS else 0)
        d[1] |= 0x04 if buttons & Button.STYLUS2 else 0
        if bluetooth:
            if not 0 <= pressure < 512:
                raise ValueError("Bluetooth Graphire pressure is 9 bits")
            d[6] = pressure & 0xFF
            d[1] |= 0x08 if pressure & 0x100 else 0
        else:
            if not 0 <= pressure < 1024:
                raise ValueError("Graphire pressure is 10 bits")
            d[6], d[7] = pressure & 0xFF, pressure >> 8
    else:
        d[1] |= (0x01 if buttons & Button.STYLUS else 0) | (0x02 if buttons & Button.STYLUS2 else 0)
        if tool == GRAPHIRE_WHEEL_MOUSE and buttons & Button.STYLUS3:
            d[1] |= 0x04
        if bluetooth:
            d[6] = (44 - mouse_distance) << 2
        else:
            d[7] = mouse_distance & 0x3F
    return bytes(d)


# -- descriptors --------------------------------------------------------------------------


def _unsigned_bytes(value: int) -> bytes:
    for n in (1, 2, 4):
        if 0 <= value < 1 << (8 * n):
            return value.to_bytes(n, "little")
    raise ValueError(f"{value} does not fit an item")


def _signed_bytes(value: int) -> bytes:
    for n in (1, 2, 4):
        if -(1 << (8 * n - 1)) <= value < 1 << (8 * n - 1):
            return value.to_bytes(n, "little", signed=True)
    raise ValueError(f"{value} does not fit an item")


class DescriptorBuilder:
    """Writes a report descriptor item by item (each method returns the builder).

    Values get the smallest item size that holds them; logical/physical
    minimums are written signed, maximums signed only when their minimum is
    negative — the way parsers read them.
    """

    def __init__(self) -> None:
        self.data = bytearray()
        self._logical_min = 0
        self._physical_min = 0

    def short(self, item_type: int, tag: int, payload: bytes = b"") -> DescriptorBuilder:
        size_code = {0: 0, 1: 1, 2: 2, 4: 3}[len(payload)]
        self.data.append((tag << 4) | (item_type << 2) | size_code)
        self.data += payload
        return self

    def raw(self, data: bytes) -> DescriptorBuilder:
        self.data += data
        return self

    def long_item(self, tag: int, payload: bytes) -> DescriptorBuilder:
        self.data += bytes([0xFE, len(payload), tag]) + payload
        return self

    # main
    def input(self, flags: int = FLAG_VARIABLE) -> DescriptorBuilder:
        return self.short(0, 0x8, _unsigned_bytes(flags))

    def output(self, flags: int = FLAG_VARIABLE) -> DescriptorBuilder:
        return self.short(0, 0x9, _unsigned_bytes(flags))

    def feature(self, flags: int = FLAG_VARIABLE) -> DescriptorBuilder:
        return self.short(0, 0xB, _unsigned_bytes(flags))

    def collection(self, kind: int) -> DescriptorBuilder:
        return self.short(0, 0xA, bytes([kind]))

    def end_collection(self) -> DescriptorBuilder:
        return self.short(0, 0xC)

    # global
    def usage_page(self, page: int) -> DescriptorBuilder:
        return self.short(1, 0x0, _unsigned_bytes(page))

    def logical(self, lo: int, hi: int) -> DescriptorBuilder:
        self._logical_min = lo
        self.short(1, 0x1, _signed_bytes(lo))
        return self.short(1, 0x2, _signed_bytes(hi) if lo < 0 else _unsigned_bytes(hi))

    def physical(self, lo: int, hi: int) -> DescriptorBuilder:
        self._physical_min = lo
        self.short(1, 0x3, _signed_bytes(lo))
        return self.short(1, 0x4, _signed_bytes(hi) if lo < 0 else _unsigned_bytes(hi))

    def unit_exponent(self, exponent: int) -> DescriptorBuilder:
        """Written as the 4-bit two's complement nibble most devices use."""
        return self.short(1, 0x5, bytes([exponent & 0xF]))

    def unit(self, unit: int) -> DescriptorBuilder:
        return self.short(1, 0x6, _unsigned_bytes(unit))

    def report_size(self, bits: int) -> DescriptorBuilder:
        return self.short(1, 0x7, _unsigned_bytes(bits))

    def report_id(self, rid: int) -> DescriptorBuilder:
        return self.short(1, 0x8, bytes([rid]))

    def report_count(self, count: int) -> DescriptorBuilder:
        return self.short(1, 0x9, _unsigned_bytes(count))

    def push(self) -> DescriptorBuilder:
        return self.short(1, 0xA)

    def pop(self) -> DescriptorBuilder:
        return self.short(1, 0xB)

    # local
    def usage(self, usage: int, extended: bool = False) -> DescriptorBuilder:
        """``usage`` is an id on the current page, or (extended) a 32-bit page<<16|id."""
        payload = usage.to_bytes(4, "little") if extended else _unsigned_bytes(usage & 0xFFFF)
        return self.short(2, 0x0, payload)

    def usage_range(self, lo: int, hi: int) -> DescriptorBuilder:
        self.short(2, 0x1, _unsigned_bytes(lo))
        return self.short(2, 0x2, _unsigned_bytes(hi))

    def delimiter(self, open_set: bool) -> DescriptorBuilder:
        return self.short(2, 0xA, bytes([1 if open_set else 0]))

    # composites
    def bits(self, page: int, usage_ids: Iterable[int]) -> DescriptorBuilder:
        """One-bit variables (switches) on ``page``."""
        ids = list(usage_ids)
        self.usage_page(page)
        for uid in ids:
            self.usage(uid)
        return self.logical(0, 1).report_size(1).report_count(len(ids)).input(FLAG_VARIABLE)

    def padding(self, bits: int) -> DescriptorBuilder:
        return self.report_size(bits).report_count(1).input(FLAG_CONSTANT)

    def value(self, page: int, uid: int, bits: int, lo: int, hi: int, *, phys: tuple[int, int]
              | None = None, unit: int | None = None, exponent: int | None = None,
              count: int = 1) -> DescriptorBuilder:
        """A variable value field (optionally with physical range, unit, exponent)."""
        self.usage_page(page).usage(uid).logical(lo, hi)
        if phys is not None:
            self.physical(*phys)
        if unit is not None:
            self.unit(unit)
        if exponent is not None:
            self.unit_exponent(exponent)
        return self.report_size(bits).report_count(count).input(FLAG_VARIABLE)

    def to_bytes(self) -> bytes:
        return bytes(self.data)


UNIT_CM, UNIT_RAD, UNIT_INCH, UNIT_DEG = 0x11, 0x12, 0x13, 0x14


def pth660_like_descriptor() -> bytes:
    """A Wacom Intuos Pro 2 (PTH-660)-like pen interface.

    Pen report 0x10: tip, barrel, eraser, invert, secondary barrel, 2 bits
    padding, in range; X 0..44800 and Y 0..29600 (22.4 x 14.8 cm: 200 units/mm);
    pressure 0..8191; X/Y tilt -9000..9000 over -90..90 degrees; Wacom vendor
    page 0xFF0D: serial (low 32 bits), serial high word, tool type, distance
    0..63.  Pad report 0x11 (8 express keys), a vendor feature report 0x02.
    """
    b = DescriptorBuilder()
    b.usage_page(U.PAGE_DIGITIZER).usage(0x02).collection(CollectionKind.APPLICATION)
    b.report_id(0x10).usage(0x20).collection(CollectionKind.PHYSICAL)
    b.bits(U.PAGE_DIGITIZER, [0x42, 0x44, 0x45, 0x3C, 0x5A]).padding(2)
    b.bits(U.PAGE_DIGITIZER, [0x32])
    b.push()
    b.value(U.PAGE_GENERIC_DESKTOP, 0x30, 16, 0, 44800, phys=(0, 2240), unit=UNIT_CM,
            exponent=-2)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x31, 16, 0, 29600, phys=(0, 1480))
    b.pop()
    b.physical(0, 0).unit(0).unit_exponent(0)
    b.value(U.PAGE_DIGITIZER, 0x30, 16, 0, 8191)
    b.value(U.PAGE_DIGITIZER, 0x3D, 16, -9000, 9000, phys=(-900, 900), unit=UNIT_DEG,
            exponent=-1)
    b.value(U.PAGE_DIGITIZER, 0x3E, 16, -9000, 9000)
    b.physical(0, 0).unit(0).unit_exponent(0)
    b.value(U.PAGE_WACOM_DIGITIZER, 0x5B, 32, 0, 0x7FFFFFFF)
    b.value(U.PAGE_WACOM_DIGITIZER, 0x5C, 32, 0, 0x7FFFFFFF)
    b.value(U.PAGE_WACOM_DIGITIZER, 0x77, 16, 0, 0xFFFF)
    b.value(U.PAGE_WACOM_DIGITIZER, 0x132, 8, 0, 63)
    b.end_collection()
    b.report_id(0x11).usage_page(U.PAGE_DIGITIZER).usage(0x39)
    b.collection(CollectionKind.PHYSICAL)
    b.usage_page(U.PAGE_BUTTON).usage_range(1, 8).logical(0, 1).report_size(1).report_count(8)
    b.input(FLAG_VARIABLE).end_collection()
    b.report_id(0x02).usage_page(0xFF00).usage(0x02).logical(0, 255).report_size(8)
    b.report_count(1).feature(FLAG_VARIABLE)
    b.end_collection()
    return b.to_bytes()


def huion_like_descriptor() -> bytes:
    """A Huion-like pen: report 0x0a, X 0..50800 / Y 0..31750 over 10 x 6.25 inches
    (5080 lpi = 200 units/mm), pressure 0..8191, tilt -60..60 degrees as signed bytes;
    plus a keyboard application (frame keys, report 0x03) that the pen parser skips."""
    b = DescriptorBuilder()
    b.usage_page(U.PAGE_DIGITIZER).usage(0x02).collection(CollectionKind.APPLICATION)
    b.report_id(0x0A).usage(0x20).collection(CollectionKind.PHYSICAL)
    b.bits(U.PAGE_DIGITIZER, [0x42, 0x44, 0x5A]).padding(2).bits(U.PAGE_DIGITIZER, [0x32])
    b.padding(2)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x30, 16, 0, 50800, phys=(0, 10000), unit=UNIT_INCH,
            exponent=-3)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x31, 16, 0, 31750, phys=(0, 6250))
    b.physical(0, 0).unit(0).unit_exponent(0)
    b.value(U.PAGE_DIGITIZER, 0x30, 16, 0, 8191)
    b.value(U.PAGE_DIGITIZER, 0x3D, 8, -60, 60, phys=(-60, 60), unit=UNIT_DEG, exponent=0)
    b.value(U.PAGE_DIGITIZER, 0x3E, 8, -60, 60)
    b.end_collection().end_collection()
    b.usage_page(U.PAGE_GENERIC_DESKTOP).usage(0x06).collection(CollectionKind.APPLICATION)
    b.report_id(0x03).usage_page(U.PAGE_KEYBOARD).usage_range(0xE0, 0xE7).logical(0, 1)
    b.report_size(1).report_count(8).input(FLAG_VARIABLE)
    b.usage_range(0x00, 0x65).logical(0, 0x65).report_size(8).report_count(6).input(0)
    b.end_collection()
    return b.to_bytes()


def ntrig_like_descriptor() -> bytes:
    """An N-trig / Microsoft-pen-like digitizer with odd bit packing.

    Report 0x02: tip, barrel, invert, eraser, in range, 3 bits padding;
    X 15 bits 0..9600 and Y 15 bits 0..7200 over 25.6 x 19.2 cm (37.5 units/mm),
    2 bits padding; pressure 10 bits; X/Y tilt signed 7 bits -60..60 degrees;
    twist 9 bits 0..359 degrees; transducer serial 32 bits (written as an
    extended 32-bit usage); Push/Pop around the tilt ranges.
    """
    b = DescriptorBuilder()
    b.usage_page(U.PAGE_DIGITIZER).usage(0x02).collection(CollectionKind.APPLICATION)
    b.report_id(0x02).usage(0x20).collection(CollectionKind.LOGICAL)
    b.bits(U.PAGE_DIGITIZER, [0x42, 0x44, 0x3C, 0x45, 0x32]).padding(3)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x30, 15, 0, 9600, phys=(0, 256), unit=UNIT_CM, exponent=-1)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x31, 15, 0, 7200, phys=(0, 192))
    b.padding(2)
    b.physical(0, 0).unit(0).unit_exponent(0)
    b.value(U.PAGE_DIGITIZER, 0x30, 10, 0, 1023)
    b.push()
    b.value(U.PAGE_DIGITIZER, 0x3D, 7, -60, 60, phys=(-60, 60), unit=UNIT_DEG, exponent=0)
    b.value(U.PAGE_DIGITIZER, 0x3E, 7, -60, 60)
    b.pop()
    b.value(U.PAGE_DIGITIZER, 0x41, 9, 0, 359, phys=(0, 359), unit=UNIT_DEG, exponent=0)
    b.physical(0, 0).unit(0)
    b.usage_page(U.PAGE_DIGITIZER).usage(U.DG_TRANSDUCER_SERIAL, extended=True)
    b.logical(0, 0x7FFFFFFF).report_size(32).report_count(1).input(FLAG_VARIABLE)
    b.end_collection().end_collection()
    return b.to_bytes()


def touch_descriptor(contacts: int = 2) -> bytes:
    """A multitouch interface (Touch Screen, report 0x03): ``contacts`` Finger collections
    (tip, confidence, contact id, X, Y) and a contact count; feature: contact count max."""
    b = DescriptorBuilder()
    b.usage_page(U.PAGE_DIGITIZER).usage(0x04).collection(CollectionKind.APPLICATION)
    b.report_id(0x03)
    for _ in range(contacts):
        b.usage_page(U.PAGE_DIGITIZER).usage(0x22).collection(CollectionKind.LOGICAL)
        b.bits(U.PAGE_DIGITIZER, [0x42, 0x47]).padding(6)
        b.value(U.PAGE_DIGITIZER, 0x51, 8, 0, 255)
        b.value(U.PAGE_GENERIC_DESKTOP, 0x30, 16, 0, 4095)
        b.value(U.PAGE_GENERIC_DESKTOP, 0x31, 16, 0, 4095)
        b.end_collection()
    b.value(U.PAGE_DIGITIZER, 0x54, 8, 0, contacts)
    b.report_id(0x04).usage(0x55).report_size(8).report_count(1).feature(FLAG_VARIABLE)
    b.end_collection()
    return b.to_bytes()


def wacom_protocol_descriptor(pen_bytes: int = 9, vendor_ids: Iterable[int] = ()) -> bytes:
    """A Wacom protocol pen interface as such tablets declare it: a boot mouse (report 1,
    the mouse mode) and a vendor-defined report 2 of ``pen_bytes`` payload bytes inside a
    Digitizer application, plus feature report 2 (the mode switch).  ``vendor_ids``: more
    vendor input reports of the same size that the pen protocol does not read (the
    PenPartner/PenStation2 declares report 0x63)."""
    b = DescriptorBuilder()
    b.usage_page(U.PAGE_GENERIC_DESKTOP).usage(0x02).collection(CollectionKind.APPLICATION)
    b.report_id(0x01).usage(0x01).collection(CollectionKind.PHYSICAL)
    b.bits(U.PAGE_BUTTON, [1, 2, 3]).padding(5)
    b.usage_page(U.PAGE_GENERIC_DESKTOP).usage(0x30).usage(0x31).logical(-127, 127)
    b.report_size(8).report_count(2).input(FLAG_VARIABLE | 0x04)
    b.end_collection().end_collection()
    b.usage_page(U.PAGE_DIGITIZER).usage(0x01).collection(CollectionKind.APPLICATION)
    b.report_id(0x02).usage_page(0xFF00).usage(0x01).logical(0, 255).report_size(8)
    b.report_count(pen_bytes).input(FLAG_VARIABLE)
    extra = list(vendor_ids)
    for rid in extra:
        b.report_id(rid).usage(0x01).input(FLAG_VARIABLE)
    if extra:
        b.report_id(0x02)
    b.usage(0x01).report_count(1).feature(FLAG_VARIABLE)
    b.end_collection()
    return b.to_bytes()


def encode_report(desc: Descriptor, report_id: int, values: Mapping[int, int | bool],
                  report_type: ReportType = ReportType.INPUT) -> bytes:
    """Build a report from usage -> value (the inverse of field extraction).

    Variables: the first slot carrying each usage gets its value (two's
    complement when the field is signed).  Arrays: a usage mapped to True is
    written into the next free slot.  Wacom vendor usages may be given as
    their standard equivalents.  Unset fields are 0.
    """
    layout = desc.reports.get((report_type, report_id))
    if layout is None:
        raise ValueError(f"no {report_type.value} report {report_id}")
    base = 8 if desc.numbered else 0
    acc = 0
    done: set[int] = set()
    for f in layout.fields:
        if f.is_constant:
            continue
        mask = (1 << f.size) - 1
        if f.is_variable:
            for i in range(f.count):
                raw_usage = f.slot_usage(i)
                usage = raw_usage if raw_usage in values else U.equivalent_usage(raw_usage)
                if usage in values and usage not in done:
                    done.add(usage)
                    acc |= (int(values[usage]) & mask) << (base + f.slot_offset(i))
        else:
            slot = 0
            for k, usage in enumerate(f.usages):
                if values.get(usage) and slot < f.count:
                    acc |= ((k + f.logical_min) & mask) << (base + f.slot_offset(slot))
                    slot += 1
    n = layout.length(desc.numbered)
    out = bytearray(acc.to_bytes(n, "little"))
    if desc.numbered:
        out[0] = report_id
    return bytes(out)


# -- hid-recorder text ------------------------------------------------------------------------


@dataclass
class RecordedDevice:
    """One device of a hid-recorder file.

    Attributes:
        name: the ``N:`` line.
        vid, pid: ids for the ``I:`` line; bus: 3 USB, 5 Bluetooth, 0x18 I2C.
        descriptor: the ``R:`` bytes.
        events: (time in seconds, report bytes) in time order.
        phys: the ``P:`` line (may be empty).
    """

    name: str
    vid: int
    pid: int
    descriptor: bytes
    events: list[tuple[float, bytes]] = field(default_factory=list)
    bus: int = 3
    phys: str = ""


def write_hid_recorder(devices: list[RecordedDevice], out: TextIO | str | Path | None = None,
                       *, upper: bool = False, pad: bool = True, start: float = 0.0,
                       comments: bool = True, always_device_lines: bool = False) -> str:
    """Write hid-recorder text; returns it (and writes it to ``out`` when given).

    Variants: ``upper`` hex digits, ``pad=False`` drops zero padding of bytes
    and seconds, ``start`` shifts every timestamp (recordings may start at
    any time), ``comments`` adds ``#`` lines.  Events of all devices are
    merged in time order with a ``D:`` line whenever the device changes
    (always, when more than one device, or ``always_device_lines``).  The text
    comes from the station's one hid-recorder writer
    (:class:`~station.drivers.traces.hidrecorder.HidRecorderWriter`).
    """
    buf = io.StringIO()
    writer = HidRecorderWriter(
        buf, upper=upper, pad=pad, pad_seconds=pad, origin=-start,
        device_lines=len(devices) > 1 or always_device_lines,
        comment="synthetic recording written by station.drivers.synth" if comments else None)
    for dev in devices:
        writer.add_device(dev.name, dev.vid, dev.pid, dev.bus, dev.descriptor, dev.phys,
                          comment=dev.name if comments else None)
    merged = sorted(((t, i, data) for i, dev in enumerate(devices) for t, data in dev.events),
                    key=lambda e: (e[0], e[1]))  # fmt: skip
    for t, i, data in merged:
        writer.write_report(t, data, device=i)
    text = buf.getvalue()
    if isinstance(out, (str, Path)):
        Path(out).write_text(text, encoding="utf-8")
    elif out is not None:
        out.write(text)
    return text


# -- whole synthetic recordings ------------------------------------------------------------


@dataclass(frozen=True)
class SynthDevice:
    """A synthetic device kind: ids, descriptor and report rate."""

    name: str
    vid: int
    pid: int
    bus: int
    descriptor: bytes
    rate_hz: float


def synth_devices() -> dict[str, SynthDevice]:
    """The device kinds :func:`stroke_recording` can write (one per supported protocol)."""
    return {
        "intuos-pro": SynthDevice("Wacom Intuos Pro M Pen", 0x056A, 0x0315, 3,
                                  wacom_protocol_descriptor(9), 200.0),
        "intuos4": SynthDevice("Wacom Intuos4 4x6 Pen", 0x056A, 0x00B8, 3,
                               wacom_protocol_descriptor(9), 190.0),
        "cintiq-22hd": SynthDevice("Wacom Cintiq 22HD Pen", 0x056A, 0x00FA, 3,
                                   wacom_protocol_descriptor(9), 128.0),
        "intuos-s": SynthDevice("Wacom Intuos S Pen", 0x056A, 0x030E, 3,
                                wacom_protocol_descriptor(9), 133.0),
        "bamboo-pen": SynthDevice("Wacom Bamboo Pen", 0x056A, 0x00D4, 3,
                                  wacom_protocol_descriptor(8), 133.0),
        "graphire": SynthDevice("Wacom Graphire", 0x056A, 0x0081, 3,
                                wacom_protocol_descriptor(7), 100.0),
        "graphire-bt": SynthDevice("Wacom Graphire Bluetooth", 0x056A, 0x0081, 5,
                                   wacom_protocol_descriptor(7), 100.0),
        "pth660": SynthDevice("Wacom Intuos Pro M Pen (PTH-660)", 0x056A, 0x0357, 3,
                              pth660_like_descriptor(), 200.0),
        "huion": SynthDevice("Huion-like Tablet Pen", 0x256C, 0x006D, 3,
                             huion_like_descriptor(), 233.0),
        "ntrig": SynthDevice("N-trig-like Pen", 0x1B96, 0x1B05, 0x18,
                             ntrig_like_descriptor(), 83.0),
        "touch": SynthDevice("Synthetic Touch", 0x056A, 0x0357, 3, touch_descriptor(), 100.0),
    }  # fmt: skip


def _times(n: int, rate_hz: float, start: float) -> list[float]:
    """Report times at ``rate_hz`` on USB 1 ms frames: intervals alternate around the period."""
    period_ms = 1000.0 / rate_hz
    lo, hi = math.floor(period_ms), math.ceil(period_ms)
    t, out = start, []
    for i in range(n):
        out.append(round(t, 6))
        t += (lo if i % 2 else hi) / 1000.0 if lo != hi else period_ms / 1000.0
    return out


def stroke_points(n: int) -> list[tuple[float, float, float, float, float]]:
    """A stroke of ``n`` points: (u, v) in [0.2, 0.8], pressure 0 -> 1 -> 0 (sine), tilt in
    [-1, 1] (a fraction of each protocol's tilt range)."""
    out = []
    for i in range(n):
        a = i / max(1, n - 1)
        out.append((0.2 + 0.6 * a, 0.5 + 0.3 * math.sin(2 * math.pi * a),
                    math.sin(math.pi * a), 0.5 * math.cos(math.pi * a), -0.25 + 0.5 * a))
    return out


def stroke_reports(kind: str, n: int = 50, tool_id: int = 0x802,
                   serial: int = 0x1A2B3C4) -> list[bytes]:
    """Reports of one stroke on a device kind of :func:`synth_devices`: proximity in, 3
    hover reports, ``n`` contact reports along :func:`stroke_points`, 2 hover reports,
    proximity out (for generic pens: an in-range-0 report)."""
    pts = stroke_points(n)
    hover = [(0.2, 0.5, 0.0, 0.0, 0.0)] * 3
    after = [(0.8, 0.5, 0.0, 0.0, 0.0)] * 2
    path = hover + pts + after
    if kind in ("intuos-pro", "intuos4", "cintiq-22hd"):
        mx, my = {"intuos-pro": (44704, 27940), "intuos4": (31496, 19685),
                  "cintiq-22hd": (95840, 54260)}[kind]  # fmt: skip
        out = [intuos_prox_in(tool_id, serial)]
        for u, v, p, tx, ty in path:
            out.append(intuos_pen(round(u * mx), round(v * my), round(p * 2047), round(tx * 63),
                                  round(ty * 63), 0 if p else 20))  # fmt: skip
        return [*out, intuos_prox_out()]
    if kind in ("intuos-s", "bamboo-pen"):
        mx, my = (15200, 9500) if kind == "intuos-s" else (14720, 9200)
        length = 10 if kind == "intuos-s" else 9
        out = [bamboo_pen(round(u * mx), round(v * my), round(p * 1023), tip=p > 0.05,
                          raw_distance=31 if p else 20, length=length)
               for u, v, p, _, _ in path]  # fmt: skip
        return [*out, bamboo_pen(0, 0, in_range=False, prox=False, ready=False, length=length)]
    if kind in ("graphire", "graphire-bt"):
        bt = kind == "graphire-bt"
        out = [graphire_report(round(u * 16704), round(v * 12064), round(p * 511), tip=p > 0.05,
                               bluetooth=bt) for u, v, p, _, _ in path]  # fmt: skip
        return [*out, graphire_report(0, 0, prox=False, bluetooth=bt)]
    if kind in ("pth660", "huion", "ntrig"):
        desc = parse_descriptor(synth_devices()[kind].descriptor)
        rid, mx, my, mp, mt = {"pth660": (0x10, 44800, 29600, 8191, 9000),
                               "huion": (0x0A, 50800, 31750, 8191, 60),
                               "ntrig": (0x02, 9600, 7200, 1023, 60)}[kind]  # fmt: skip
        out = []
        for u, v, p, tx, ty in path:
            out.append(encode_report(desc, rid, {
                U.GD_X: round(u * mx), U.GD_Y: round(v * my), U.DG_TIP_PRESSURE: round(p * mp),
                U.DG_TIP_SWITCH: int(p > 0.05), U.DG_IN_RANGE: 1, U.DG_X_TILT: round(tx * mt),
                U.DG_Y_TILT: round(ty * mt), U.DG_TRANSDUCER_SERIAL: serial,
                U.WD_TOOL_TYPE: tool_id,
            }))  # fmt: skip
        out.append(encode_report(desc, rid, {U.GD_X: round(0.8 * mx), U.GD_Y: round(0.5 * my)}))
        return out
    if kind == "touch":
        d = parse_descriptor(touch_descriptor())
        return [encode_report(d, 0x03, {U.DG_TIP_SWITCH: 1, U.GD_X: 100 + i, U.GD_Y: 200,
                                         U.DG_CONTACT_COUNT: 1})
                for i in range(n)]  # fmt: skip
    raise ValueError(f"unknown synthetic device kind {kind!r} (one of {sorted(synth_devices())})")


def stroke_recording(kind: str, n: int = 50, start: float = 0.0, tool_id: int = 0x802,
                     serial: int = 0x1A2B3C4) -> RecordedDevice:
    """One device of a hid-recorder file holding a stroke (see :func:`stroke_reports`),
    timed at the device's report rate with USB-frame jitter, starting at ``start``."""
    dev = synth_devices()[kind]
    reports = stroke_reports(kind, n, tool_id, serial)
    times = _times(len(reports), dev.rate_hz, start)
    return RecordedDevice(dev.name, dev.vid, dev.pid, dev.descriptor,
                          list(zip(times, reports, strict=True)), bus=dev.bus,
                          phys=f"usb-0000:00:14.0-1/input0#{kind}")  # fmt: skip


# -- UC-Logic -------------------------------------------------------------------------------
def uclogic_pen_report(kind: str, x: int, y: int, pressure: int, tip: bool = False,
                       buttons: int = 0, in_range: bool = True, tilt_x: int = 0,
                       tilt_y: int = 0) -> bytes:
    """A full-resolution UC-Logic pen report as the tablet sends it (inverse of
    :func:`station.drivers.uclogic.parser.decode`): v1 report 7, v2 report 8, ugee-v2 report 2."""
    flags = (0x01 if tip else 0) | (0x02 if buttons & Button.STYLUS else 0) | (
        0x04 if buttons & Button.STYLUS2 else 0)
    if kind == "v1":
        flags |= 0 if in_range else 0x40  # the in-range bit is inverted
        return bytes([7, flags]) + b"".join(v.to_bytes(2, "little") for v in (x, y, pressure))
    if kind == "v2":
        return bytes([8, flags | 0x80, x & 0xFF, (x >> 8) & 0xFF, y & 0xFF, (y >> 8) & 0xFF,
                      pressure & 0xFF, pressure >> 8, x >> 16, y >> 16, tilt_x & 0xFF,
                      (-tilt_y) & 0xFF])  # fmt: skip
    if kind == "ugee-v2":
        flags |= 0x20 if in_range else 0
        return bytes([2, flags, x & 0xFF, x >> 8, y & 0xFF, y >> 8, pressure & 0xFF,
                      (pressure >> 8) & 0x1F, tilt_x & 0xFF, tilt_y & 0xFF])  # fmt: skip
    raise ValueError(f"unknown UC-Logic report kind {kind!r}")


def uclogic_compat_descriptor(max_x: int, max_y: int) -> bytes:
    """A UC-Logic compatibility-mode pen (before the set-up): report 9, X/Y at a quarter of
    the full resolution over the same inches, 10-bit pressure; lpi 1000 per axis unit."""
    b = DescriptorBuilder()
    b.usage_page(U.PAGE_DIGITIZER).usage(0x02).collection(CollectionKind.APPLICATION)
    b.report_id(0x09).usage(0x20).collection(CollectionKind.PHYSICAL)
    b.bits(U.PAGE_DIGITIZER, [0x42, 0x44, 0x5A]).padding(2).bits(U.PAGE_DIGITIZER, [0x32])
    b.padding(2)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x30, 16, 0, max_x // 4, phys=(0, max_x // 4), unit=UNIT_INCH,
            exponent=-3)
    b.value(U.PAGE_GENERIC_DESKTOP, 0x31, 16, 0, max_y // 4, phys=(0, max_y // 4))
    b.physical(0, 0).unit(0).unit_exponent(0)
    b.value(U.PAGE_DIGITIZER, 0x30, 16, 0, 1023)
    b.end_collection().end_collection()
    return b.to_bytes()


def uclogic_compat_report(x: int, y: int, pressure: int, tip: bool, in_range: bool) -> bytes:
    """A report of :func:`uclogic_compat_descriptor` (x, y already at compat resolution)."""
    flags = (0x01 if tip else 0) | (0x20 if in_range else 0)
    return bytes([9, flags]) + b"".join(v.to_bytes(2, "little") for v in (x, y, pressure))
