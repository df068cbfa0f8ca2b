"""Synthetic report descriptors: :class:`DescriptorBuilder` writes them item by
item; typical ones (PTH-660-like, Huion-like, N-trig-like, touch, the Wacom
protocol interfaces, UC-Logic compatibility mode); :func:`encode_report` fills
any descriptor-defined report."""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from station.drivers.hid import usages as U
from station.drivers.hid.descriptor import (
    FLAG_CONSTANT,
    FLAG_VARIABLE,
    CollectionKind,
    Descriptor,
    ReportType,
)

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


