"""Sweep a collection of real HID report descriptors through the station's parser choice.

For every ``BBBB:VVVV:PPPP.NNNN.hid.bin`` under ROOT (the layout of
linuxwacom/wacom-hid-descriptors, whose ``.hid.txt`` files are hidrd renderings of the
same bytes) this builds what the driver sees on that interface -- bus, vendor and
product from the file name, the descriptor bytes -- asks
:func:`station.drivers.registry.parser_for` for its parser, and says which parser serves
it or exactly why none does.

A descriptor *declares a pen* when it reports X/Y in a Pen, Stylus or Light Pen
collection, or in a Digitizer application beside a tip, pressure or in-range usage
(standard or Wacom-vendor page: what the kernel's hid-input makes a pen of); a
Wacom protocol model (``wacom-*`` parsers, vendor-defined reports) is a pen device when
the registry gives it its protocol parser.  Flagged:

- ``refused-pen``: a descriptor that declares a pen gets no pen parser;
- ``protocol-without-pen-report``: a protocol parser on an interface whose descriptor
  declares none of the parser's pen report IDs (mis-assigned: a touch or pad node);
- ``roundtrip``: a descriptor-path pen (UC-Logic ones read before their set-up too)
  whose own report layout, filled with known values (x, y, pressure, tip, in range),
  does not read back.

Usage::

    python tools/sweep_descriptors.py /tmp/whd            # summary as JSON
    python tools/sweep_descriptors.py /tmp/whd --files    # one line per descriptor too

The collection is ODbL and stays outside the repository (tests skip without it).
"""

from __future__ import annotations

import argparse
import json
import logging
import re
import sys
from collections import Counter
from dataclasses import asdict, dataclass
from pathlib import Path

from station.drivers import synth as S
from station.drivers.hid import usages as U
from station.drivers.hid.descriptor import Descriptor, parse_descriptor
from station.drivers.hid.pen import GenericPenParser
from station.drivers.registry import BUS_NUMBERS, ReportParser, parser_for

from station.errors import BadInput

# BBBB:VVVV:PPPP.NNNN.hid.bin (sysfs names); older entries: VVVV:PPPP_I.hid.bin (USB,
# interface I) and BBBB:VVVV:PPPP[_I].hid.bin.
NAME = re.compile(r"^(?:([0-9A-Fa-f]{4}):)?([0-9A-Fa-f]{4}):([0-9A-Fa-f]{4})"
                  r"(?:\.[0-9A-Fa-f]+|_(\d+))?\.hid\.bin$")
PEN_COLLECTIONS = frozenset({U.DG_PEN, U.DG_STYLUS, U.DG_LIGHT_PEN})
TOUCH_COLLECTIONS = frozenset({U.DG_FINGER, U.DG_TOUCH_SCREEN, U.DG_TOUCH_PAD})
DIGITIZER_APPLICATIONS = frozenset({U.DG_DIGITIZER, U.DG_WHITEBOARD})
PEN_BITS = frozenset({U.DG_TIP_SWITCH, U.DG_TIP_PRESSURE, U.DG_IN_RANGE})


@dataclass
class Entry:
    """What the sweep found for one descriptor file."""

    path: str
    bus: str
    usb_id: str
    outcome: str  # pen, ignored, refused, empty, bad-descriptor
    interface: int | None = None  # from an older file name's _I suffix
    parser: str | None = None
    kind: str | None = None  # the parser's kind: pen, touch, pad, other
    declares_pen: bool = False
    declares_touch: bool = False
    generic: bool = False
    model: str | None = None
    reason: str | None = None
    flag: str | None = None
    roundtrip: bool | None = None  # a pen report of its own layout read back (None: not tried)


def declared(desc: Descriptor) -> tuple[bool, bool]:
    """(declares a pen, declares touch), report by report: an input X or Y inside a Pen,
    Stylus or Light Pen collection (application or physical: hid-input maps its In Range to
    BTN_TOOL_PEN), or inside a Digitizer/Whiteboard application whose report also has a
    tip, pressure or in-range usage; touch: X or Y inside Finger, Touch Screen, Touch Pad."""
    pen = touch = False
    for r in desc.input_reports():
        usages = {U.equivalent_usage(u) for f in r.fields for u in f.usages}
        pen_bits = bool(usages & PEN_BITS)
        for f in r.fields:
            if not {U.equivalent_usage(u) for u in f.usages} & {U.GD_X, U.GD_Y}:
                continue
            chain = {U.equivalent_usage(u) for u in desc.collection_usages(f)}
            chain.add(U.equivalent_usage(f.application))
            touch = touch or bool(chain & TOUCH_COLLECTIONS)
            pen = pen or bool(chain & PEN_COLLECTIONS) or (
                pen_bits and bool(chain & DIGITIZER_APPLICATIONS) and not chain & TOUCH_COLLECTIONS)
    return pen, touch


def reads_pen(desc: Descriptor, parser: ReportParser) -> bool:
    """A protocol parser can get a pen report from this interface: the descriptor declares
    one of its pen IDs (or, for the Tablet PC protocol, a report of its pen length: the
    kernel's wacom_tpc_irq reads any 8-byte report as pen)."""
    ids = set(getattr(parser, "pen_report_ids", ()))
    any_length = getattr(getattr(parser, "protocol", None), "any_id_length", None)
    return any(r.report_id in ids or r.length(desc.numbered) == any_length
               for r in desc.input_reports())


