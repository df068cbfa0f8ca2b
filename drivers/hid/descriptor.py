"""HID report-descriptor parser and report field extraction (pure, no I/O).

A report descriptor is a byte string of *items* (HID 1.11 §6.2.2): short items
(one prefix byte ``tag:4 type:2 size:2`` and 0, 1, 2 or 4 data bytes) and long
items (prefix 0xFE, data size, long tag, data).  Main items (Input, Output,
Feature) declare report fields using the global state (usage page, logical and
physical ranges, unit, unit exponent, report size/count/ID) and the local state
(usages) collected since the previous main item.

:func:`parse_descriptor` validates the whole descriptor — truncated items,
unbalanced collections or delimiters, pop without push, report IDs out of
range, Report Size above 256 bits, reports longer than 16 KiB — raising
:class:`DescriptorError` that names the byte offset, and builds one
:class:`Report` layout per (report type, report ID).  Signedness and unit
exponent decoding follow the Linux HID core, so layouts and resolutions match
what the kernel shows on evdev.

Why the station parses descriptors itself although hid-tools (a dependency) has
``hidtools.hid.ReportDescriptor`` (measured, tests/test_descriptor_vs_hidtools.py):
hid-tools 0.12 decodes the real-world quirks this parser was fixed for (Push/Pop
around X/Y, a 64-bit USI serial with a 1..255 logical range, Report Count 2 with
one usage) exactly as this one does, and parses faster (446 vs 735 us per
descriptor on 6 descriptors, 2 loaded cores); but it accepts descriptors the
kernel refuses (a report past the 16 KiB buffer, a 257-bit Report Size) and fails
on truncated or unbalanced ones (Pop without Push) with a bare IndexError, where
the station must refuse hostile input with the byte offset and the item (exit 2)
and keep running.  Not checked: the 800 real descriptors of wacom-hid-descriptors
(not on this machine).
"""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Final

from station.drivers.hid.errors import DescriptorError, ReportError

MAX_DESCRIPTOR_BYTES: Final = 4096  # the kernel's HID_MAX_DESCRIPTOR_SIZE
# The kernel's HID_MAX_BUFFER_SIZE is 16384 bytes with the ID byte: real I2C screens declare
# vendor input reports of 7487 bytes (ELAN 04f3:2fc4), so 4096 would refuse their pen.
MAX_REPORT_BYTES: Final = 16383
MAX_VALUE_BITS: Final = 32  # wider data fields are opaque blobs (never read as values)
MAX_REPORT_SIZE: Final = 256  # Report Size above this is refused (as the kernel does)
MAX_SERIAL_BITS: Final = 64  # transducer serial numbers may be 64-bit
MAX_USAGES: Final = 12288  # the kernel's HID_MAX_USAGES (per main item)
MAX_COLLECTION_DEPTH: Final = 32
MAX_PUSH_DEPTH: Final = 16

_SERIAL_USAGES = frozenset({0x000D005B, 0xFF0D005B, 0xFF0D005C})


class ItemType(enum.IntEnum):
    MAIN = 0
    GLOBAL = 1
    LOCAL = 2
    RESERVED = 3
    LONG = 4  # not a bType value: marks long items


class ReportType(str, enum.Enum):
    INPUT = "input"
    OUTPUT = "output"
    FEATURE = "feature"


# Main item tags
TAG_INPUT, TAG_OUTPUT, TAG_COLLECTION, TAG_FEATURE, TAG_END_COLLECTION = 0x8, 0x9, 0xA, 0xB, 0xC
_MAIN_REPORT_TYPES = {
    TAG_INPUT: ReportType.INPUT,
    TAG_OUTPUT: ReportType.OUTPUT,
    TAG_FEATURE: ReportType.FEATURE,
}
# Global item tags
(G_USAGE_PAGE, G_LOGICAL_MIN, G_LOGICAL_MAX, G_PHYSICAL_MIN, G_PHYSICAL_MAX, G_UNIT_EXPONENT,
 G_UNIT, G_REPORT_SIZE, G_REPORT_ID, G_REPORT_COUNT, G_PUSH, G_POP) = range(12)  # fmt: skip
# Local item tags
(L_USAGE, L_USAGE_MIN, L_USAGE_MAX, L_DESIGNATOR_INDEX, L_DESIGNATOR_MIN, L_DESIGNATOR_MAX,
 _L_RESERVED, L_STRING_INDEX, L_STRING_MIN, L_STRING_MAX, L_DELIMITER) = range(11)  # fmt: skip

