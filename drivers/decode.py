"""Reports and events in words, one line each: ``station record`` prints them as they
arrive (as hid-recorder does) and ``station replay --decode`` prints a trace's (as
hid-decode does).

A HID report gets the fields its report descriptor declares, by usage name
(``Tip Switch=1 X=11826 Y=7310 Tip Pressure=512``), and then what the station's
own parser read from it (``-> pen x=11826 y=7310 p=512 tip in-range``): for a
Wacom in its vendor mode the descriptor says little and the parser says it all.
An evdev event is its type, code and value by name (``EV_ABS ABS_X 11826``).
"""

from __future__ import annotations

from types import ModuleType

from station.drivers.hid.descriptor import Descriptor, parse_descriptor, report_values
from station.drivers.hid.errors import DescriptorError, ReportError
from station.drivers.hid.usages import usage_name
from station.drivers.raw import RawSample
from station.drivers.registry import ReportParser, parser_for

from station.errors import BadInput

_ecodes: ModuleType | None
try:  # event code names; without python-evdev the numbers are printed
    from evdev import ecodes as _ecodes
except ImportError:  # pragma: no cover - python-evdev is a Linux dependency
    _ecodes = None

MAX_FIELDS = 24  # a vendor report of hundreds of fields: the first ones, then "…"


class ReportDecoder:
    """Decodes one HID device's input reports (its descriptor and its parser)."""

    def __init__(self, descriptor: bytes | None, vid: int, pid: int, bus: int = 3) -> None:
        self.desc: Descriptor | None = None
        self.note = ""
        if descriptor:
            try:
                self.desc = parse_descriptor(descriptor)
            except DescriptorError as exc:
                self.note = f"descriptor not parsed: {exc}"
        self.parser: ReportParser | None = None
        try:
            self.parser = parser_for(vid, pid, descriptor, bus)
        except BadInput as exc:
            self.note = self.note or f"no parser: {exc}"

    def line(self, t: float, data: bytes) -> str:
        """``t`` and ``data`` in words (never raises: a report it cannot read says why)."""
        parts = [f"{t:11.6f}", _fields(self.desc, data)]
        if self.parser is not None and getattr(self.parser, "is_pen", True):
            try:
                raws = self.parser.parse(data, t)
            except (ReportError, BadInput, ValueError) as exc:
                parts.append(f"-> not read: {exc}")
            else:
                parts.append("-> " + ("; ".join(_raw(r) for r in raws) if raws else "no sample"))
        return " ".join(p for p in parts if p)


def _fields(desc: Descriptor | None, data: bytes) -> str:
    if not data:
        return "(empty)"
    head = f"report {data[0]}" if desc is not None and desc.numbered else "report"
    if desc is None:
        return f"{head}: {data.hex(' ')}"
    try:
        values = report_values(desc, data)
    except ReportError as exc:
        return f"{head}: {data.hex(' ')} ({exc})"
    items = [f"{usage_name(u)}={int(v)}" for u, v in values.items()]
    more = " …" if len(items) > MAX_FIELDS else ""
    return f"{head}: " + (" ".join(items[:MAX_FIELDS]) + more if items else data.hex(" "))


def _raw(r: RawSample) -> str:
    if not r.proximity:
        return "out of proximity"
    if not r.valid:
        return f"{r.tool.value if r.tool else 'tool'} in range (no data)"
    bits = [f"{r.tool.value if r.tool else 'pen'} x={r.x} y={r.y}"]
    if r.pressure is not None:
        bits.append(f"p={r.pressure}")
    if r.tilt_x is not None and r.tilt_y is not None:
        bits.append(f"tilt={r.tilt_x},{r.tilt_y}")
    for name in ("distance", "rotation", "wheel"):
        v = getattr(r, name)
        if v is not None:
            bits.append(f"{name}={v}")
    if r.buttons:
        bits.append(f"buttons={r.buttons:#x}")
    if r.tip:
        bits.append("tip")
    if r.serial:
        bits.append(f"serial={r.serial:#x}")
    return " ".join(bits)


def event_line(t: float, type_: int, code: int, value: int) -> str:
    """An evdev event by name: ``  0.004512 EV_ABS ABS_X 11826``."""
    tname, cname = str(type_), str(code)
    if _ecodes is not None:
        tname = str(_ecodes.EV.get(type_, type_))
        names = _ecodes.bytype.get(type_, {}).get(code, code)
        cname = str(names[0] if isinstance(names, (list, tuple)) else names)
    return f"{t:11.6f} {tname} {cname} {value}"
