"""What pen devices this machine has, and who serves them (``station devices``, and the
blueprint doctor's device check).

Looks at evdev nodes, hidraw nodes, USB (pyusb) and hidapi, and lists the
mock models.  For each real device: what it is, which device-data file and
protocol serve it and, when none does or it cannot be opened, exactly why and
how to fix it.  :func:`model_list` gives every model in the device data with its
protocol instead.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Literal, NotRequired, TypedDict

from station.drivers.devicedata import DeviceModel
from station.drivers.evdev.frames import is_pen_device, ranges_from_caps
from station.drivers.mock.tablet import GENERIC_MODELS
from station.drivers.registry import (
    WACOM_VID,
    bad_device_files,
    find_device,
    interface_from_phys,
    load_devices,
    parser_for,
)
from station.drivers.transport.base import TransportError
from station.drivers.transport.evdev import list_evdev
from station.drivers.transport.hidapi import enumerate_hidapi
from station.drivers.transport.hidraw import HidrawTransport, OsHidrawNode, list_hidraw

from station.errors import BadInput
from station.paths import device_data_dirs

ScanKind = Literal["evdev", "hidraw", "usb", "hidapi"]
SCAN_KINDS: tuple[ScanKind, ...] = ("evdev", "hidraw", "usb", "hidapi")


class ParserInfo(TypedDict, total=False):
    """Which data file and protocol serve a node (``note``: why none, or a caveat)."""

    model: str | None  # the device data's id
    data_file: str | None  # "folder/file.json"
    family: str | None
    parser: str | None
    generic: bool
    is_pen: bool
    kind: str  # "pen", "touch", "pad" …
    note: str


class ScanEntry(ParserInfo, total=False):
    """A device the scan found: the SPEC that opens it, its ids, and what serves it
    (``problem``: why it cannot be opened)."""

    spec: str
    path: str
    name: str | None
    vid: str  # 4 hex digits
    pid: str
    bus: int
    resolution: bool  # evdev: the axes have a resolution
    usage_page: int | None  # hidapi
    interface: int | None  # hidapi
    problem: str


class ScanResult(TypedDict):
    """``station devices --json``: what each way of opening a device found."""

    evdev: list[ScanEntry]
    hidraw: list[ScanEntry]
    usb: list[ScanEntry]
    hidapi: list[ScanEntry]
    mock: list[MockEntry]
    found: int  # devices that can be opened
    problems: list[str]
    notes: list[str]


def _data_file(model: DeviceModel | None) -> str | None:
    if model is None:
        return None
    path = Path(model["_path"])
    return f"{path.parent.name}/{path.name}"


def _parser_name(vid: int, pid: int, descriptor: bytes | None, bus: int,
                 interface: int | None = None) -> ParserInfo:
    """Which data file and protocol serve this node, or exactly why none does."""
    model = find_device(vid, pid, bus)
    base: ParserInfo = {"model": model.get("id") if model else None, "data_file": _data_file(model),
            "family": model.get("family") if model else None}
    try:
        parser = parser_for(vid, pid, descriptor, bus, interface=interface)
    except BadInput as exc:
        return {**base, "parser": None, "note": f"no parser: {exc}"}
    out: ParserInfo = {**base, "parser": parser.name, "generic": bool(parser.generic),
           "is_pen": bool(parser.is_pen), "kind": getattr(parser, "kind", "pen")}
    if parser.warning:
        out["note"] = parser.warning
    elif not parser.is_pen:
        why = getattr(parser, "why", "")
        out["note"] = f"not a pen: {out['kind']} interface" + (f" ({why})" if why else "")
    elif model is None:
        out["note"] = "not in the device data: served from its report descriptor"
    return out


def scan_evdev() -> tuple[list[ScanEntry], list[str]]:
    out: list[ScanEntry] = []
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
        model = find_device(caps.vid, caps.pid, getattr(caps, "bus", None))
        item: ScanEntry = {
                "spec": f"evdev:{entry['path']}", "path": entry["path"], "name": caps.name,
                "vid": f"{caps.vid:04x}", "pid": f"{caps.pid:04x}", "parser": "evdev",
                "resolution": ranges.has_resolution, "model": model["id"] if model else None,
                "data_file": _data_file(model)}
        notes = []
        if model is not None:
            notes.append(f"kernel driver; the station's own protocol for it: {model['parser']}")
        if not ranges.has_resolution:
            notes.append("no resolution: normalised units only, cannot map millimetres")
        if notes:
            item["note"] = "; ".join(notes)
        out.append(item)
    unreadable = [d for d in out if "problem" in d]
    if unreadable:
        notes.append(f"{len(unreadable)} event node(s) not readable: install the udev rules "
                     "(docs/drivers.md, 'Permissions')")
    return out, notes


def scan_hidraw() -> tuple[list[ScanEntry], list[str]]:
    out: list[ScanEntry] = []
    entries = list_hidraw()
    if not entries:
        return out, ["no hidraw nodes (/sys/class/hidraw is empty or missing)"]
    for e in entries:
        vid, pid, bus = int(e["vid"]), int(e["pid"]), int(e["bus"])
        item: ScanEntry = {"spec": f"hidraw:{e['path']}", "path": e["path"],
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
        item.update(_parser_name(vid, pid, descriptor, bus,
                                 interface_from_phys(e["phys"])))
        # Every node a data file names, every pen, and every unknown Wacom (with the reason).
        if item.get("parser") or item.get("model") or vid == WACOM_VID or "problem" in item:
            out.append(item)
    return out, []


def scan_usb() -> tuple[list[ScanEntry], list[str]]:
    try:
        import usb.core  # in the function: pyusb is the optional ``usb`` extra
    except ImportError:
        return [], ["pyusb is not installed"]
    try:
        devices = list(usb.core.find(find_all=True) or [])
    except usb.core.NoBackendError:
        return [], ["pyusb has no backend (libusb-1.0 missing): USB devices not listed"]
    except Exception as exc:  # pyusb surfaces libusb errors untyped
        return [], [f"USB scan failed: {exc}"]
    out: list[ScanEntry] = []
    for d in devices:
        model = find_device(d.idVendor, d.idProduct, 3)
        if model is None:
            continue
        out.append({"spec": f"usb:{d.idVendor:04x}:{d.idProduct:04x}", "name": model["name"],
                    "vid": f"{d.idVendor:04x}", "pid": f"{d.idProduct:04x}",
                    "model": model["id"], "parser": model["parser"],
                    "data_file": _data_file(model), "family": model.get("family"),
                    "note": "claimed by the kernel? use hidraw:/evdev:, or usb:…?detach=1"})
    return out, []


def scan_hidapi() -> tuple[list[ScanEntry], list[str]]:
    out: list[ScanEntry] = []
    for e in enumerate_hidapi():
        vid, pid = int(e.get("vendor_id", 0)), int(e.get("product_id", 0))
        item: ScanEntry = {
                "spec": f"hidapi:{vid:04x}:{pid:04x}", "name": e.get("product_string", ""),
                "vid": f"{vid:04x}", "pid": f"{pid:04x}",
                "usage_page": e.get("usage_page"), "interface": e.get("interface_number")}
        info = _parser_name(vid, pid, None, 3)
        if info.get("model") or e.get("usage_page") == 0x0D:
            item.update(info)
            out.append(item)
    return out, []


class MockEntry(TypedDict):
    """A mock device ``station devices`` lists: the spec that opens it and its ids."""

    spec: str
    name: str | None
    vid: str | None
    pid: str | None
    parser: str | None
    bus: str | None


def mock_models() -> list[MockEntry]:
    """The curated models (hand-written data, encoded by the mock tablet) and generic pens."""
    out: list[MockEntry] = []
    curated = [m for m in load_devices() if "provenance" not in m]
    for m in [*curated, *GENERIC_MODELS.values()]:
        mid = str(m.get("id"))
        out.append({"spec": f"mock:{mid.removeprefix('wacom-')}", "name": m.get("name"),
                    "vid": m.get("vendor_id"), "pid": m.get("product_id"),
                    "parser": m.get("parser"), "bus": m.get("bus")})
    return out


def scan() -> ScanResult:
    notes: list[str] = []
    evdev, more = scan_evdev()
    notes.extend(more)
    hidraw, more = scan_hidraw()
    notes.extend(more)
    usb, more = scan_usb()
    notes.extend(more)
    hidapi, more = scan_hidapi()
    notes.extend(more)
    real = sum(1 for found in (evdev, hidraw, usb, hidapi) for d in found if "problem" not in d)
    problems = [d for found in (evdev, hidraw) for d in found if "problem" in d]
    notes.extend(f"your device data was skipped: {bad}" for bad in bad_device_files())
    return {"evdev": evdev, "hidraw": hidraw, "usb": usb, "hidapi": hidapi,
            "mock": mock_models(), "found": real,
            "problems": [f"{d['path']}: {d['problem']}" for d in problems], "notes": notes}


# One model of the device data as ``station devices --list`` shows it ("from": where the
# record came from, "bundled", "user" …; "overrides": the bundled file it replaces).
ModelRow = TypedDict("ModelRow", {
    "id": str, "vid": str, "pid": str, "bus": str, "protocol": str, "family": str,
    "name": str, "models": int, "screen_tablet": bool, "file": str | None, "source": str,
    "from": str, "path": str, "overrides": NotRequired[str],
})


class ModelList(TypedDict):
    """``station devices --list --json``."""

    models: list[ModelRow]
    device_ids: int
    pen_models: int  # products: an id shared by several counts each
    directories: dict[str, str]  # "user", "system": where own device data goes
    bad_files: list[str]


def model_list() -> ModelList:
    """Every model of the device data: id, ids, protocol, family, name, file."""
    rows: list[ModelRow] = []
    pen_models = 0
    for m in sorted(load_devices(), key=lambda m: (m["vendor_id"], m["product_id"], m["bus"])):
        pen_models += len(m.get("models", [])) or 1
        row: ModelRow = {
            "id": m["id"], "vid": m["vendor_id"], "pid": m["product_id"],
            "bus": m["bus"], "protocol": m["parser"], "family": m.get("family", ""),
            "name": m["name"], "models": len(m.get("models", [])) or 1,
            "screen_tablet": bool(m.get("screen_tablet")), "file": _data_file(m),
            "source": "generated" if "provenance" in m else "curated",
            "from": m.get("_source", "bundled"), "path": m["_path"]}
        if "_overrides" in m:
            row["overrides"] = m["_overrides"]
        rows.append(row)
    return {"models": rows, "device_ids": len(rows), "pen_models": pen_models,
            "directories": {name: str(d) for name, d in device_data_dirs()},
            "bad_files": bad_device_files()}