# Main item data flags (Input/Output/Feature)
FLAG_CONSTANT = 0x001
FLAG_VARIABLE = 0x002
FLAG_RELATIVE = 0x004
FLAG_WRAP = 0x008
FLAG_NONLINEAR = 0x010
FLAG_NO_PREFERRED = 0x020
FLAG_NULL_STATE = 0x040
FLAG_VOLATILE = 0x080
FLAG_BUFFERED_BYTES = 0x100


class CollectionKind(enum.IntEnum):
    PHYSICAL = 0
    APPLICATION = 1
    LOGICAL = 2
    REPORT = 3
    NAMED_ARRAY = 4
    USAGE_SWITCH = 5
    USAGE_MODIFIER = 6


_ITEM_NAMES = {
    (ItemType.MAIN, TAG_INPUT): "Input", (ItemType.MAIN, TAG_OUTPUT): "Output",
    (ItemType.MAIN, TAG_FEATURE): "Feature", (ItemType.MAIN, TAG_COLLECTION): "Collection",
    (ItemType.MAIN, TAG_END_COLLECTION): "End Collection",
    (ItemType.GLOBAL, G_USAGE_PAGE): "Usage Page",
    (ItemType.GLOBAL, G_LOGICAL_MIN): "Logical Minimum",
    (ItemType.GLOBAL, G_LOGICAL_MAX): "Logical Maximum",
    (ItemType.GLOBAL, G_PHYSICAL_MIN): "Physical Minimum",
    (ItemType.GLOBAL, G_PHYSICAL_MAX): "Physical Maximum",
    (ItemType.GLOBAL, G_UNIT_EXPONENT): "Unit Exponent", (ItemType.GLOBAL, G_UNIT): "Unit",
    (ItemType.GLOBAL, G_REPORT_SIZE): "Report Size", (ItemType.GLOBAL, G_REPORT_ID): "Report ID",
    (ItemType.GLOBAL, G_REPORT_COUNT): "Report Count", (ItemType.GLOBAL, G_PUSH): "Push",
    (ItemType.GLOBAL, G_POP): "Pop",
    (ItemType.LOCAL, L_USAGE): "Usage", (ItemType.LOCAL, L_USAGE_MIN): "Usage Minimum",
    (ItemType.LOCAL, L_USAGE_MAX): "Usage Maximum",
    (ItemType.LOCAL, L_DESIGNATOR_INDEX): "Designator Index",
    (ItemType.LOCAL, L_DESIGNATOR_MIN): "Designator Minimum",
    (ItemType.LOCAL, L_DESIGNATOR_MAX): "Designator Maximum",
    (ItemType.LOCAL, L_STRING_INDEX): "String Index",
    (ItemType.LOCAL, L_STRING_MIN): "String Minimum",
    (ItemType.LOCAL, L_STRING_MAX): "String Maximum", (ItemType.LOCAL, L_DELIMITER): "Delimiter",
}  # fmt: skip


@dataclass(frozen=True, slots=True)
class Item:
    """One descriptor item.

    Attributes:
        offset: byte offset of the item's prefix in the descriptor.
        type: main, global, local, reserved, or long.
        tag: the item tag (4 bits for short items, 8 for long items).
        data: the item's data bytes (0, 1, 2 or 4 for short items).
    """

    offset: int
    type: ItemType
    tag: int
    data: bytes

    @property
    def size(self) -> int:
        return len(self.data)

    @property
    def unsigned(self) -> int:
        """Data as an unsigned little-endian integer."""
        return int.from_bytes(self.data, "little")

    @property
    def signed(self) -> int:
        """Data as a signed (two's complement, of its own size) little-endian integer."""
        return int.from_bytes(self.data, "little", signed=True) if self.data else 0

    @property
    def name(self) -> str:
        if self.type == ItemType.LONG:
            return f"Long Item 0x{self.tag:02x}"
        return _ITEM_NAMES.get((self.type, self.tag), f"{self.type.name.title()} tag {self.tag}")


