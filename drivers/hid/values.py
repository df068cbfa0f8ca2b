"""Reading HID reports through a parsed layout: bit extraction, values by usage, and the
resolution of an axis from its ranges, unit and exponent as the Linux HID core computes it
(pure, no I/O)."""

from __future__ import annotations

from station.drivers.hid.errors import ReportError
from station.drivers.hid.items import ReportType
from station.drivers.hid.layout import Descriptor, Field, Report


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
