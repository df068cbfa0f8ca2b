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
from typing import TYPE_CHECKING

from station.drivers.devicedata import BusName, DeviceModel
from station.drivers.hid import usages as U
from station.drivers.hid.base import IgnoredInterface, ReportParser
from station.drivers.hid.descriptor import Descriptor, ReportType, parse_descriptor
from station.drivers.hid.errors import DescriptorError, ReportError
from station.drivers.hid.pen import GenericPenParser, classify_reports
from station.drivers.hid.quirks import pen_usage_quirks
from station.drivers.raw import Axis, AxisRanges
from station.drivers.uclogic.parser import UclogicPenParser
from station.drivers.wacom.bamboo import BambooParser
from station.drivers.wacom.bluetooth import Intuos4WirelessParser, IntuosBluetoothParser
from station.drivers.wacom.common import WacomParams
from station.drivers.wacom.graphire import GraphireParser
from station.drivers.wacom.intuos import IntuosParser
from station.drivers.wacom.legacy import PROTOCOLS as LEGACY
from station.drivers.wacom.legacy import LegacyPenParser

from station import boundedio, paths
from station.errors import BadInput

if TYPE_CHECKING:  # jsonschema is imported where device data is first checked
    import jsonschema

log = logging.getLogger(__name__)
_eq_usage = U.equivalent_usage

DEVICES_DIR = Path(__file__).resolve().parent / "devices"
MAX_DEVICE_DATA = 256 * 1024  # characters of one model's JSON (the largest shipped: 21 KiB)
MAX_STRING = 4096  # one string in it (names, notes)
MAX_FEATURE_REPORT = 64  # bytes of one init feature report (shipped ones: 2)
SCHEMA_PATH = DEVICES_DIR / "devices.schema.json"

BUS_USB, BUS_BLUETOOTH, BUS_I2C = 0x03, 0x05, 0x18
BUS_NAMES: dict[BusName, int] = {"usb": BUS_USB, "bluetooth": BUS_BLUETOOTH, "i2c": BUS_I2C}
BUS_NUMBERS: dict[int, BusName] = {v: k for k, v in BUS_NAMES.items()}

__all__ = [
    "PARSERS", "DescriptorError", "ReportError", "ReportParser", "device_ids", "find_device",
    "load_devices", "parser_for", "parser_names",
]  # fmt: skip


def _init_features(model: DeviceModel) -> list[bytes]:
    return [bytes.fromhex(h) for h in model.get("init_feature_reports", [])]


def _wacom(cls: Callable[..., ReportParser], **kw: bool,
           ) -> Callable[[DeviceModel, Descriptor | None], ReportParser]:
    def make(model: DeviceModel, desc: Descriptor | None) -> ReportParser:
        parser: ReportParser = cls(WacomParams.from_model(model), model, _init_features(model),
                                   **kw)  # fmt: skip
        return parser

    return make


# Protocol parsers by name (the names device data may use).  "hid-generic" is
# built from the descriptor and has no factory here.
PARSERS: dict[str, Callable[[DeviceModel, Descriptor | None], ReportParser]] = {
    "wacom-intuos": _wacom(IntuosParser),
    "wacom-bamboo": _wacom(BambooParser),
    "wacom-graphire": _wacom(GraphireParser),
    "wacom-graphire-bt": _wacom(GraphireParser, bluetooth=True),
    "wacom-graphire4": _wacom(GraphireParser, graphire4=True),
    "wacom-intuos1": _wacom(IntuosParser, original=True),
    "wacom-intuos4wl": _wacom(Intuos4WirelessParser),
    "wacom-intuos-bt": _wacom(IntuosBluetoothParser),
}
for _name in LEGACY:
    PARSERS[_name] = _wacom(LegacyPenParser.for_protocol(_name))
GENERIC = "hid-generic"
UCLOGIC = "uclogic"
WACOM_VID = 0x056A
# The interface that carries the pen on UC-Logic tablets (uclogic_params_init: Huion
# and v1 tablets interface 0, UGEE v2 interface 2).
UCLOGIC_PEN_INTERFACE = {"huion": 0, "v1": 0, "ugee-v2": 2}
REPORT_HINT = ("please report it (docs/devices.md, 'Reporting a tablet'): attach "
               "`station record --device hidraw:/dev/hidrawN -o tablet.hid` and "
               "`lsusb -v -d {vid:04x}:{pid:04x}`")


def parser_names() -> list[str]:
    """Every parser name device data may use."""
    return sorted([*PARSERS, GENERIC, UCLOGIC])


@lru_cache(maxsize=1)
def _validator() -> jsonschema.Draft202012Validator:
    import jsonschema

    return jsonschema.Draft202012Validator(json.loads(SCHEMA_PATH.read_text(encoding="utf-8")))