def iter_items(data: bytes) -> list[Item]:
    """Split a descriptor into items; a truncated item raises :class:`DescriptorError`."""
    items: list[Item] = []
    i, n = 0, len(data)
    while i < n:
        prefix = data[i]
        if prefix == 0xFE:  # long item: FE, bDataSize, bLongItemTag, data
            if i + 3 > n:
                raise DescriptorError("long item header truncated", i)
            size, tag = data[i + 1], data[i + 2]
            if i + 3 + size > n:
                raise DescriptorError(
                    f"long item declares {size} data bytes, only {n - i - 3} remain", i
                )
            items.append(Item(i, ItemType.LONG, tag, bytes(data[i + 3 : i + 3 + size])))
            i += 3 + size
            continue
        size = (0, 1, 2, 4)[prefix & 3]
        if i + 1 + size > n:
            raise DescriptorError(
                f"item 0x{prefix:02x} declares {size} data bytes, only {n - i - 1} remain", i
            )
        items.append(Item(i, ItemType((prefix >> 2) & 3), prefix >> 4,
                          bytes(data[i + 1 : i + 1 + size])))  # fmt: skip
        i += 1 + size
    return items


def decode_unit_exponent(value: int) -> int:
    """The unit exponent as the kernel reads it.

    HID 1.11 says a signed integer, but most devices write a 4-bit two's
    complement nibble (0x0E = -2); values 0..15 are read as a nibble.
    """
    if 0 <= value <= 15:
        return value - 16 if value & 0x8 else value
    return value


def _nibble(value: int, index: int) -> int:
    v = (value >> (4 * index)) & 0xF
    return v - 16 if v & 0x8 else v


UNIT_SYSTEMS = {0: "none", 1: "SI linear", 2: "SI rotation", 3: "English linear",
                4: "English rotation"}  # fmt: skip


@dataclass(frozen=True, slots=True)
class Unit:
    """A decoded HID unit: system and the exponents of length, mass, time … (nibbles 1-6)."""

    system: int
    length: int
    mass: int
    time: int
    temperature: int
    current: int
    luminous: int

    @classmethod
    def decode(cls, value: int) -> Unit:
        return cls(value & 0xF, *(_nibble(value, k) for k in range(1, 7)))


@dataclass(frozen=True, slots=True)
class GlobalState:
    usage_page: int = 0
    logical_min: int = 0
    logical_max: int = 0
    physical_min: int = 0
    physical_max: int = 0
    unit_exponent: int = 0
    unit: int = 0
    report_size: int = 0
    report_id: int = 0
    report_count: int = 0


@dataclass(frozen=True, slots=True)
class Collection:
    """A collection: its kind, usage, parent index (-1 for top level) and byte offset."""

    kind: int
    usage: int
    parent: int
    offset: int


@dataclass(frozen=True, slots=True)
class Field:
    """One Input/Output/Feature main item: ``count`` slots of ``size`` bits.

    Attributes:
        report_type: input, output or feature.
        report_id: the report ID (0 when the descriptor declares none).
        bit_offset: bit offset of the first slot in the report *payload* (after
            the report ID byte, if any).
        size: bits per slot.
        count: number of slots.
        flags: main item data flags (``FLAG_*``).
        usages: variables: one 32-bit usage per slot; arrays: the usage list
            that array values index (value - logical_min).
        logical_min, logical_max: logical range (signed when logical_min < 0).
        physical_min, physical_max: physical range as declared (0, 0 = none).
        unit: raw HID unit value; unit_exponent: decoded exponent.
        application: usage of the enclosing application collection (0 if none).
        collections: indices into :attr:`Descriptor.collections`, outermost first.
        offset: byte offset of the main item in the descriptor.
    """

    report_type: ReportType
    report_id: int
    bit_offset: int
    size: int
    count: int
    flags: int
    usages: tuple[int, ...]
    logical_min: int
    logical_max: int
    physical_min: int
    physical_max: int
    unit: int
    unit_exponent: int
    application: int
    collections: tuple[int, ...]
    offset: int

    @property
    def is_constant(self) -> bool:
        return bool(self.flags & FLAG_CONSTANT)

    @property
    def is_variable(self) -> bool:
        return bool(self.flags & FLAG_VARIABLE)

    @property
    def is_array(self) -> bool:
        return not self.flags & FLAG_VARIABLE

    @property
    def is_relative(self) -> bool:
        return bool(self.flags & FLAG_RELATIVE)

    @property
    def signed(self) -> bool:
        """Values are two's complement (sign-extended) when logical_min < 0."""
        return self.logical_min < 0

    @property
    def bits(self) -> int:
        return self.size * self.count

    @property
    def is_opaque(self) -> bool:
        """A data field too wide to be a value (vendor blobs such as Huion's 104-bit
        report 8): kept in the layout for lengths and offsets, never read as a value."""
        if self.is_constant or self.size <= MAX_VALUE_BITS:
            return False
        serial = bool(self.usages) and all(u in _SERIAL_USAGES for u in self.usages)
        return not (serial and self.size <= MAX_SERIAL_BITS)

    def slot_usage(self, index: int) -> int:
        """Usage of variable slot ``index`` (0 when the field declared no usage)."""
        return self.usages[index] if index < len(self.usages) else 0

    def slot_offset(self, index: int) -> int:
        return self.bit_offset + index * self.size


