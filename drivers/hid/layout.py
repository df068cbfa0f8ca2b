"""HID report layouts: the fields, reports and collections a parsed descriptor declares,
and the decoded unit (pure data, no I/O).  :func:`station.drivers.hid.descriptor.parse_descriptor`
builds them; :mod:`station.drivers.hid.values` reads reports through them."""

from __future__ import annotations

from dataclasses import dataclass, field

from station.drivers.hid.items import (
    FLAG_CONSTANT,
    FLAG_RELATIVE,
    FLAG_VARIABLE,
    MAX_SERIAL_BITS,
    MAX_VALUE_BITS,
    CollectionKind,
    Item,
    ReportType,
)

_SERIAL_USAGES = frozenset({0x000D005B, 0xFF0D005B, 0xFF0D005C})


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