def parse_device_data(text: str, where: str) -> DeviceModel:
    """One device model from its JSON text, checked against ``devices.schema.json``
    and for a parser this station has; anything else is :class:`BadInput` at ``where``.
    Sizes are capped (:data:`MAX_DEVICE_DATA`, :data:`MAX_STRING`,
    :data:`MAX_FEATURE_REPORT`): a real model is a few KiB, a feature report a few
    bytes, and the driver sends those reports to the device."""
    if len(text) > MAX_DEVICE_DATA:
        raise BadInput(f"device data is {len(text)} characters, more than "
                       f"{MAX_DEVICE_DATA}", where)
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
    for key, value in model.items():
        strings = [value] if isinstance(value, str) else \
            [v for v in value if isinstance(v, str)] if isinstance(value, list) else []
        for v in strings:
            if len(v) > MAX_STRING:
                raise BadInput(f"device data {key!r} holds a string of {len(v)} characters "
                               f"(at most {MAX_STRING})", where)
    for report in model["init_feature_reports"]:
        if not isinstance(report, str) or len(report) > 2 * MAX_FEATURE_REPORT:
            raise BadInput(f"device data init_feature_reports: a report longer than "
                           f"{MAX_FEATURE_REPORT} bytes", where)
    if model["parser"] not in parser_names():
        raise BadInput(f"device data names unknown parser {model['parser']!r} "
                       f"(one of {', '.join(parser_names())})", where)
    return model


@lru_cache(maxsize=1)
def _bundled() -> tuple[DeviceModel, ...]:
    """The package's own models (validated once per process: 560 files, ~1 s)."""
    models = read_device_dir(DEVICES_DIR)
    for model in models:
        model["_source"] = "bundled"
    return tuple(models)


def read_device_dir(directory: Path) -> list[DeviceModel]:
    """Every model in ``directory`` (``*.json``), each checked; two with one id are
    refused (the second would shadow the first depending on file order)."""
    models = []
    seen: dict[str, str] = {}
    for path in sorted(directory.glob("*.json")):
        if path.name.endswith(".schema.json"):
            continue
        model = parse_device_data(
            boundedio.read_text(path, MAX_DEVICE_DATA * 4, str(path)), str(path))
        if model["id"] in seen:
            raise BadInput(f"device id {model['id']!r} is also in {seen[model['id']]}",
                           str(path))
        seen[model["id"]] = str(path)
        model["_path"] = str(path)
        models.append(model)
    return models


@lru_cache(maxsize=1)
def _load() -> tuple[DeviceModel, ...]:
    """The bundled models, then the system's and the user's device data
    (:func:`station.paths.device_data_dirs`), a later file replacing an earlier model
    with the same id or the same vendor, product and bus.  A bad file of the system or
    the user is said in one line (file and field) and skipped: the rest still works."""
    models = {m["id"]: m for m in _bundled()}
    _BAD_FILES.clear()
    for source, directory in paths.device_data_dirs():
        try:
            files = sorted(directory.glob("*.json"))
        except OSError:
            continue
        for path in files:
            try:
                model = parse_device_data(_read_small(path), str(path))
            except BadInput as exc:
                _BAD_FILES.append(str(exc))  # names the file and the field
                log.warning("device data skipped (the bundled data still works): %s", exc)
                continue
            model["_path"], model["_source"] = str(path), source
            ids = device_ids(model)
            for key in [k for k, m in models.items() if device_ids(m) == ids]:
                model["_overrides"] = models.pop(key)["_path"]
            if model["id"] in models:
                model["_overrides"] = models.pop(model["id"])["_path"]
            models[model["id"]] = model
    return tuple(models.values())


_BAD_FILES: list[str] = []
MAX_DEVICE_FILE = 1 << 20  # device data is a few kB: a bigger file is not one


def _read_small(path: Path) -> str:
    try:
        with path.open("rb") as f:
            data = f.read(MAX_DEVICE_FILE + 1)
    except OSError as exc:
        raise BadInput(f"cannot read it ({exc.strerror})", str(path)) from None
    if len(data) > MAX_DEVICE_FILE:
        raise BadInput(f"over {MAX_DEVICE_FILE} bytes: not device data", str(path))
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise BadInput("not UTF-8 text", str(path)) from None


def bad_device_files() -> list[str]:
    """The user's and the system's device files that were skipped, each with why."""
    _load()
    return list(_BAD_FILES)


def reload_devices() -> None:
    """Read the device data again (after a file was added or changed)."""
    _load.cache_clear()
    _by_ids.cache_clear()


def load_devices() -> list[DeviceModel]:
    """Every device model (dicts as in the JSON files, plus ``_path`` and ``_source``:
    ``bundled``, ``system`` or ``user``; ``_overrides``: the file it replaces)."""
    return [copy.deepcopy(m) for m in _load()]