@dataclass(slots=True)
class Report:
    """Layout of one report: its fields in order and its payload length in bits."""

    report_type: ReportType
    report_id: int
    fields: list[Field] = field(default_factory=list)
    bits: int = 0

    @property
    def payload_bytes(self) -> int:
        return (self.bits + 7) // 8

    def length(self, numbered: bool) -> int:
        """Bytes on the wire: payload plus the ID byte when the descriptor numbers reports."""
        return self.payload_bytes + (1 if numbered else 0)


@dataclass(slots=True)
class Descriptor:
    """A parsed report descriptor.

    Attributes:
        raw: the descriptor bytes.
        items: every item in order.
        collections: every collection in order of appearance.
        fields: every Input/Output/Feature field in order of appearance.
        reports: layouts keyed by (report type, report ID).
        numbered: True when any Report ID item exists (reports then start with the ID byte).
        warnings: oddities that are tolerated (long items, reserved items …).
    """

    raw: bytes
    items: list[Item]
    collections: list[Collection]
    fields: list[Field]
    reports: dict[tuple[ReportType, int], Report]
    numbered: bool
    warnings: list[str]

    def input_reports(self) -> list[Report]:
        return [r for (t, _), r in sorted(self.reports.items(), key=lambda kv: kv[0][1])
                if t == ReportType.INPUT]  # fmt: skip

    def report(self, report_type: ReportType, report_id: int) -> Report | None:
        return self.reports.get((report_type, report_id))

    def collection_usages(self, f: Field) -> tuple[int, ...]:
        """Usages of the collections enclosing ``f``, outermost first."""
        return tuple(self.collections[i].usage for i in f.collections)

    def application_usages(self) -> list[int]:
        return [c.usage for c in self.collections if c.kind == CollectionKind.APPLICATION]


# -- parsing -----------------------------------------------------------------


@dataclass(slots=True)
class _Local:
    """Local state between main items (HID 1.11 §6.2.2.8)."""

    usages: list[int] = field(default_factory=list)  # 32-bit usages
    sizes: list[int] = field(default_factory=list)  # item data size of each usage (<=2: paged)
    usage_min: int | None = None
    usage_min_size: int = 0
    delimiter_depth: int = 0
    delimiter_branch: int = 0


def _complete_usage(page: int, value: int, size: int) -> int:
    # Extended usages (4-byte data) carry their own page in the high word.
    return value if size > 2 else (page << 16) | (value & 0xFFFF)


def _concatenate_last_page(local: _Local, page: int) -> None:
    """Re-page the trailing short usages with the last declared usage page.

    Same rule as the kernel: a Usage Page item placed after some usages but
    before the main item applies to them, walking back until a usage already
    on that page.
    """
    for i in range(len(local.usages) - 1, -1, -1):
        if local.sizes[i] > 2:
            continue
        if local.usages[i] >> 16 == page:
            break
        local.usages[i] = (page << 16) | (local.usages[i] & 0xFFFF)


