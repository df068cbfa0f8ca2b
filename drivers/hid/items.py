"""HID report-descriptor items: the item grammar (HID 1.11 §6.2.2), its tags and flags,
the splitting of a descriptor into items, and a human-readable listing (pure, no I/O).

The parser that turns items into report layouts is :mod:`station.drivers.hid.descriptor`;
the layouts are in :mod:`station.drivers.hid.layout`.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Final

from station.drivers.hid.errors import DescriptorError

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
MAIN_REPORT_TYPES = {
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
        elif it.type == ItemType.MAIN and it.tag in MAIN_REPORT_TYPES:
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
