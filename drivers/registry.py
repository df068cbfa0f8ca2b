"""Which parser serves which device: the seam between transports and parsers.

Device models live in ``drivers/devices/*.json`` (one per model, validated by
``devices.schema.json``).  :func:`parser_for` picks the parser of a known
model, or — for an unknown device, or a model whose parser is
``hid-generic`` — builds the generic parser from the report descriptor.

    parser = parser_for(0x056A, 0x0315, descriptor_bytes)
    for report, t in reports:
        for raw in parser.parse(report, t):
            ...

Unknown device without a pen collection in its descriptor -> :class:`BadInput`.
"""

from __future__ import annotations

import copy
import json
import logging
import re
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path
from typing import Any

from station.drivers.hid.base import IgnoredInterface, ReportParser
from station.drivers.hid.descriptor import Descriptor, parse_descriptor
from station.drivers.hid.errors import DescriptorError, ReportError
from station.drivers.hid.pen import GenericPenParser
from station.drivers.hid.quirks import pen_usage_quirks
from station.drivers.raw import Axis, AxisRanges
from station.drivers.wacom.bamboo import BambooParser
from station.drivers.wacom.common import WacomParams
from station.drivers.wacom.graphire import GraphireParser
from station.drivers.wacom.intuos import IntuosParser

from station.errors import BadInput

log = logging.getLogger(__name__)

DEVICES_DIR = Path(__file__).resolve().parent / "devices"
SCHEMA_PATH = DEVICES_DIR / "devices.schema.json"

BUS_USB, BUS_BLUETOOTH, BUS_I2C = 0x03, 0x05, 0x18
BUS_NAMES = {"usb": BUS_USB, "bluetooth": BUS_BLUETOOTH, "i2c": BUS_I2C}
BUS_NUMBERS = {v: k for k, v in BUS_NAMES.items()}

__all__ = [
    "PARSERS", "DescriptorError", "ReportError", "ReportParser", "device_ids", "find_device",
    "load_devices", "parser_for", "parser_names",
]  # fmt: skip


def _init_features(model: dict[str, Any]) -> list[bytes]:
    return [bytes.fromhex(h) for h in model.get("init_feature_reports", [])]


def _wacom(cls: type, **kw: Any) -> Callable[[dict[str, Any], Descriptor | None], ReportParser]:
    def make(model: dict[str, Any], desc: Descriptor | None) -> ReportParser:
        parser: ReportParser = cls(WacomParams.from_model(model), model, _init_features(model),
                                   **kw)  # fmt: skip
        return parser

    return make


# Protocol parsers by name (the names device data may use).  "hid-generic" is
# built from the descriptor and has no factory here.
PARSERS: dict[str, Callable[[dict[str, Any], Descriptor | None], ReportParser]] = {
    "wacom-intuos": _wacom(IntuosParser),
    "wacom-bamboo": _wacom(BambooParser),
    "wacom-graphire": _wacom(GraphireParser),
    "wacom-graphire-bt": _wacom(GraphireParser, bluetooth=True),
    "wacom-graphire4": _wacom(GraphireParser, graphire4=True),
}
GENERIC = "hid-generic"


def parser_names() -> list[str]:
    """Every parser name device data may use."""
    return sorted([*PARSERS, GENERIC])


@lru_cache(maxsize=1)
def _validator() -> Any:
    import jsonschema

    return jsonschema.Draft202012Validator(json.loads(SCHEMA_PATH.read_text(encoding="utf-8")))


def parse_device_data(text: str, where: str) -> dict[str, Any]:
    """One device model from its JSON text, checked against ``devices.schema.json``
    and for a parser this station has; anything else is :class:`BadInput` at ``where``."""
    try:
        model = json.loads(text)
    except ValueError as exc:
        raise BadInput(f"device data is not JSON: {exc}", where) from None
    except RecursionError:
        raise BadInput("device data is not JSON (nested too deeply)", where) from None
    try:
        error = next(iter(_validator().iter_errors(model)), None)
    except RecursionError:
        raise BadInput("device data is nested too deeply", where) from None
    if error is not None:
        at = "/".join(str(p) for p in error.absolute_path) or "the top level"
        raise BadInput(f"device data does not fit devices.schema.json at {at}: "
                       f"{error.message[:200]}", where)
    if model["parser"] not in parser_names():
        raise BadInput(f"device data names unknown parser {model['parser']!r} "
                       f"(one of {', '.join(parser_names())})", where)
    return model


@lru_cache(maxsize=1)
def _load() -> tuple[dict[str, Any], ...]:
    models = []
    for path in sorted(DEVICES_DIR.glob("*.json")):
        if path.name.endswith(".schema.json"):
            continue
        model = parse_device_data(path.read_text(encoding="utf-8"), str(path))
        model["_path"] = str(path)
        models.append(model)
    return tuple(models)


def load_devices() -> list[dict[str, Any]]:
    """Every device model (dicts as in the JSON files, plus ``_path``)."""
    return [copy.deepcopy(m) for m in _load()]


def device_ids(model: dict[str, Any]) -> tuple[int, int, int]:
    """(vid, pid, bus number) of a model."""
    return (int(model["vendor_id"], 16), int(model["product_id"], 16), BUS_NAMES[model["bus"]])