def parse_descriptor(data: bytes) -> Descriptor:
    """Parse and validate a report descriptor (see the module docstring)."""
    data = bytes(data)
    if not data:
        raise DescriptorError("empty report descriptor", 0)
    if len(data) > MAX_DESCRIPTOR_BYTES:
        raise DescriptorError(
            f"descriptor is {len(data)} bytes, more than the {MAX_DESCRIPTOR_BYTES} allowed", 0
        )
    items = iter_items(data)
    g = GlobalState()
    stack: list[GlobalState] = []
    local = _Local()
    collections: list[Collection] = []
    open_collections: list[int] = []
    fields: list[Field] = []
    reports: dict[tuple[ReportType, int], Report] = {}
    numbered = False
    warnings: list[str] = []

    def add_usage(value: int, size: int, offset: int) -> None:
        if len(local.usages) >= MAX_USAGES:
            raise DescriptorError(f"more than {MAX_USAGES} usages before one main item", offset)
        local.usages.append(_complete_usage(g.usage_page, value, size))
        local.sizes.append(size)

    for it in items:
        if it.type == ItemType.LONG:
            warnings.append(f"byte {it.offset}: long item 0x{it.tag:02x} ignored")
            continue
        if it.type == ItemType.RESERVED:
            warnings.append(f"byte {it.offset}: reserved item tag {it.tag} ignored")
            continue
        if it.type == ItemType.GLOBAL:
            g = _apply_global(g, it, stack)
            if it.tag == G_REPORT_ID:
                numbered = True
            continue
        if it.type == ItemType.LOCAL:
            _apply_local(local, it, add_usage, g)
            continue
        # main items
        if it.tag == TAG_COLLECTION:
            if len(open_collections) >= MAX_COLLECTION_DEPTH:
                raise DescriptorError(
                    f"collections nested deeper than {MAX_COLLECTION_DEPTH}", it.offset
                )
            _concatenate_last_page(local, g.usage_page)
            usage = local.usages[0] if local.usages else 0
            parent = open_collections[-1] if open_collections else -1
            kind = it.unsigned & 0xFF
            collections.append(Collection(kind, usage, parent, it.offset))
            open_collections.append(len(collections) - 1)
        elif it.tag == TAG_END_COLLECTION:
            if not open_collections:
                raise DescriptorError("End Collection without an open Collection", it.offset)
            open_collections.pop()
        elif it.tag in _MAIN_REPORT_TYPES:
            _concatenate_last_page(local, g.usage_page)
            f = _make_field(it, g, local, collections, open_collections, reports, numbered)
            if f is not None:
                fields.append(f)
                if f.is_opaque:
                    warnings.append(f"byte {it.offset}: {f.size}-bit {f.report_type.value} "
                                    f"field of report {f.report_id} is opaque (not a value)")
        else:
            warnings.append(f"byte {it.offset}: unknown main item tag {it.tag} ignored")
        if local.delimiter_depth:
            raise DescriptorError("main item inside an open Delimiter set", it.offset)
        local = _Local()

    if open_collections:
        first = collections[open_collections[-1]]
        raise DescriptorError(
            f"{len(open_collections)} collection(s) left open at the end of the descriptor "
            f"(innermost opened at byte {first.offset})",
            len(data),
        )
    if local.delimiter_depth:
        raise DescriptorError("Delimiter set left open at the end of the descriptor", len(data))
    if numbered and any(f.report_id == 0 for f in fields if not f.is_constant):
        warnings.append("fields before the first Report ID are unreachable (report ID 0)")
    return Descriptor(data, items, collections, fields, reports, numbered, warnings)


def _apply_global(g: GlobalState, it: Item, stack: list[GlobalState]) -> GlobalState:
    tag = it.tag
    if tag == G_USAGE_PAGE:
        return _replace(g, usage_page=it.unsigned & 0xFFFF)
    if tag == G_LOGICAL_MIN:
        return _replace(g, logical_min=it.signed)
    if tag == G_LOGICAL_MAX:
        # Signed only when the minimum is negative (as the kernel reads it).
        return _replace(g, logical_max=it.signed if g.logical_min < 0 else it.unsigned)
    if tag == G_PHYSICAL_MIN:
        return _replace(g, physical_min=it.signed)
    if tag == G_PHYSICAL_MAX:
        return _replace(g, physical_max=it.signed if g.physical_min < 0 else it.unsigned)
    if tag == G_UNIT_EXPONENT:
        return _replace(g, unit_exponent=decode_unit_exponent(it.signed))
    if tag == G_UNIT:
        return _replace(g, unit=it.unsigned)
    if tag == G_REPORT_SIZE:
        size = it.unsigned
        if size > MAX_REPORT_SIZE:
            raise DescriptorError(f"Report Size {size} bits is absurd (at most {MAX_REPORT_SIZE})",
                                  it.offset)
        return _replace(g, report_size=size)
    if tag == G_REPORT_COUNT:
        count = it.unsigned
        if count > MAX_REPORT_BYTES * 8:
            raise DescriptorError(f"Report Count {count} is absurd", it.offset)
        return _replace(g, report_count=count)
    if tag == G_REPORT_ID:
        rid = it.unsigned
        if not 1 <= rid <= 255:
            raise DescriptorError(f"Report ID {rid} out of range 1..255", it.offset)
        return _replace(g, report_id=rid)
    if tag == G_PUSH:
        if len(stack) >= MAX_PUSH_DEPTH:
            raise DescriptorError(f"Push nested deeper than {MAX_PUSH_DEPTH}", it.offset)
        stack.append(g)
        return g
    if tag == G_POP:
        if not stack:
            raise DescriptorError("Pop without a matching Push", it.offset)
        return stack.pop()
    raise DescriptorError(f"unknown global item tag {tag}", it.offset)


