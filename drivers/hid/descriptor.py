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

Split by job: the item grammar and listing in :mod:`station.drivers.hid.items`, the layouts
in :mod:`station.drivers.hid.layout`, reading reports in :mod:`station.drivers.hid.values`;
this module parses and re-exports all three, so ``descriptor`` stays the one import
callers need.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field

from station.drivers.hid.errors import DescriptorError
from station.drivers.hid.items import (
    FLAG_BUFFERED_BYTES,
    FLAG_CONSTANT,
    FLAG_NO_PREFERRED,
    FLAG_NONLINEAR,
    FLAG_NULL_STATE,
    FLAG_RELATIVE,
    FLAG_VARIABLE,
    FLAG_VOLATILE,
    FLAG_WRAP,
    G_LOGICAL_MAX,
    G_LOGICAL_MIN,
    G_PHYSICAL_MAX,
    G_PHYSICAL_MIN,
    G_POP,
    G_PUSH,
    G_REPORT_COUNT,
    G_REPORT_ID,
    G_REPORT_SIZE,
    G_UNIT,
    G_UNIT_EXPONENT,
    G_USAGE_PAGE,
    L_DELIMITER,
    L_DESIGNATOR_INDEX,
    L_DESIGNATOR_MAX,
    L_DESIGNATOR_MIN,
    L_STRING_INDEX,
    L_STRING_MAX,
    L_STRING_MIN,
    L_USAGE,
    L_USAGE_MAX,
    L_USAGE_MIN,
    MAIN_REPORT_TYPES,
    MAX_COLLECTION_DEPTH,
    MAX_DESCRIPTOR_BYTES,
    MAX_PUSH_DEPTH,
    MAX_REPORT_BYTES,
    MAX_REPORT_SIZE,
    MAX_SERIAL_BITS,
    MAX_USAGES,
    MAX_VALUE_BITS,
    TAG_COLLECTION,
    TAG_END_COLLECTION,
    TAG_FEATURE,
    TAG_INPUT,
    TAG_OUTPUT,
    CollectionKind,
    Item,
    ItemType,
    ReportType,
    decode_unit_exponent,
    format_items,
    iter_items,
)
from station.drivers.hid.layout import (
    UNIT_SYSTEMS,
    Collection,
    Descriptor,
    Field,
    GlobalState,
    Report,
    Unit,
)
from station.drivers.hid.values import (
    UNIT_CENTIMETER,
    UNIT_DEGREE,
    UNIT_INCH,
    UNIT_RADIAN,
    array_usages,
    extract_bits,
    field_values,
    input_layout_for,
    kernel_resolution,
    report_values,
    resolution,
)

__all__ = [
    "FLAG_BUFFERED_BYTES",
    "FLAG_CONSTANT",
    "FLAG_NONLINEAR",
    "FLAG_NO_PREFERRED",
    "FLAG_NULL_STATE",
    "FLAG_RELATIVE",
    "FLAG_VARIABLE",
    "FLAG_VOLATILE",
    "FLAG_WRAP",
    "G_LOGICAL_MAX",
    "G_LOGICAL_MIN",
    "G_PHYSICAL_MAX",
    "G_PHYSICAL_MIN",
    "G_POP",
    "G_PUSH",
    "G_REPORT_COUNT",
    "G_REPORT_ID",
    "G_REPORT_SIZE",
    "G_UNIT",
    "G_UNIT_EXPONENT",
    "G_USAGE_PAGE",
    "L_DELIMITER",
    "L_DESIGNATOR_INDEX",
    "L_DESIGNATOR_MAX",
    "L_DESIGNATOR_MIN",
    "L_STRING_INDEX",
    "L_STRING_MAX",
    "L_STRING_MIN",
    "L_USAGE",
    "L_USAGE_MAX",
    "L_USAGE_MIN",
    "MAX_COLLECTION_DEPTH",
    "MAX_DESCRIPTOR_BYTES",
    "MAX_PUSH_DEPTH",
    "MAX_REPORT_BYTES",
    "MAX_REPORT_SIZE",
    "MAX_SERIAL_BITS",
    "MAX_USAGES",
    "MAX_VALUE_BITS",
    "TAG_COLLECTION",
    "TAG_END_COLLECTION",
    "TAG_FEATURE",
    "TAG_INPUT",
    "TAG_OUTPUT",
    "UNIT_CENTIMETER",
    "UNIT_DEGREE",
    "UNIT_INCH",
    "UNIT_RADIAN",
    "UNIT_SYSTEMS",
    "Collection",
    "CollectionKind",
    "Descriptor",
    "Field",
    "GlobalState",
    "Item",
    "ItemType",
    "Report",
    "ReportType",
    "Unit",
    "array_usages",
    "decode_unit_exponent",
    "extract_bits",
    "field_values",
    "format_items",
    "input_layout_for",
    "iter_items",
    "kernel_resolution",
    "parse_descriptor",
    "report_values",
    "resolution",
]  # fmt: skip


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
        elif it.tag in MAIN_REPORT_TYPES:
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
    rtype = MAIN_REPORT_TYPES[it.tag]
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