def find_device(vid: int, pid: int, bus: int | None = None) -> dict[str, Any] | None:
    """The model with this vid/pid (and bus, when given; else USB first), or None."""
    matches = [m for m in _load() if device_ids(m)[:2] == (vid, pid)]
    if not matches:
        return None
    if bus is not None:
        exact = [m for m in matches if device_ids(m)[2] == bus]
        if exact:
            return copy.deepcopy(exact[0])
    usb = [m for m in matches if m["bus"] == "usb"]
    return copy.deepcopy((usb or matches)[0])


def _model_ranges(model: dict[str, Any]) -> AxisRanges:
    res = model.get("resolution", {})
    return AxisRanges(Axis(0, int(model["max_x"]), res.get("x")),
                      Axis(0, int(model["max_y"]), res.get("y")),
                      Axis(0, int(model["max_pressure"])))  # fmt: skip


def parser_for(vid: int, pid: int, descriptor: bytes | None, bus: int = BUS_USB,
               interface: int | None = None) -> ReportParser:
    """The parser for one interface of a device.

    Args:
        vid, pid: USB/Bluetooth vendor and product ids.
        descriptor: the interface's report descriptor (None when unknown: only
            known protocol devices work then).
        bus: 3 USB, 5 Bluetooth, 0x18 I2C.
        interface: the interface number when known; a model's
            ``ignore_interfaces`` then marks touch/pad interfaces directly.

    Returns a parser whose ``is_pen`` is False for interfaces to ignore.
    Raises :class:`BadInput` for an unknown device without a usable pen
    descriptor, and :class:`DescriptorError` (a BadInput) for a malformed
    descriptor of a device that needs it.
    """
    model = find_device(vid, pid, bus)
    if model is not None and interface is not None:
        for ign in model.get("ignore_interfaces", []):
            if ign["interface"] == interface:
                return IgnoredInterface(f"{model['parser']}/{ign['kind']}", ign["kind"],
                                        _model_ranges(model), model)  # fmt: skip
    if model is not None and model["parser"] != GENERIC:
        factory = PARSERS.get(model["parser"])
        if factory is None:
            raise BadInput(f"device data names unknown parser {model['parser']!r}",
                           model.get("_path"))  # fmt: skip
        desc = None
        if descriptor:
            try:
                desc = parse_descriptor(descriptor)
            except DescriptorError as exc:
                # Protocol devices do not need the descriptor (and kernel fix-ups vary).
                log.warning("%04x:%04x: descriptor ignored: %s", vid, pid, exc)
        parser = factory(model, desc)
        if desc is not None:
            ignored = _non_pen_interface(desc, model, parser)
            if ignored is not None:
                return ignored
        return parser
    if not descriptor:
        what = model["name"] if model else f"unknown device {vid:04x}:{pid:04x}"
        raise BadInput(f"{what} needs its report descriptor (generic HID parser)")
    desc = parse_descriptor(descriptor)
    parser = GenericPenParser(desc, model, _init_features(model) if model else [],
                              generic=model is None, quirks=pen_usage_quirks(vid, pid))
    if model is not None:
        parser.name = GENERIC
        return parser  # known model: its touch/pad interfaces come back with is_pen False
    if not parser.is_pen:
        kinds = sorted(set(parser.kinds.values())) or ["no input reports"]
        raise BadInput(f"unknown device {vid:04x}:{pid:04x} has no pen collection in its "
                       f"report descriptor (reports: {', '.join(kinds)})")  # fmt: skip
    return parser


# Report lengths of Wacom touch frames that share report ID 2 with the pen protocol
# (kernel WACOM_PKGLEN_BBTOUCH 20, WACOM_PKGLEN_BBTOUCH3 64: Bamboo/Intuos5/Pro touch).
TOUCH_REPORT_LENGTHS = frozenset({20, 64})


def _non_pen_interface(desc: Descriptor, model: dict[str, Any],
                       parser: ReportParser) -> ReportParser | None:
    """A protocol device's interface that plainly carries no pen -> ignored interface.

    The kernel only delivers reports a descriptor declares, so a protocol pen
    interface declares the parser's pen report IDs.  An interface is touch when
    it has Finger collections or a Touch Screen/Pad application and no pen
    report, or when its pen-ID reports all have a touch-frame length (Wacom
    touch interfaces reuse report ID 2 with 64-byte frames).  Interfaces known
    by number (``ignore_interfaces``, matched through the ``P:`` path) are
    handled before this.
    """
    from station.drivers.hid.pen import classify_reports

    kinds = set(classify_reports(desc).values())
    ranges = _model_ranges(model)
    if "touch" in kinds and "pen" not in kinds:
        return IgnoredInterface(f"{model['parser']}/touch", "touch", ranges, model)
    pen_ids: frozenset[int] = getattr(parser, "pen_report_ids", frozenset())
    if not desc.numbered or not pen_ids:
        return None
    lengths = {r.report_id: r.length(True) for r in desc.input_reports() if r.report_id}
    if not lengths:
        return None
    declared = {rid: n for rid, n in lengths.items() if rid in pen_ids}
    # A descriptor that declares no pen ID at all is left alone (kernel fix-ups and
    # Bluetooth descriptors vary); only the touch-frame length is conclusive.
    if declared and all(n in TOUCH_REPORT_LENGTHS for n in declared.values()):
        return IgnoredInterface(f"{model['parser']}/touch", "touch", ranges, model)
    return None


def interface_from_phys(phys: str) -> int | None:
    """The USB interface number in a physical path such as ``usb-0000:00:14.0-2/input1``."""
    m = re.search(r"/input(\d+)$", phys.strip())
    return int(m.group(1)) if m else None