def _replace(g: GlobalState, **changes: int) -> GlobalState:
    return dataclasses.replace(g, **changes)


def _apply_local(
    local: _Local, it: Item, add_usage: Callable[[int, int, int], None], g: GlobalState
) -> None:
    tag = it.tag
    if tag == L_DELIMITER:
        if it.unsigned:
            if local.delimiter_depth:
                raise DescriptorError("nested Delimiter sets", it.offset)
            local.delimiter_depth += 1
            local.delimiter_branch += 1
        else:
            if local.delimiter_depth < 1:
                raise DescriptorError("Delimiter close without an open set", it.offset)
            local.delimiter_depth -= 1
        return
    if tag in (L_USAGE, L_USAGE_MIN, L_USAGE_MAX) and local.delimiter_branch > 1:
        return  # alternative usages of a delimiter set: only the first set counts
    if tag == L_USAGE:
        add_usage(it.unsigned, it.size, it.offset)
    elif tag == L_USAGE_MIN:
        local.usage_min = it.unsigned
        local.usage_min_size = it.size
    elif tag == L_USAGE_MAX:
        if local.usage_min is None:
            raise DescriptorError("Usage Maximum without a Usage Minimum", it.offset)
        lo = _complete_usage(g.usage_page, local.usage_min, local.usage_min_size)
        hi = _complete_usage(g.usage_page, it.unsigned, it.size)
        if hi < lo:
            raise DescriptorError(
                f"Usage Maximum 0x{hi:08x} below Usage Minimum 0x{lo:08x}", it.offset
            )
        if hi - lo + 1 > MAX_USAGES:
            raise DescriptorError(
                f"usage range of {hi - lo + 1} usages is absurd (at most {MAX_USAGES})", it.offset
            )
        size = max(it.size, local.usage_min_size)
        for usage in range(lo, hi + 1):
            add_usage(usage if size > 2 else usage & 0xFFFF, size, it.offset)
        local.usage_min = None
    elif tag in (L_DESIGNATOR_INDEX, L_DESIGNATOR_MIN, L_DESIGNATOR_MAX, L_STRING_INDEX,
                 L_STRING_MIN, L_STRING_MAX):  # fmt: skip
        pass  # physical descriptors and strings: parsed, not needed for pens
    else:
        raise DescriptorError(f"unknown local item tag {tag}", it.offset)


def _make_field(
    it: Item,
    g: GlobalState,
    local: _Local,
    collections: list[Collection],
    open_collections: list[int],
    reports: dict[tuple[ReportType, int], Report],
    numbered: bool,
) -> Field | None:
    rtype = _MAIN_REPORT_TYPES[it.tag]
    flags = it.unsigned
    report = reports.get((rtype, g.report_id))
    if report is None:
        report = reports[(rtype, g.report_id)] = Report(rtype, g.report_id)
    bits = g.report_size * g.report_count
    if report.bits + bits > MAX_REPORT_BYTES * 8:
        raise DescriptorError(
            f"{rtype.value} report {g.report_id} grows past {MAX_REPORT_BYTES} bytes", it.offset
        )
    usages = tuple(local.usages)
    if bits == 0:
        return None
    if flags & FLAG_VARIABLE and len(usages) > g.report_count:
        usages = usages[: g.report_count]
    elif flags & FLAG_VARIABLE and usages:
        # Slots beyond the declared usages repeat the last usage (HID 1.11 §6.2.2.8).
        usages = usages + (usages[-1],) * (g.report_count - len(usages))
    application = 0
    for idx in open_collections:
        if collections[idx].kind == CollectionKind.APPLICATION:
            application = collections[idx].usage
    f = Field(
        report_type=rtype,
        report_id=g.report_id,
        bit_offset=report.bits,
        size=g.report_size,
        count=g.report_count,
        flags=flags,
        usages=usages,
        logical_min=g.logical_min,
        logical_max=g.logical_max,
        physical_min=g.physical_min,
        physical_max=g.physical_max,
        unit=g.unit,
        unit_exponent=g.unit_exponent,
        application=application,
        collections=tuple(open_collections),
        offset=it.offset,
    )
    report.fields.append(f)
    report.bits += bits
    return f