def device_ids(model: DeviceModel) -> tuple[int, int, int]:
    """(vid, pid, bus number) of a model."""
    return (int(model["vendor_id"], 16), int(model["product_id"], 16), BUS_NAMES[model["bus"]])


@lru_cache(maxsize=1)
def _by_ids() -> dict[tuple[int, int], list[DeviceModel]]:
    index: dict[tuple[int, int], list[DeviceModel]] = {}
    for m in _load():
        index.setdefault(device_ids(m)[:2], []).append(m)
    return index


def find_device(vid: int, pid: int, bus: int | None = None) -> DeviceModel | None:
    """The model with this vid/pid (and bus, when given; else USB first), or None."""
    matches = _by_ids().get((vid, pid), [])
    if not matches:
        return None
    if bus is not None:
        exact = [m for m in matches if device_ids(m)[2] == bus]
        if exact:
            return copy.deepcopy(exact[0])
    usb = [m for m in matches if m["bus"] == "usb"]
    return copy.deepcopy((usb or matches)[0])


def _model_ranges(model: DeviceModel) -> AxisRanges:
    # Descriptor-driven models (hid-generic, uclogic) may carry no numbers: 0..1 then.
    res = model.get("resolution", {})
    return AxisRanges(Axis(0, int(model.get("max_x", 1)), res.get("x")),
                      Axis(0, int(model.get("max_y", 1)), res.get("y")),
                      Axis(0, int(model.get("max_pressure", 1))))  # fmt: skip


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
    if model is not None and model["parser"] == UCLOGIC:
        return _uclogic(model, descriptor, interface)
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
            parser.unused_report_ids = unused_report_ids(desc, parser)
        return parser
    if not descriptor:
        what = model["name"] if model else f"unknown device {vid:04x}:{pid:04x}"
        unknown_wacom = model is None and vid == WACOM_VID
        hint = f"; {REPORT_HINT.format(vid=vid, pid=pid)}" if unknown_wacom else ""
        raise BadInput(f"{what} needs its report descriptor (generic HID parser){hint}")
    desc = parse_descriptor(descriptor)
    if model is None and vid == WACOM_VID:
        return _unknown_wacom(vid, pid, desc, bus)
    feats = _init_features(model) if model else []
    if vid == WACOM_VID:
        feats += [f for f in [wacom_data_mode_feature(desc)] if f and f not in feats]
    parser = GenericPenParser(desc, model, feats,
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


def _non_pen_interface(desc: Descriptor, model: DeviceModel,
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
    any_length = getattr(getattr(parser, "protocol", None), "any_id_length", None)
    desktop_only = all(_eq_usage(a) >> 16 == U.PAGE_GENERIC_DESKTOP
                       for a in desc.application_usages())
    if desktop_only and not any(rid in pen_ids or n == any_length for rid, n in lengths.items()):
        # Only a boot mouse/keyboard and no pen report (the third interface of the Intuos
        # CTL/CTH-490, 056a:033c: report 1, a relative mouse).  hid-core drops undeclared
        # report IDs before any driver sees them, so no pen report can come from here.
        return IgnoredInterface(f"{model['parser']}/other", "other", ranges, model)
    declared = {rid: n for rid, n in lengths.items() if rid in pen_ids}
    # A descriptor that declares no pen ID at all is left alone (kernel fix-ups and
    # Bluetooth descriptors vary); only the touch-frame length is conclusive.
    if declared and all(n in TOUCH_REPORT_LENGTHS for n in declared.values()):
        return IgnoredInterface(f"{model['parser']}/touch", "touch", ranges, model)
    return None


def unused_report_ids(desc: Descriptor, parser: ReportParser) -> frozenset[int]:
    """Input report IDs the descriptor declares and the protocol parser does not read.

    The kernel's Wacom protocol handlers (wacom_graphire_irq, wacom_intuos_irq …) return
    on a report ID they do not handle (dev_dbg only): the PenPartner/PenStation2
    descriptor declares a vendor report 0x63 that the device sends between pen reports.
    Such reports are skipped and counted by ID; an ID the descriptor does not declare
    stays a bad report.
    """
    if not desc.numbered:
        return frozenset()
    pen_ids: frozenset[int] = frozenset(getattr(parser, "pen_report_ids", ()))
    return frozenset(r.report_id for r in desc.input_reports() if r.report_id) - pen_ids


def interface_from_phys(phys: str) -> int | None:
    """The USB interface number in a physical path such as ``usb-0000:00:14.0-2/input1``."""
    m = re.search(r"/input(\d+)$", phys.strip())
    return int(m.group(1)) if m else None


def _uclogic(model: DeviceModel, descriptor: bytes | None,
             interface: int | None) -> ReportParser:
    """A UC-Logic interface: the pen one gets the set-up-capable parser, others are ignored."""
    desc = None
    if descriptor:
        try:
            desc = parse_descriptor(descriptor)
        except DescriptorError as exc:
            log.warning("%s: descriptor ignored: %s", model["name"], exc)
    parser = UclogicPenParser(model, desc)
    pen_interface = UCLOGIC_PEN_INTERFACE.get(parser.init_kind)
    if (parser.fallback is None and desc is not None and interface is not None
            and interface != pen_interface):
        kinds = set(GenericPenParser(desc, model).kinds.values()) - {"pen"}
        kind = "pad" if "pad" in kinds else "other"
        return IgnoredInterface(f"uclogic/{kind}", kind, _model_ranges(model), model)
    return parser


WACOM_HID_WD_DATAMODE = 0xFF0D1002


def wacom_data_mode_feature(desc: Descriptor) -> bytes | None:
    """The kernel's mode switch for generic-HID Wacoms (wacom_hid_usage_quirk / set_device_mode):
    the feature report holding Wacom's Data Mode usage gets value 2 in its first byte."""
    for (rtype, rid), report in sorted(desc.reports.items(), key=lambda kv: kv[0][1]):
        if rtype == ReportType.FEATURE and rid and any(
                WACOM_HID_WD_DATAMODE in f.usages for f in report.fields):
            return bytes([rid, 2]) + bytes(max(0, report.length(True) - 2))
    return None


# Pen report lengths (with the ID byte) of report 2 on a vendor-defined Wacom interface ->
# the protocol it implies: 8 Graphire, 9 Bamboo "fun", 10..16 the Intuos family.
_IMPLIED = ((8, "wacom-graphire"), (9, "wacom-bamboo"),
            *((n, "wacom-intuos") for n in range(10, 17)))


def implied_protocol(desc: Descriptor) -> str | None:
    """The Wacom protocol a descriptor implies (None: no vendor report 2 of a pen length)."""
    lengths = {r.report_id: r.length(True) for r in desc.input_reports() if r.report_id}
    return dict(_IMPLIED).get(lengths.get(2, 0))


def _unknown_wacom(vid: int, pid: int, desc: Descriptor, bus: int) -> ReportParser:
    """An unknown Wacom id: the generic pen path, or the protocol its descriptor implies."""
    mode = wacom_data_mode_feature(desc)
    generic = GenericPenParser(desc, None, [mode] if mode else [], generic=True,
                               quirks=pen_usage_quirks(vid, pid))
    what = f"unknown Wacom tablet {vid:04x}:{pid:04x}"
    if generic.is_pen:
        generic.warning = (f"{what}: read through its HID descriptor (generic path); "
                           + REPORT_HINT.format(vid=vid, pid=pid))
        log.warning("%s", generic.warning)
        return generic
    family = implied_protocol(desc)
    if family is None:
        kinds = sorted(set(generic.kinds.values())) or ["no input reports"]
        raise BadInput(f"{what} has no pen collection and no Wacom pen report in its report "
                       f"descriptor (reports: {', '.join(kinds)}); "
                       + REPORT_HINT.format(vid=vid, pid=pid))  # fmt: skip
    # Ranges: the largest known model of the family, so no coordinate leaves its range;
    # the mapping to the surface is a guess until the tablet is in the data.
    peers = [m for m in _load() if m["parser"] == family and "max_x" in m]
    big = max(peers, key=lambda m: int(m["max_x"]) * int(m["max_y"]))
    model: DeviceModel = {}
    # the ranges of the family's largest model first (the keys in the order they had)
    if "max_x" in big:
        model["max_x"] = big["max_x"]
    if "max_y" in big:
        model["max_y"] = big["max_y"]
    if "max_pressure" in big:
        model["max_pressure"] = big["max_pressure"]
    if "max_distance" in big:
        model["max_distance"] = big["max_distance"]
    if "resolution" in big:
        model["resolution"] = big["resolution"]
    if "pad_report_ids" in big:
        model["pad_report_ids"] = big["pad_report_ids"]
    model.update({
        "id": f"wacom-unknown-{pid:04x}", "name": what, "vendor_id": f"{vid:04x}",
        "product_id": f"{pid:04x}", "bus": BUS_NUMBERS.get(bus, "usb"),
        "parser": family, "init_feature_reports": ["0202"] if bus == BUS_USB else [],
    })
    parser = PARSERS[family](model, desc)
    parser.unused_report_ids = unused_report_ids(desc, parser)
    parser.generic = True
    parser.warning = (f"{what}: its descriptor implies the {family} protocol; ranges guessed "
                      f"from {big['name']}; " + REPORT_HINT.format(vid=vid, pid=pid))
    log.warning("%s", parser.warning)
    return parser