def roundtrip(parser: GenericPenParser) -> str | None:
    """None when every pen report of the parser reads back known values, else why not."""
    for rid, plan in parser.plans.items():
        fields = plan.fields
        want: dict[int, int] = {}
        if "x" in fields:
            want[U.GD_X] = min(1234, fields["x"].logical_max)
        if "y" in fields:
            want[U.GD_Y] = min(567, fields["y"].logical_max)
        if "pressure" in fields:
            want[U.DG_TIP_PRESSURE] = min(89, fields["pressure"].logical_max)
        values: dict[int, int | bool] = {**want, U.DG_TIP_SWITCH: 1, U.DG_IN_RANGE: 1}
        try:
            report = S.encode_report(parser.descriptor, rid, values)
            (s,) = parser.parse(report, 0.0)
        except Exception as exc:
            return f"report {rid}: {type(exc).__name__}: {exc}"
        got = {U.GD_X: s.x, U.GD_Y: s.y, U.DG_TIP_PRESSURE: s.pressure}
        bad = {hex(u): (v, got[u]) for u, v in want.items() if got[u] != v}
        if bad or not s.proximity:
            return f"report {rid}: wrote {want}, read back {bad or 'out of proximity'}"
    return None


def sweep_one(path: Path) -> Entry | None:
    m = NAME.match(path.name)
    if m is None:
        return None
    bus, vid, pid = (int(g, 16) for g in m.groups("0003")[:3])
    interface = None if m.group(4) is None else int(m.group(4))
    e = Entry(str(path), BUS_NUMBERS.get(bus, f"{bus:#x}"), f"{vid:04x}:{pid:04x}", "",
              interface=interface)
    raw = path.read_bytes()
    if not raw:
        e.outcome, e.reason = "empty", "the file is empty (no descriptor was captured)"
        return e
    try:
        desc = parse_descriptor(raw)
    except BadInput as exc:
        e.outcome, e.reason = "bad-descriptor", str(exc)
        return e
    e.declares_pen, e.declares_touch = declared(desc)
    try:
        p = parser_for(vid, pid, raw, bus, interface=interface)
    except BadInput as exc:
        e.outcome, e.reason = "refused", str(exc)
        if e.declares_pen:
            e.flag = "refused-pen"
        return e
    e.parser, e.kind, e.generic = p.name, p.kind, bool(p.generic)
    e.model = None if p.model is None else str(p.model.get("id") or p.model.get("name"))
    if not p.is_pen:
        e.outcome = "ignored"
        e.reason = getattr(p, "why", "") or f"a {p.kind} interface"
        if e.declares_pen:
            e.flag = "refused-pen"
        return e
    e.outcome = "pen"
    generic = p if isinstance(p, GenericPenParser) else getattr(p, "fallback", None)
    if isinstance(generic, GenericPenParser):  # the descriptor path (UC-Logic: before set-up)
        why = roundtrip(generic)
        e.roundtrip = why is None
        if why is not None:
            e.flag, e.reason = "roundtrip", why
    elif p.name.startswith("wacom-") and desc.numbered and not reads_pen(desc, p):
        ids = sorted(r.report_id for r in desc.input_reports())
        e.flag = "protocol-without-pen-report"
        e.reason = f"declares reports {ids}, the protocol reads {sorted(p.pen_report_ids)}"
    return e


def family(e: Entry) -> str:
    """The parser family serving a pen entry (UC-Logic and generic variants folded)."""
    assert e.parser is not None
    name = e.parser.split("/")[0]
    if name == "hid-generic" and e.generic:
        return "hid-generic (unknown device, descriptor path)"
    return name


def sweep(root: Path) -> tuple[list[Entry], dict[str, object]]:
    entries = [e for p in sorted(root.rglob("*.hid.bin")) if (e := sweep_one(p)) is not None]
    pens = [e for e in entries if e.outcome == "pen"]
    pen_devices = [e for e in entries if e.outcome == "pen" or e.declares_pen]
    summary: dict[str, object] = {
        "root": str(root),
        "descriptors": len(entries),
        "by_outcome": dict(Counter(e.outcome for e in entries).most_common()),
        "declaring_a_pen": sum(e.declares_pen for e in entries),
        "pen_devices": len(pen_devices),
        "served_as_pen": len(pens),
        "served_by_family": dict(Counter(family(e) for e in pens).most_common()),
        "distinct_pen_ids_by_family": {
            f: len({e.usb_id + e.bus for e in pens if family(e) == f})
            for f in sorted({family(e) for e in pens})},
        "ignored_by_kind": dict(Counter(e.kind for e in entries
                                        if e.outcome == "ignored").most_common()),
        "refused": sum(e.outcome == "refused" for e in entries),
        "roundtrip_checked": sum(e.roundtrip is not None for e in entries),
        "roundtrip_ok": sum(e.roundtrip is True for e in entries),
        "flagged": [asdict(e) for e in entries if e.flag],
    }
    return entries, summary


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("root", type=Path, help="directory holding *.hid.bin files (searched deep)")
    ap.add_argument("--files", action="store_true", help="one JSON line per descriptor too")
    args = ap.parse_args(argv)
    if not args.root.is_dir():
        sys.stderr.write(f"sweep_descriptors: {args.root}: not a directory\n")
        return 2
    logging.disable(logging.WARNING)  # the registry's per-device warnings: in the summary
    entries, summary = sweep(args.root)
    if args.files:
        for e in entries:
            print(json.dumps(asdict(e)))
    print(json.dumps(summary, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