# -- field extraction -----------------------------------------------------------


def extract_bits(report: bytes, bit_offset: int, size: int, signed: bool = False) -> int:
    """Little-endian bit extraction: ``size`` bits from ``bit_offset`` of ``report``.

    HID packs fields LSB first within little-endian bytes; ``signed`` sign-extends
    the result from ``size`` bits.  Bits past the end of ``report`` read as 0.
    """
    first = bit_offset >> 3
    last = (bit_offset + size + 7) >> 3
    v = (int.from_bytes(report[first:last], "little") >> (bit_offset & 7)) & ((1 << size) - 1)
    if signed and size and v >> (size - 1):
        v -= 1 << size
    return v


def field_values(desc: Descriptor, f: Field, report: bytes) -> list[int]:
    """Every slot of field ``f`` in ``report`` (a full report, ID byte included if numbered)."""
    base = 8 if desc.numbered else 0
    return [extract_bits(report, base + f.slot_offset(i), f.size, f.signed) for i in range(f.count)]


def array_usages(f: Field, values: list[int]) -> set[int]:
    """The usages an array field's slot values select (out-of-range values are 'none')."""
    active = set()
    for v in values:
        if f.logical_min <= v <= f.logical_max:
            k = v - f.logical_min
            if k < len(f.usages):
                active.add(f.usages[k])
    return active


def report_values(desc: Descriptor, report: bytes) -> dict[int, int | bool]:
    """All input values of ``report`` by usage: variables by value, arrays as True per usage.

    Raises :class:`station.drivers.hid.errors.ReportError` for an unknown
    report ID or a wrong length.
    """
    layout = input_layout_for(desc, report)
    out: dict[int, int | bool] = {}
    for f in layout.fields:
        if f.is_constant or f.is_opaque:
            continue
        values = field_values(desc, f, report)
        if f.is_variable:
            for i, v in enumerate(values):
                usage = f.slot_usage(i)
                if usage and usage not in out:
                    out[usage] = v
        else:
            for usage in array_usages(f, values):
                out[usage] = True
    return out


def input_layout_for(desc: Descriptor, report: bytes) -> Report:
    """The input report layout ``report`` belongs to, checking its ID and length."""
    if not report:
        raise ReportError("empty report")
    rid = report[0] if desc.numbered else 0
    layout = desc.reports.get((ReportType.INPUT, rid))
    if layout is None or (desc.numbered and rid == 0):
        raise ReportError(f"unknown input report ID {rid}")
    want = layout.length(desc.numbered)
    if len(report) != want:
        raise ReportError(f"input report {rid} is {len(report)} bytes, the descriptor says {want}")
    return layout


# -- units and resolution -----------------------------------------------------------

UNIT_CENTIMETER = 0x11
UNIT_RADIAN = 0x12
UNIT_INCH = 0x13
UNIT_DEGREE = 0x14


