"""Generic HID pen parser: pen reports decoded from the report descriptor alone.

The descriptor's input reports are classified (:func:`classify_reports`):

- ``pen``: X and Y under a Digitizer-page application (Digitizer, Pen, Light
  Pen, Whiteboard) or a Stylus collection, with a tip switch, in-range bit or
  tip pressure;
- ``touch``: anything under a Finger collection or a Touch Screen / Touch Pad
  application;
- ``pad``: Digitizer-page reports without X/Y that carry buttons or tablet
  function keys (express keys, rings, strips);
- ``other``: mice, keyboards, consumer keys, vendor-defined reports.

Only pen reports produce samples; the others are skipped and counted.  For
each pen report a :class:`PenPlan` precomputes the bit shift and mask of every
field the pen needs (Tip Switch, In Range, Barrel, Secondary Barrel, Invert,
Eraser, X, Y, Tip Pressure, X/Y Tilt, Twist, Transducer Serial Number, Z or
Wacom distance, Wacom tool type), so parsing a report is one
``int.from_bytes`` and a few shifts.  Wacom's vendor digitizer page 0xFF0D is
read through :func:`station.drivers.hid.usages.equivalent_usage`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial
from typing import Any

from station.drivers.devicedata import DeviceModel
from station.drivers.hid import usages as U
from station.drivers.hid.base import ReportParser
from station.drivers.hid.descriptor import Descriptor, Field, Report, ReportType, resolution
from station.drivers.hid.errors import ReportError
from station.drivers.raw import Axis, AxisRanges, RawSample
from station.drivers.wacom.tools import tool_from_id

from station.events import Button, Tool

PEN_APPLICATIONS = frozenset({U.DG_DIGITIZER, U.DG_PEN, U.DG_LIGHT_PEN, U.DG_WHITEBOARD})
TOUCH_APPLICATIONS = frozenset({U.DG_TOUCH_SCREEN, U.DG_TOUCH_PAD})
PEN_COLLECTIONS = frozenset({U.DG_STYLUS, U.DG_PEN, U.DG_LIGHT_PEN})

# role name -> usages that fill it (first match in a report wins)
ROLE_USAGES: dict[str, tuple[int, ...]] = {
    "x": (U.GD_X,),
    "y": (U.GD_Y,),
    "pressure": (U.DG_TIP_PRESSURE,),
    "tip": (U.DG_TIP_SWITCH,),
    "in_range": (U.DG_IN_RANGE,),
    "sense": (U.WD_SENSE,),
    "barrel": (U.DG_BARREL_SWITCH,),
    "barrel2": (U.DG_SECONDARY_BARREL_SWITCH,),
    "barrel3": (U.WD_BARREL_SWITCH3,),
    "invert": (U.DG_INVERT,),
    "eraser": (U.DG_ERASER,),
    "tilt_x": (U.DG_X_TILT,),
    "tilt_y": (U.DG_Y_TILT,),
    "azimuth": (U.DG_AZIMUTH,),
    "altitude": (U.DG_ALTITUDE,),
    "twist": (U.DG_TWIST,),
    "serial": (U.DG_TRANSDUCER_SERIAL,),
    "serial_hi": (U.WD_SERIAL_HI,),
    "tool_type": (U.WD_TOOL_TYPE,),
    "distance": (U.WD_DISTANCE, U.GD_Z),
}
_USAGE_ROLE = {usage: role for role, us in ROLE_USAGES.items() for usage in us}
SERIAL_MASK = (1 << 64) - 1  # serials are at most 64 bits (a 64-bit field plus a high word)
_BOOL_ROLES = ("tip", "in_range", "sense", "barrel", "barrel2", "barrel3", "invert", "eraser")
_UNSIGNED_ROLES = ("serial", "serial_hi", "tool_type")


def _eq(usage: int) -> int:
    return U.equivalent_usage(usage)


def classify_report(desc: Descriptor, report: Report) -> str:
    """``pen``, ``touch``, ``pad`` or ``other`` for one input report layout."""
    data_fields = [f for f in report.fields if not f.is_constant]
    if not data_fields:
        return "other"
    usages: set[int] = set()
    variables: set[int] = set()  # usages of variable slots (X and Y must be variables)
    chains: set[int] = set()
    apps: set[int] = set()
    for f in data_fields:
        usages.update(_eq(u) for u in f.usages)
        if f.is_variable and not f.is_opaque:  # X/Y must be readable values
            variables.update(_eq(u) for u in f.usages)
        chains.update(_eq(u) for u in desc.collection_usages(f))
        apps.add(_eq(f.application))
    if U.DG_FINGER in chains or apps & TOUCH_APPLICATIONS:
        return "touch"
    # A Pen or Stylus collection makes a pen whatever encloses it: hid-input maps In Range
    # inside a physical Pen to BTN_TOOL_PEN, and some UC-Logic tablets (Huion H580X,
    # Gaomon 1080Pro: 256c:0064 interface 1) declare their pen as a physical Pen
    # collection with no application collection at all.
    digitizer = bool(apps & PEN_APPLICATIONS) or bool(chains & PEN_COLLECTIONS)
    has_xy = U.GD_X in variables and U.GD_Y in variables
    pen_bits = usages & {U.DG_TIP_SWITCH, U.DG_IN_RANGE, U.DG_TIP_PRESSURE, U.WD_SENSE}
    if digitizer and has_xy and pen_bits:
        return "pen"
    on_digitizer = digitizer or any(_eq(a) >> 16 in (U.PAGE_DIGITIZER, U.PAGE_WACOM_DIGITIZER)
                                    for a in apps)  # fmt: skip
    keys = (U.DG_TABLET_FUNCTION_KEYS in chains
            or any(u >> 16 == U.PAGE_BUTTON or u >> 8 == 0xFF0D10 for u in usages))
    if on_digitizer and keys:
        return "pad"  # express keys, rings, strips
    return "other"  # mice, keyboards, vendor-defined data (e.g. Wacom protocol reports)


def classify_reports(desc: Descriptor) -> dict[int, str]:
    """Kind of every input report ID of a descriptor."""
    return {r.report_id: classify_report(desc, r) for r in desc.input_reports()}


@dataclass(frozen=True, slots=True)
class _Slot:
    role: str
    shift: int  # bit offset in the whole report (ID byte included)
    mask: int
    sign_bit: int  # 0 = unsigned


@dataclass(frozen=True, slots=True)
class _ArraySlots:
    shifts: tuple[int, ...]
    mask: int
    logical_min: int
    roles: tuple[str | None, ...]  # role of usage k (value - logical_min)
    present: tuple[str, ...]  # roles this array can report (0 unless selected)


@dataclass(slots=True)
class PenPlan:
    """Precomputed extraction of one pen report.

    ``angles`` is set when the pen reports azimuth and altitude but no X/Y
    tilt: (scale, offset) pairs turning each into degrees, so tilt can be
    derived (in centidegrees, see :data:`DERIVED_TILT_AXIS`).
    """

    report_id: int
    length: int
    slots: tuple[_Slot, ...]
    arrays: tuple[_ArraySlots, ...]
    fields: dict[str, Field]  # role -> field (for ranges)
    angles: tuple[tuple[float, float], tuple[float, float]] | None = None


DERIVED_TILT_AXIS = Axis(-9000, 9000, 100.0)  # tilt derived from azimuth/altitude: centidegrees


def degrees_map(f: Field) -> tuple[float, float] | None:
    """(scale, offset) with ``degrees = value * scale + offset`` for an angle field, or None."""
    logical = f.logical_max - f.logical_min
    physical = f.physical_max - f.physical_min
    if logical <= 0 or physical <= 0 or f.unit not in (0x12, 0x14):
        return None
    if not -30 <= f.unit_exponent <= 30:
        return None
    unit = 10.0 ** f.unit_exponent * (57.29577951308232 if f.unit == 0x12 else 1.0)
    scale = physical / logical * unit
    return scale, f.physical_min * unit - f.logical_min * scale


def _usage_roles(report: Report, overrides: Mapping[int, str] | None) -> dict[int, str]:
    """Usage -> role for one report: the standard table plus the device's quirks, each
    quirk only where the report does not already declare a usage for that role."""
    if not overrides:
        return _USAGE_ROLE
    declared = {_USAGE_ROLE.get(_eq(u)) for f in report.fields for u in f.usages}
    roles = dict(_USAGE_ROLE)
    for usage, role in overrides.items():
        if role not in declared:
            roles[usage] = role
    return roles


def make_plan(desc: Descriptor, report: Report,
              overrides: Mapping[int, str] | None = None) -> PenPlan:
    """The extraction plan of one pen report (``overrides``: quirk usage -> role)."""
    base = 8 if desc.numbered else 0
    slots: list[_Slot] = []
    arrays: list[_ArraySlots] = []
    fields: dict[str, Field] = {}
    usage_role = _usage_roles(report, overrides)
    for f in report.fields:
        if f.is_constant or f.is_opaque:
            continue
        if f.is_variable:
            for i in range(f.count):
                role = usage_role.get(_eq(f.slot_usage(i)))
                if role is None or role in fields:
                    continue
                fields[role] = f
                signed = f.signed and role not in _UNSIGNED_ROLES
                sign_bit = (1 << (f.size - 1)) if signed else 0
                slots.append(_Slot(role, base + f.slot_offset(i), (1 << f.size) - 1, sign_bit))
        else:
            roles = tuple(usage_role.get(_eq(u)) for u in f.usages)
            if not any(r in _BOOL_ROLES for r in roles):
                continue
            for r in roles:
                if r in _BOOL_ROLES and r not in fields:
                    fields[r] = f
            arrays.append(_ArraySlots(
                tuple(base + f.slot_offset(i) for i in range(f.count)),
                (1 << f.size) - 1, f.logical_min,
                tuple(r if r in _BOOL_ROLES else None for r in roles),
                tuple(sorted({r for r in roles if r is not None and r in _BOOL_ROLES})),
            ))  # fmt: skip
    angles = None
    if "tilt_x" not in fields and "azimuth" in fields and "altitude" in fields:
        az, alt = degrees_map(fields["azimuth"]), degrees_map(fields["altitude"])
        if az is not None and alt is not None:
            angles = (az, alt)
    return PenPlan(report.report_id, report.length(desc.numbered), tuple(slots), tuple(arrays),
                   fields, angles)  # fmt: skip


def _axis(f: Field | None) -> Axis | None:
    if f is None:
        return None
    return Axis(f.logical_min, f.logical_max, resolution(f))


def ranges_from_plan(plan: PenPlan) -> AxisRanges:
    fx, fy = plan.fields["x"], plan.fields["y"]
    derived = DERIVED_TILT_AXIS if plan.angles is not None else None
    return AxisRanges(
        x=_axis(fx) or Axis(0, 1),
        y=_axis(fy) or Axis(0, 1),
        pressure=_axis(plan.fields.get("pressure")),
        tilt_x=_axis(plan.fields.get("tilt_x")) or derived,
        tilt_y=_axis(plan.fields.get("tilt_y")) or derived,
        distance=_axis(plan.fields.get("distance")),
        rotation=_axis(plan.fields.get("twist")),
    )


class GenericPenParser(ReportParser):
    """Parses the pen reports of any HID digitizer from its descriptor.

    Attributes:
        descriptor: the parsed descriptor.
        kinds: report ID -> ``pen``/``touch``/``pad``/``other``.
        plans: report ID -> :class:`PenPlan` for pen reports.
        primary: the pen report whose axes define :attr:`ranges`.
    """

    name = "hid-generic"

    def __init__(self, desc: Descriptor, model: DeviceModel | None = None,
                 init_features: list[bytes] | None = None, generic: bool = True,
                 quirks: Mapping[int, str] | None = None) -> None:
        self.descriptor = desc
        self.quirks = dict(quirks or {})  # usage -> role (station.drivers.hid.quirks)
        self.kinds = classify_reports(desc)
        # In a numbered descriptor, fields before the first Report ID (report 0) are unreachable.
        self.lengths = {r.report_id: r.length(desc.numbered) for r in desc.input_reports()
                        if not (desc.numbered and r.report_id == 0)}  # fmt: skip
        self.numbered = desc.numbered
        self.plans: dict[int, PenPlan] = {}
        self.decoders: dict[int, Callable[[bytes, float], RawSample]] = {}
        for r in desc.input_reports():
            if self.kinds[r.report_id] == "pen" and r.report_id in self.lengths:
                plan = self.plans[r.report_id] = make_plan(desc, r, self.quirks)
                self.decoders[r.report_id] = compile_plan(plan) or partial(self.decode, plan)
        if self.plans:
            self.primary: PenPlan | None = max(self.plans.values(), key=lambda p: len(p.slots))
            ranges = ranges_from_plan(self.primary)
            kind, is_pen = "pen", True
        else:
            self.primary = None
            ranges = AxisRanges(Axis(0, 1), Axis(0, 1))
            kinds = set(self.kinds.values())
            kind = "touch" if "touch" in kinds else "pad" if "pad" in kinds else "other"
            is_pen = False
        super().__init__(ranges, model, init_features, generic=generic, is_pen=is_pen, kind=kind)
        self.long_reports = 0  # reports longer than the descriptor says (tail ignored)
        # report ID -> (declared length, decoder) of the pen reports
        self._pen_reports = {rid: (self.lengths[rid], dec) for rid, dec in self.decoders.items()}

    @property
    def pen_report_ids(self) -> list[int]:
        return sorted(self.plans)

    def parse(self, report: bytes, time: float) -> list[RawSample]:
        # The hot path: a pen report of exactly its declared length, one dict lookup.
        if report:
            pen = self._pen_reports.get(report[0] if self.numbered else 0)
            if pen is not None and len(report) == pen[0]:
                return [pen[1](report, time)]
        else:
            raise ReportError("empty report")
        rid = report[0] if self.numbered else 0
        want = self.lengths.get(rid)
        if want is None:
            raise ReportError(f"unknown input report ID {rid}")
        if len(report) != want:
            if len(report) < want:
                raise ReportError(f"input report {rid} is {len(report)} bytes, the descriptor "
                                  f"says {want}")  # fmt: skip
            # Longer than declared: the kernel (hid_report_raw_event) reads the declared
            # fields and ignores the tail; some pens pad their reports (counted, not an error).
            self.long_reports += 1
            report = report[:want]
        decode = self.decoders.get(rid)
        if decode is None:
            return self._skip(self.kinds[rid], rid)
        return [decode(report, time)]

    def decode(self, plan: PenPlan, report: bytes, time: float) -> RawSample:
        """Decode one pen report by walking the plan (the reference for :func:`compile_plan`)."""
        bits = int.from_bytes(report, "little")
        v: dict[str, int] = {}
        for s in plan.slots:
            value = (bits >> s.shift) & s.mask
            if s.sign_bit and value & s.sign_bit:
                value -= s.sign_bit << 1
            v[s.role] = value
        for a in plan.arrays:
            for name in a.present:
                v.setdefault(name, 0)
            for shift in a.shifts:
                k = ((bits >> shift) & a.mask) - a.logical_min
                if 0 <= k < len(a.roles):
                    role = a.roles[k]
                    if role is not None:
                        v[role] = 1
        get = v.get
        tip_bit = get("tip")
        eraser_bit = get("eraser", 0)
        invert = get("invert", 0)
        # The eraser end touching reports Eraser (not Tip Switch) on Microsoft-style pens.
        tip = None if tip_bit is None and "eraser" not in plan.fields else bool(
            tip_bit or eraser_bit)
        in_range = get("in_range")
        sense = get("sense")
        # Wacom (kernel wacom_wac_pen_report): Sense = the tool is near (in proximity),
        # In Range = close enough for valid data.  Without either usage a report only
        # arrives while the pen is sensed.
        # A touching tip (or eraser) is in proximity whatever In Range says: some
        # controllers (Goodix GXTP 27c6:0113) drop In Range while the tip moves, and the
        # kernel's hid-input counts Tip Switch, Eraser and Invert as "tool active" too.
        if in_range is None and sense is None:
            proximity = valid = True
        else:
            touching = bool(tip_bit or eraser_bit)
            proximity = bool(in_range or sense or touching or invert)
            valid = bool(in_range or touching) if in_range is not None else proximity
        buttons = 0
        if get("barrel"):
            buttons |= Button.STYLUS
        if get("barrel2"):
            buttons |= Button.STYLUS2
        if get("barrel3"):
            buttons |= Button.STYLUS3
        tool_id = get("tool_type") or None
        eraser = bool(invert or eraser_bit)
        if eraser:
            tool = Tool.ERASER
        elif tool_id is not None:
            tool = tool_from_id(tool_id)
        else:
            tool = Tool.PEN
        serial = (get("serial", 0) | (get("serial_hi", 0) << 32)) & SERIAL_MASK
        tilt_x, tilt_y = get("tilt_x"), get("tilt_y")
        if plan.angles is not None:
            (az_s, az_o), (alt_s, alt_o) = plan.angles
            tx, ty = tilt_from_azimuth(get("azimuth", 0) * az_s + az_o,
                                       get("altitude", 0) * alt_s + alt_o)  # fmt: skip
            tilt_x, tilt_y = round(tx * 100), round(ty * 100)
        return RawSample(
            time=time,
            proximity=proximity,
            x=get("x", 0),
            y=get("y", 0),
            tip=tip,
            pressure=get("pressure"),
            tilt_x=tilt_x,
            tilt_y=tilt_y,
            distance=get("distance"),
            rotation=get("twist"),
            buttons=int(buttons),
            tool=tool,
            serial=serial or None,
            tool_id=tool_id,
            eraser=eraser,
            valid=valid,
        )

    def describe(self) -> dict[str, object]:
        d = super().describe()
        d["report_kinds"] = {str(k): v for k, v in sorted(self.kinds.items())}
        d["pen_reports"] = self.pen_report_ids
        return d


_ROLE_DEFAULT = {"x": "0", "y": "0"}


def compile_plan(plan: PenPlan) -> Callable[[bytes, float], RawSample] | None:
    """A decoder specialised to one pen report: straight-line shifts and masks.

    The generated source holds only integers from the plan and fixed names,
    never text from the device.  Plans with array fields or derived tilt
    return None (they use :meth:`GenericPenParser.decode`).  About twice as
    fast as walking the plan; tests check both agree on random reports.
    """
    if plan.arrays or plan.angles is not None:
        return None
    lines = ["def decode(report, time):", "    b = from_bytes(report, 'little')"]
    have = set()
    for slot in plan.slots:
        var = f"v_{slot.role}"
        have.add(slot.role)
        lines.append(f"    {var} = (b >> {int(slot.shift)}) & {int(slot.mask)}")
        if slot.sign_bit:
            lines.append(f"    if {var} & {int(slot.sign_bit)}: {var} -= {int(slot.sign_bit) << 1}")

    def val(role: str, default: str = "None") -> str:
        return f"v_{role}" if role in have else _ROLE_DEFAULT.get(role, default)

    if "tip" in have or "eraser" in have:
        lines.append(f"    tip = bool({val('tip', '0')} or {val('eraser', '0')})")
    else:
        lines.append("    tip = None")
    # see GenericPenParser.decode: a touching tip/eraser (or invert) keeps the tool in
    active = f"({val('tip', '0')} or {val('eraser', '0')})"
    if "in_range" in have:
        lines.append(f"    valid = bool(v_in_range or {active})")
        sense = "v_sense or " if "sense" in have else ""
        lines.append(f"    prox = bool(valid or {sense}{val('invert', '0')})")
    elif "sense" in have:
        lines.append(f"    prox = valid = bool(v_sense or {active} or {val('invert', '0')})")
    else:
        lines.append("    prox = valid = True")
    lines.append(f"    buttons = (1 if {val('barrel', '0')} else 0) | "
                 f"(2 if {val('barrel2', '0')} else 0) | (4 if {val('barrel3', '0')} else 0)")
    lines.append(f"    eraser = bool({val('invert', '0')} or {val('eraser', '0')})")
    lines.append(f"    tool_id = {val('tool_type', '0')} or None")
    lines.append("    tool = ERASER if eraser else PEN if tool_id is None else tool_of(tool_id)")
    serial = f"({val('serial', '0')} | ({val('serial_hi', '0')} << 32))"
    lines.append(f"    serial = ({serial} & {SERIAL_MASK}) or None")
    lines.append(
        f"    return new(RawSample, (time, prox, {val('x')}, {val('y')}, tip, {val('pressure')}, "
        f"{val('tilt_x')}, {val('tilt_y')}, {val('distance')}, {val('twist')}, None, buttons, "
        "tool, serial, tool_id, eraser, valid))"
    )
    namespace: dict[str, Any] = {
        "from_bytes": int.from_bytes, "RawSample": RawSample, "ERASER": Tool.ERASER,
        "PEN": Tool.PEN, "tool_of": tool_from_id,
        # RawSample is a named tuple: tuple.__new__ with the values in field order skips
        # its Python-level __new__ (built per report)
        "new": tuple.__new__,
    }  # fmt: skip
    exec(compile("\n".join(lines), f"<pen report {plan.report_id}>", "exec"), namespace)
    decoder: Callable[[bytes, float], RawSample] = namespace["decode"]
    return decoder


def tilt_from_azimuth(azimuth_deg: float, altitude_deg: float) -> tuple[float, float]:
    """X/Y tilt in degrees from azimuth and altitude (degrees).

    Azimuth is the direction the pen top leans, measured from +x toward +y
    (device axes: y down, so clockwise on the tablet); altitude is the angle
    between pen and surface.  Each tilt is the angle of the pen's projection
    on the x-z and y-z planes from the vertical.
    """
    alt = math.radians(max(0.0, min(90.0, altitude_deg)))
    az = math.radians(azimuth_deg)
    if alt >= math.pi / 2:
        return 0.0, 0.0
    t = math.tan(alt)
    return (math.degrees(math.atan2(math.cos(az), t)), math.degrees(math.atan2(math.sin(az), t)))


def input_report_kinds(desc: Descriptor) -> dict[str, list[int]]:
    """Report IDs grouped by kind, for ``station devices``."""
    out: dict[str, list[int]] = {}
    for rid, kind in sorted(classify_reports(desc).items()):
        out.setdefault(kind, []).append(rid)
    return out


__all__ = ["GenericPenParser", "ReportType", "classify_report", "classify_reports",
           "compile_plan", "input_report_kinds", "make_plan", "tilt_from_azimuth"]  # fmt: skip
