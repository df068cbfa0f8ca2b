"""``station devices [--json]``: what pen devices this machine has, and who serves them.

Looks at evdev nodes, hidraw nodes, USB (pyusb) and hidapi, and lists the
mock models.  For each real device: what it is, which parser serves it and,
when it cannot be opened, why and how to fix it.  A machine with no tablet
says so plainly.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from typing import Any


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("devices", help="list pen devices (evdev, hidraw, USB, mock)")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def _parser_name(vid: int, pid: int, descriptor: bytes | None, bus: int) -> dict[str, Any]:
    from station.drivers.registry import find_device, parser_for
    from station.errors import BadInput

    model = find_device(vid, pid, bus)
    try:
        parser = parser_for(vid, pid, descriptor, bus)
    except BadInput as exc:
        return {"parser": None, "model": model.get("id") if model else None,
                "note": str(exc)}
    return {"parser": parser.name, "model": model.get("id") if model else None,
            "generic": bool(parser.generic), "is_pen": bool(parser.is_pen),
            "kind": getattr(parser, "kind", "pen")}


def scan_evdev() -> tuple[list[dict[str, Any]], list[str]]:
    from station.drivers.evdev.frames import is_pen_device, ranges_from_caps
    from station.drivers.transport.base import TransportError
    from station.drivers.transport.evdev import list_evdev

    out: list[dict[str, Any]] = []
    notes: list[str] = []
    if not os.path.isdir("/dev/input"):
        return out, ["no /dev/input on this machine (no evdev devices, or a container)"]
    try:
        nodes = list_evdev()
    except TransportError as exc:
        return out, [str(exc)]
    for entry in nodes:
        if "error" in entry:
            out.append({"spec": f"evdev:{entry['path']}", "path": entry["path"],
                        "problem": entry["error"]})
            continue
        caps = entry["caps"]
        if not is_pen_device(caps):
            continue
        ranges = ranges_from_caps(caps)
        item = {"spec": f"evdev:{entry['path']}", "path": entry["path"], "name": caps.name,
                "vid": f"{caps.vid:04x}", "pid": f"{caps.pid:04x}", "parser": "evdev",
                "resolution": ranges.has_resolution}
        if not ranges.has_resolution:
            item["note"] = "no resolution: normalised units only, cannot map millimetres"
        out.append(item)
    unreadable = [d for d in out if "problem" in d]
    if unreadable:
        notes.append(f"{len(unreadable)} event node(s) not readable: install the udev rules "
                     "(docs/drivers.md, 'Permissions')")
    return out, notes


def scan_hidraw() -> tuple[list[dict[str, Any]], list[str]]:
    from station.drivers.transport.base import TransportError
    from station.drivers.transport.hidraw import HidrawTransport, OsHidrawNode, list_hidraw

    out: list[dict[str, Any]] = []
    entries = list_hidraw()
    if not entries:
        return out, ["no hidraw nodes (/sys/class/hidraw is empty or missing)"]
    for e in entries:
        vid, pid, bus = int(e["vid"]), int(e["pid"]), int(e["bus"])
        item: dict[str, Any] = {"spec": f"hidraw:{e['path']}", "path": e["path"],
                                "name": e["name"], "vid": f"{vid:04x}", "pid": f"{pid:04x}",
                                "bus": bus}
        descriptor = None
        if e["readable"]:
            try:
                t = HidrawTransport(OsHidrawNode(str(e["path"])))
                descriptor = t.info.descriptor
                t.close()
            except (TransportError, OSError) as exc:
                item["problem"] = str(exc)
        else:
            item["problem"] = (f"no permission to open {e['path']}: install the station udev "
                               "rules (uaccess) or join the 'station' group")
        item.update(_parser_name(vid, pid, descriptor, bus))
        if item.get("parser") or item.get("model"):
            out.append(item)
    return out, []


def scan_usb() -> tuple[list[dict[str, Any]], list[str]]:
    from station.drivers.registry import find_device

    try:
        import usb.core
    except ImportError:
        return [], ["pyusb is not installed"]
    try:
        devices = list(usb.core.find(find_all=True) or [])
    except usb.core.NoBackendError:
        return [], ["pyusb has no backend (libusb-1.0 missing): USB devices not listed"]
    except Exception as exc:  # pyusb surfaces libusb errors untyped
        return [], [f"USB scan failed: {exc}"]
    out = []
    for d in devices:
        model = find_device(d.idVendor, d.idProduct, 3)
        if model is None:
            continue
        out.append({"spec": f"usb:{d.idVendor:04x}:{d.idProduct:04x}", "name": model["name"],
                    "vid": f"{d.idVendor:04x}", "pid": f"{d.idProduct:04x}",
                    "model": model["id"], "parser": model["parser"],
                    "note": "claimed by the kernel? use hidraw:/evdev:, or usb:…?detach=1"})
    return out, []


def scan_hidapi() -> tuple[list[dict[str, Any]], list[str]]:
    from station.drivers.transport.hidapi import enumerate_hidapi

    out = []
    for e in enumerate_hidapi():
        vid, pid = int(e.get("vendor_id", 0)), int(e.get("product_id", 0))
        item = {"spec": f"hidapi:{vid:04x}:{pid:04x}", "name": e.get("product_string", ""),
                "vid": f"{vid:04x}", "pid": f"{pid:04x}",
                "usage_page": e.get("usage_page"), "interface": e.get("interface_number")}
        info = _parser_name(vid, pid, None, 3)
        if info.get("model") or e.get("usage_page") == 0x0D:
            item.update(info)
            out.append(item)
    return out, []


def mock_models() -> list[dict[str, Any]]:
    from station.drivers.mock.tablet import GENERIC_MODELS
    from station.drivers.registry import load_devices

    out = []
    for m in [*load_devices(), *GENERIC_MODELS.values()]:
        mid = str(m.get("id"))
        out.append({"spec": f"mock:{mid.removeprefix('wacom-')}", "name": m.get("name"),
                    "vid": m.get("vendor_id"), "pid": m.get("product_id"),
                    "parser": m.get("parser"), "bus": m.get("bus")})
    return out


def scan() -> dict[str, Any]:
    result: dict[str, Any] = {}
    notes: list[str] = []
    for key, fn in (("evdev", scan_evdev), ("hidraw", scan_hidraw), ("usb", scan_usb),
                    ("hidapi", scan_hidapi)):
        found, more = fn()
        result[key] = found
        notes.extend(more)
    real = sum(1 for k in ("evdev", "hidraw", "usb", "hidapi") for d in result[k]
               if "problem" not in d)
    problems = [d for k in ("evdev", "hidraw") for d in result[k] if "problem" in d]
    result["mock"] = mock_models()
    result["found"] = real
    result["problems"] = [f"{d['path']}: {d['problem']}" for d in problems]
    result["notes"] = notes
    return result


def run(args: argparse.Namespace) -> int:
    result = scan()
    if args.json:
        json.dump(result, sys.stdout, indent=2)
        sys.stdout.write("\n")
        return 0
    w = sys.stdout.write
    if result["found"] == 0:
        w("No pen tablet found on this machine.\n")
    for key, title in (("evdev", "evdev (kernel driver)"), ("hidraw", "hidraw"),
                       ("usb", "USB (pyusb)"), ("hidapi", "hidapi")):
        for d in result[key]:
            parser = d.get("parser") or "none"
            extra = f" — {d['problem']}" if "problem" in d else (
                f" ({d['note']})" if d.get("note") else "")
            w(f"{title}: {d['spec']}  {d.get('name', '')}  parser={parser}{extra}\n")
    for note in result["notes"]:
        w(f"  note: {note}\n")
    for problem in result["problems"]:
        w(f"  problem: {problem}\n")
    w("Mock devices (for testing without a tablet; add ?script=demo&rate=200):\n")
    for m in result["mock"]:
        w(f"  {m['spec']:<34} {m['name']}  parser={m['parser']}\n")
    return 0