def kernel_resolution(f: Field, angular: bool) -> int:
    """The integer resolution Linux puts in absinfo (hidinput_calc_abs_res).

    Units per millimetre for linear axes (unit cm or inch), units per radian
    for angular ones (radian or degree); 0 when unknown or insane.
    """
    logical = f.logical_max - f.logical_min
    physical = f.physical_max - f.physical_min
    exponent = f.unit_exponent
    if logical <= 0 or physical <= 0 or not -20 <= exponent <= 20:
        return 0  # the kernel's s32 arithmetic overflows (-> 0) long before |exponent| = 20
    if not angular:
        if f.unit == UNIT_CENTIMETER:
            exponent += 1
        elif f.unit == UNIT_INCH:
            physical *= 254
            exponent -= 1
        else:
            return 0
    else:
        if f.unit == UNIT_DEGREE:
            logical *= 573
            exponent += 1
        elif f.unit != UNIT_RADIAN:
            return 0
    while exponent < 0:
        logical *= 10
        exponent += 1
    while exponent > 0:
        physical *= 10
        exponent -= 1
    if logical >= 2**31 or physical >= 2**31:  # the kernel's s32 overflow checks
        return 0
    return (logical + physical // 2) // physical  # DIV_ROUND_CLOSEST for positive values


def resolution(f: Field) -> float | None:
    """Logical units per millimetre (length units) or per degree (angle units), or None.

    Computed from the logical and physical ranges, the unit and the unit
    exponent like the kernel, but in floating point: ``logical extent /
    physical extent in mm (or degrees)``.
    """
    logical = f.logical_max - f.logical_min
    physical = f.physical_max - f.physical_min
    if logical <= 0 or physical <= 0 or not -30 <= f.unit_exponent <= 30:
        return None
    scale = 10.0 ** f.unit_exponent
    if f.unit == UNIT_CENTIMETER:
        extent = physical * scale * 10.0  # mm
    elif f.unit == UNIT_INCH:
        extent = physical * scale * 25.4  # mm
    elif f.unit == UNIT_DEGREE:
        extent = physical * scale  # degrees
    elif f.unit == UNIT_RADIAN:
        extent = physical * scale * 57.29577951308232  # degrees
    else:
        return None
    # rounded to 9 significant digits so 44800 / 224.0 mm reads 200.0, not 199.99999999999997
    return float(f"{logical / extent:.9g}") if extent > 0 else None


# -- human-readable listing ---------------------------------------------------------


_COLLECTION_NAMES = {k.value: k.name.replace("_", " ").title() for k in CollectionKind}


def format_items(data: bytes) -> list[str]:
    """One line per item, indented by collection depth, like hid-decode's listing:
    ``offset: bytes  Name (value)``.  Stops at a truncated item with an ``error`` line
    instead of raising, so a broken descriptor can still be shown."""
    lines: list[str] = []
    try:
        items = iter_items(data)
    except DescriptorError as exc:
        items = iter_items(data[: exc.offset]) if exc.offset else []
        tail = f"{exc.offset}: error: {exc}"
    else:
        tail = ""
    depth = 0
    for it in items:
        if it.type == ItemType.MAIN and it.tag == TAG_END_COLLECTION:
            depth = max(0, depth - 1)
        raw = data[it.offset : it.offset + 1 + it.size + (2 if it.type == ItemType.LONG else 0)]
        value = ""
        if it.type == ItemType.MAIN and it.tag == TAG_COLLECTION:
            value = f" ({_COLLECTION_NAMES.get(it.unsigned, it.unsigned)})"
        elif it.type == ItemType.MAIN and it.tag in _MAIN_REPORT_TYPES:
            f = it.unsigned
            value = (" (" + ", ".join([
                "Const" if f & FLAG_CONSTANT else "Data",
                "Var" if f & FLAG_VARIABLE else "Arr",
                "Rel" if f & FLAG_RELATIVE else "Abs",
            ] + (["Null"] if f & FLAG_NULL_STATE else [])) + ")")  # fmt: skip
        elif it.type == ItemType.GLOBAL and it.tag in (G_LOGICAL_MIN, G_PHYSICAL_MIN):
            value = f" ({it.signed})"
        elif it.type == ItemType.GLOBAL and it.tag == G_UNIT_EXPONENT:
            value = f" ({decode_unit_exponent(it.signed)})"
        elif (it.type == ItemType.GLOBAL and it.tag in (G_USAGE_PAGE, G_UNIT)) or (
                it.type == ItemType.LOCAL and it.tag in (L_USAGE, L_USAGE_MIN, L_USAGE_MAX)):
            value = f" (0x{it.unsigned:x})"
        elif it.size:
            value = f" ({it.unsigned})" if it.type != ItemType.LONG else f" ({it.size} bytes)"
        lines.append(f"{it.offset:4d}: {raw.hex(' '):<15} {'  ' * depth}{it.name}{value}")
        if it.type == ItemType.MAIN and it.tag == TAG_COLLECTION:
            depth += 1
    if tail:
        lines.append(tail)
    return lines
