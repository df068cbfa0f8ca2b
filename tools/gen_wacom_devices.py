#!/usr/bin/env python3
"""Generate ``drivers/devices/*.json`` from the Linux Wacom table and libwacom's data.

    python tools/gen_wacom_devices.py --cache DIR [--check]

DIR holds the source texts (never committed; see docs/devices.md for how to
fetch them):

- ``input-wacom/4.18/wacom_wac.c`` and ``wacom_wac.h`` (linuxwacom/input-wacom,
  the kernel's Wacom driver as maintained upstream; its device table is the
  one in torvalds/linux ``drivers/hid/wacom_wac.c``), with ``input-wacom/COMMIT``;
- ``libwacom/data/*.tablet`` and ``*.stylus`` (linuxwacom/libwacom), with
  ``libwacom/COMMIT``;
- ``digimend/hid-uclogic-core.c`` and ``hid-ids.h`` (the uclogic driver's id
  table; DIGImend/digimend-kernel-drivers), with ``digimend/COMMIT``.

Facts are read from the texts (numbers, names, ids; ``tools/wacom_sources.py``); no code
is copied.  One
file is written per pen-capable device id (vendor, product, bus).  Files
without a ``provenance`` key are curated by hand and left alone: the
generator skips their ids.  Files it wrote before and would not write now are
removed.  ``--check`` writes nothing and exits 1 when the directory differs.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path
from typing import Any, TypedDict

# tools/ is no package: run as a script, or loaded by path (tests), the generator finds its
# sibling module through its own folder
sys.path.insert(0, str(Path(__file__).resolve().parent))
from wacom_sources import (
    WACOM,
    CValue,
    KernelEntry,
    Source,
    Styli,
    StylusGroups,
    Tablet,
    c_defines,
    enum_order,
    parse_features,
    parse_id_table,
    parse_styli,
    parse_tablet,
    resolve_styli,
    strip_c_comments,
    uclogic_ids,
    uclogic_init_kinds,
)

ROOT = Path(__file__).resolve().parent.parent
OUT_DIR = ROOT / "drivers" / "devices"
GENERATOR = "tools/gen_wacom_devices.py"

# Kernel type (wacom_wac.h enum) -> (station parser, family name, protocol quirks).
# Which irq handler serves which type is wacom_wac_irq()'s switch; the quirks
# are the type tests inside wacom_intuos_general() / wacom_intuos_pro2_bt_pen().
_INTUOS3 = "wacom-intuos"
TYPE_PROTOCOL: dict[str, tuple[str, str, list[str]]] = {
    "PENPARTNER": ("wacom-penpartner", "PenPartner", []),
    "GRAPHIRE": ("wacom-graphire", "Graphire/Volito/Bamboo1", []),
    "GRAPHIRE_BT": ("wacom-graphire-bt", "Graphire Bluetooth", []),
    "WACOM_G4": ("wacom-graphire4", "Graphire4", []),
    "WACOM_MO": ("wacom-graphire4", "Bamboo Fun (MO)", []),
    "PTU": ("wacom-ptu", "Cintiq Partner (PTU)", []),
    "PL": ("wacom-pl", "PL / DTF / DTU pen display", []),
    "DTU": ("wacom-dtu", "DTU pen display", []),
    "DTUS": ("wacom-dtus", "DTU/DTK (DTUS)", []),
    "DTUSX": ("wacom-dtus", "DTU (DTUSX)", []),
    "INTUOS": ("wacom-intuos1", "Intuos/Intuos2", []),
    "INTUOS3S": (_INTUOS3, "Intuos3", ["no-lens"]),
    "INTUOS3": (_INTUOS3, "Intuos3", ["no-lens"]),
    "INTUOS3L": (_INTUOS3, "Intuos3", []),
    "INTUOS4S": (_INTUOS3, "Intuos4", ["no-lens"]),
    "INTUOS4": (_INTUOS3, "Intuos4", ["no-lens"]),
    "INTUOS4L": (_INTUOS3, "Intuos4", []),
    "INTUOS4WL": ("wacom-intuos4wl", "Intuos4 wireless (Bluetooth)", []),
    "INTUOS5S": (_INTUOS3, "Intuos5", ["no-lens"]),
    "INTUOS5": (_INTUOS3, "Intuos5", ["no-lens"]),
    "INTUOS5L": (_INTUOS3, "Intuos5", []),
    "INTUOSPS": (_INTUOS3, "Intuos Pro", ["no-lens"]),
    "INTUOSPM": (_INTUOS3, "Intuos Pro", ["no-lens"]),
    "INTUOSPL": (_INTUOS3, "Intuos Pro", []),
    "INTUOSP2_BT": ("wacom-intuos-bt", "Intuos Pro 2 (Bluetooth)", ["pro2-frames"]),
    "INTUOSP2S_BT": ("wacom-intuos-bt", "Intuos Pro 2 S (Bluetooth)", ["pro2-frames"]),
    "INTUOSHT3_BT": ("wacom-intuos-bt", "Intuos CTL-4100/6100 (Bluetooth)", []),
    "WACOM_21UX2": (_INTUOS3, "Cintiq 21UX2", ["old-styli-invalid"]),
    "WACOM_22HD": (_INTUOS3, "Cintiq 22HD", []),
    "DTK": (_INTUOS3, "DTK/DTH pen display", []),
    "WACOM_24HD": (_INTUOS3, "Cintiq 24HD", []),
    "WACOM_27QHD": (_INTUOS3, "Cintiq 27QHD", []),
    "CINTIQ_HYBRID": (_INTUOS3, "Cintiq Companion Hybrid", []),
    "CINTIQ_COMPANION_2": (_INTUOS3, "Cintiq Companion 2", []),
    "CINTIQ": (_INTUOS3, "Cintiq", ["ready-bit"]),
    "WACOM_BEE": (_INTUOS3, "Cintiq 12WX/20WSX", []),
    "WACOM_13HD": (_INTUOS3, "Cintiq 13HD", []),
    "BAMBOO_PEN": ("wacom-bamboo", "Bamboo Pen / Wacom One", []),
    "BAMBOO_PT": ("wacom-bamboo", "Bamboo Pen & Touch", []),
    "INTUOSHT": ("wacom-bamboo", "Intuos (CTL/CTH-480/680)", []),
    "INTUOSHT2": (_INTUOS3, "Intuos (CTL/CTH-490/690)", ["no-tilt", "distance-inverted"]),
    "TABLETPC": ("wacom-tpc", "ISDv4 Tablet PC", []),
    "TABLETPCE": ("wacom-tpc", "ISDv4 Tablet PC", []),
    "TABLETPC2FG": ("wacom-tpc", "ISDv4 Tablet PC", []),
    "MTSCREEN": ("wacom-tpc", "ISDv4 Tablet PC", []),
    "MTTPC": ("wacom-tpc", "ISDv4 Tablet PC", []),
    "MTTPC_B": ("wacom-tpc", "ISDv4 Tablet PC", []),
    "HID_GENERIC": ("hid-generic", "Wacom generic HID", []),
}
# Measured corrections: what a device's pen really sends, where recordings of it show the
# kernel table (which gives every pen of a kernel type the type's axes) and libwacom claim
# more.  Each one names its evidence; the model gets the quirk and its provenance says why.
class Measured(TypedDict):
    quirks: list[str]  # protocol quirks the recordings show
    evidence: str  # which recordings, and what they show


MEASURED: dict[tuple[str, int, int], Measured] = {
    ("usb", 0x056A, 0x0057): {
        "quirks": ["no-tilt"],
        "evidence": "DTK-2241 recordings (issue 24): the pen's tilt bytes are 0 in every "
                    "report, so the kernel reports tilt -64,-64 (its minimum) throughout; "
                    "the DTK-2241 pen has no tilt sensor",
    },
}
# Types with no pen: touch-only halves of pen displays, pads, receivers, remotes.
NOT_PEN_TYPES = {"BAMBOO_TOUCH", "BAMBOO_PAD", "WIRELESS", "REMOTE", "WACOM_24HDT",
                 "WACOM_27QHDT", "BOOTLOADER"}  # fmt: skip
# Display tablets (the kernel sets INPUT_PROP_DIRECT for these types).
DISPLAY_TYPES = {"PL", "DTU", "DTUS", "DTUSX", "PTU", "CINTIQ", "WACOM_BEE", "WACOM_21UX2",
                 "WACOM_22HD", "DTK", "WACOM_24HD", "WACOM_27QHD", "CINTIQ_HYBRID",
                 "CINTIQ_COMPANION_2", "WACOM_13HD", "TABLETPC", "TABLETPCE", "TABLETPC2FG",
                 "MTSCREEN", "MTTPC", "MTTPC_B"}  # fmt: skip
# Mode switches, as _wacom_query_tablet_data() / wacom_bt_query_tablet_data() do them:
# USB pen interfaces of every type up to BAMBOO_PT get feature report 2 = 2;
# the Bluetooth Graphire gets 03 00 then 06 00 (high speed), the Intuos4 WL 03 00.
ENUM_ORDER: list[str] = []  # filled from wacom_wac.h
BT_INIT = {"GRAPHIRE_BT": ["0300", "0600"], "INTUOS4WL": ["0300"]}
PAD_REPORT_IDS = {_INTUOS3: [3, 12, 17], "wacom-intuos1": [3, 12, 17],
                  "wacom-intuos4wl": [], "wacom-dtus": [21]}  # fmt: skip


# -- the files ------------------------------------------------------------------------------------
def slug(text: str) -> str:
    s = re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")
    return re.sub(r"-+", "-", s)[:48].strip("-")


VENDOR_PREFIX = {0x056A: "wacom", 0x256C: "huion", 0x28BD: "ugee", 0x5543: "uclogic",
                 0x17EF: "lenovo", 0x04F3: "elan"}  # fmt: skip


def file_id(vid: int, pid: int, bus: str, name: str) -> str:
    prefix = VENDOR_PREFIX.get(vid, f"v{vid:04x}")
    tail = slug(name.removeprefix("Wacom ").removeprefix("wacom "))
    busp = {"usb": "", "bluetooth": "bt-", "i2c": "i2c-"}[bus]
    return f"{prefix}-{busp}{pid:04x}-{tail}" if tail else f"{prefix}-{busp}{pid:04x}"


def _number(v: CValue) -> int:
    """A feature that must be a number (an unresolved name there is a source we misread)."""
    if isinstance(v, str):
        raise ValueError(f"expected a number in wacom_features, got {v!r}")
    return v


def kernel_model(e: KernelEntry, src: Source, tablets: dict[tuple[str, int, int], Tablet],
                 styli: Styli, groups: StylusGroups, lw_src: Source) -> dict[str, Any] | None:
    f = e.features
    ktype = str(f.get("type"))
    if ktype == "HID_GENERIC" and not f.get("x_max"):
        return generic_kernel_model(e, src, tablets, styli, groups, lw_src)
    if ktype in NOT_PEN_TYPES or not isinstance(f.get("x_max"), int) or not f.get("pressure_max"):
        return None
    parser, family, quirks = TYPE_PROTOCOL[ktype]
    measured = MEASURED.get((e.bus, e.vid, e.pid))
    if measured:
        quirks = [*quirks, *(q for q in measured["quirks"] if q not in quirks)]
    tab = tablets.get((e.bus, e.vid, e.pid))
    name = tab.name if tab else str(f["name"])
    if tab and tab.model_name:
        name = f"{name} ({tab.model_name})"
    xres, yres = _number(f.get("x_resolution") or 0), _number(f.get("y_resolution") or 0)
    model: dict[str, Any] = {
        "id": file_id(e.vid, e.pid, e.bus, str(f["name"])),
        "name": name,
        "vendor_id": f"{e.vid:04x}",
        "product_id": f"{e.pid:04x}",
        "bus": e.bus,
        "parser": parser,
        "family": family,
        "kernel_type": ktype,
        "kernel_name": f["name"],
        "max_x": f["x_max"],
        "max_y": f["y_max"],
        "max_pressure": f["pressure_max"],
        "max_distance": int(f.get("distance_max") or 0),
    }
    if xres and yres:
        model["resolution"] = {"x": xres, "y": yres}
        model["drawing_area_mm"] = [round(_number(f["x_max"]) / xres, 2),
                                    round(_number(f["y_max"]) / yres, 2)]
    init: list[str] = []
    rank = ENUM_ORDER.index(ktype)
    if e.bus == "usb" and rank <= ENUM_ORDER.index("BAMBOO_PT"):
        init = ["0202"]
    elif e.bus == "bluetooth":
        init = list(BT_INIT.get(ktype, []))
    model["init_feature_reports"] = init
    model["ignore_interfaces"] = []
    if PAD_REPORT_IDS.get(parser):
        model["pad_report_ids"] = PAD_REPORT_IDS[parser]
    integrated = tab.integrated if tab else (["Display"] if ktype in DISPLAY_TYPES else [])
    if ktype.startswith(("TABLETPC", "MTSCREEN", "MTTPC")) and not tab:
        integrated = ["Display", "System"]
    model["screen_tablet"] = "Display" in integrated
    model["integrated_in"] = [i.lower() for i in integrated]
    model["tilt"] = (parser in (_INTUOS3, "wacom-intuos1", "wacom-intuos4wl")
                     and "no-tilt" not in quirks) or "pro2-frames" in quirks
    if quirks:
        model["protocol_quirks"] = quirks
    offsets = [f.get(k) or 0 for k in ("offset_left", "offset_right", "offset_top",
                                        "offset_bottom")]  # fmt: skip
    if any(offsets):
        model["offsets"] = dict(zip(["left", "right", "top", "bottom"], offsets, strict=True))
    if f.get("touch_max"):
        model["touch_max"] = f["touch_max"]
    if f.get("numbered_buttons"):
        model["pad_buttons"] = f["numbered_buttons"]
    if tab is not None:
        _libwacom_facts(model, tab, styli, groups)
    if not model["tilt"]:  # libwacom's styli are generic: a pen here sends no tilt
        for stylus in model.get("styli", []):
            if "tilt" in stylus.get("axes", []):
                stylus["axes"] = [a for a in stylus["axes"] if a != "tilt"]
    prov = [src.ref(f"wacom_features_{e.macro_arg}")]
    if tab is not None:
        prov.append(lw_src.ref(tab.file))
    model["provenance"] = {"generator": GENERATOR, "sources": prov}
    if measured:
        model["provenance"]["measured"] = measured["evidence"]
    return model


def generic_kernel_model(e: KernelEntry, src: Source, tablets: dict[tuple[str, int, int], Tablet],
                         styli: Styli, groups: StylusGroups, lw_src: Source,
                         ) -> dict[str, Any] | None:
    """A kernel entry of type HID_GENERIC without numbers: the descriptor says everything."""
    tab = tablets.get((e.bus, e.vid, e.pid))
    if tab is not None and not tab.stylus:
        return None
    name = str(e.features["name"])
    model: dict[str, Any] = {
        "id": file_id(e.vid, e.pid, e.bus, name), "name": tab.name if tab else name,
        "vendor_id": f"{e.vid:04x}", "product_id": f"{e.pid:04x}", "bus": e.bus,
        "parser": "hid-generic", "family": "Wacom generic HID", "kernel_type": "HID_GENERIC",
        "kernel_name": name, "init_feature_reports": [], "ignore_interfaces": [],
        "screen_tablet": bool(tab and "Display" in tab.integrated),
        "integrated_in": [i.lower() for i in tab.integrated] if tab else [],
    }
    if tab is not None:
        _libwacom_facts(model, tab, styli, groups)
    prov = [src.ref(f"wacom_features_{e.macro_arg}")] + ([lw_src.ref(tab.file)] if tab else [])
    model["provenance"] = {"generator": GENERATOR, "sources": prov}
    return model


def _libwacom_facts(model: dict[str, Any], tab: Tablet, styli: Styli, groups: StylusGroups) -> None:
    if tab.width_mm and tab.height_mm:
        model["physical_size_mm"] = [tab.width_mm, tab.height_mm]
    resolved = resolve_styli(tab.styli, styli, groups)
    if resolved:
        model["styli"] = resolved
    names = sorted({m[3] for m in tab.matches if m[3]})
    if names:
        model["hid_names"] = names
    if tab.tablet_class:
        model["libwacom_class"] = tab.tablet_class


VENDOR_NAMES = {0x056A: "Wacom", 0x256C: "Huion/Gaomon", 0x28BD: "XP-Pen/UGEE",
                0x5543: "UC-Logic", 0x04F3: "ELAN"}  # fmt: skip


def libwacom_model(tabs: list[Tablet], key: tuple[str, int, int], uclogic: set[tuple[int, int]],
                   styli: Styli, groups: StylusGroups, lw_src: Source, uc_src: Source,
                   uc_kinds: dict[tuple[int, int], str]) -> dict[str, Any]:
    bus, vid, pid = key
    uc = bus == "usb" and (vid, pid) in uclogic
    parser = "uclogic" if uc else "hid-generic"
    tab = tabs[0]
    uc_kind = uc_kinds.get((vid, pid), "fixed-descriptor") if uc else None
    shared = len({t.name for t in tabs}) > 1
    if shared:
        # One USB id, many products (UC-Logic firmware reuses ids): the model is told
        # apart by its name string and, after the UC-Logic init, by its parameters.
        vendor = VENDOR_NAMES.get(vid, f"vendor {vid:04x}")
        name = f"{vendor} tablets sharing {vid:04x}:{pid:04x} ({len(tabs)} models)"
    else:
        name = tab.name + (f" ({tab.model_name})" if tab.model_name else "")
    model: dict[str, Any] = {
        "id": file_id(vid, pid, bus, "shared" if shared else tab.name),
        "name": name,
        "vendor_id": f"{vid:04x}",
        "product_id": f"{pid:04x}",
        "bus": bus,
        "parser": parser,
        "family": "UC-Logic" if uc else ("Wacom generic HID" if vid == WACOM else "generic HID"),
        "init_feature_reports": [],
        "ignore_interfaces": [],
        "screen_tablet": all("Display" in t.integrated for t in tabs),
        "integrated_in": [i.lower() for i in tab.integrated] if not shared else [],
    }
    if uc_kind is not None:
        model["uclogic"] = {"init": uc_kind}
        if uc_kind != "fixed-descriptor":
            # A kernel without hid-uclogic support for this id binds hid-generic: hidraw then
            # shows the compatibility reports and the set-up needs the raw USB interface.
            model["udev_unbind_from"] = "hid-generic"
    if shared:
        model["models"] = sorted({t.name for t in tabs})
    else:
        _libwacom_facts(model, tab, styli, groups)
    prov = [lw_src.ref(t.file) for t in tabs]
    if uc:
        prov.append(uc_src.ref("uclogic_devices"))
        prov.append(Source(uc_src.repo, uc_src.commit, "hid-uclogic-params.c").ref(
            "uclogic_params_init"))
    model["provenance"] = {"generator": GENERATOR, "sources": prov}
    return model


def build(cache: Path, curated: set[tuple[str, int, int]]) -> list[dict[str, Any]]:
    def commit(sub: str) -> str:
        return (cache / sub / "COMMIT").read_text().strip()

    wac_c = (cache / "input-wacom/4.18/wacom_wac.c").read_text(encoding="utf-8")
    wac_h = (cache / "input-wacom/4.18/wacom_wac.h").read_text(encoding="utf-8")
    ENUM_ORDER[:] = enum_order(wac_h)
    defines = c_defines(wac_c) | c_defines(wac_h)
    text = strip_c_comments(wac_c)
    features = parse_features(text, defines)
    entries = parse_id_table(text, features)
    src = Source("linuxwacom/input-wacom", commit("input-wacom"), "4.18/wacom_wac.c")
    lw_src = Source("linuxwacom/libwacom", commit("libwacom"), "data/")
    uc_src = Source("DIGImend/digimend-kernel-drivers", commit("digimend"), "hid-uclogic-core.c")
    data = cache / "libwacom" / "data"
    styli, groups = parse_styli(sorted(data.glob("*.stylus")))
    tablets_all = [t for p in sorted(data.glob("*.tablet")) if (t := parse_tablet(p))]
    by_key: dict[tuple[str, int, int], list[Tablet]] = {}
    for t in tablets_all:
        for bus, vid, pid, _ in t.matches:
            by_key.setdefault((bus, vid, pid), [])
            if t not in by_key[(bus, vid, pid)]:
                by_key[(bus, vid, pid)].append(t)
    # A kernel id gets the facts of the libwacom tablet that has a stylus (several files
    # may share an id: pen + touch halves, or firmware variants told apart by name).
    first = {k: next((t for t in v if t.stylus), v[0]) for k, v in by_key.items()}
    uc = uclogic_ids((cache / "digimend/hid-uclogic-core.c").read_text(encoding="utf-8"),
                     (cache / "digimend/hid-ids.h").read_text(encoding="utf-8"))  # fmt: skip
    uc_kinds = uclogic_init_kinds(
        (cache / "digimend/hid-uclogic-params.c").read_text(encoding="utf-8"),
        (cache / "digimend/hid-ids.h").read_text(encoding="utf-8"))
    models: dict[tuple[str, int, int], dict[str, Any]] = {}
    for e in entries:
        key = (e.bus, e.vid, e.pid)
        if key in curated or key in models:
            continue
        m = kernel_model(e, src, first, styli, groups, lw_src)
        if m is not None:
            models[key] = m
    for key, tabs in sorted(by_key.items()):
        if key in curated or key in models:
            continue
        pens = [t for t in tabs if t.stylus]
        if not pens:
            continue
        models[key] = libwacom_model(pens, key, uc, styli, groups, lw_src, uc_src, uc_kinds)
    ids: dict[str, int] = {}
    out = []
    for key in sorted(models, key=lambda k: (k[1], k[2], k[0])):
        m = models[key]
        n = ids.get(m["id"], 0)
        ids[m["id"]] = n + 1
        if n:
            m["id"] = f"{m['id']}-{n + 1}"
        out.append(m)
    return out


def kernel_entries(cache: Path) -> dict[tuple[str, int, int], KernelEntry]:
    """The kernel table's entries by (bus, vid, pid)."""
    wac_c = (cache / "input-wacom/4.18/wacom_wac.c").read_text(encoding="utf-8")
    wac_h = (cache / "input-wacom/4.18/wacom_wac.h").read_text(encoding="utf-8")
    text = strip_c_comments(wac_c)
    features = parse_features(text, c_defines(wac_c) | c_defines(wac_h))
    return {(e.bus, e.vid, e.pid): e for e in parse_id_table(text, features)}


def curated_disagreements(cache: Path, out_dir: Path) -> list[str]:
    """Curated files whose numbers differ from the kernel's table (a check of the hand work)."""
    entries = kernel_entries(cache)
    out = []
    for p in sorted(out_dir.glob("*.json")):
        if p.name.endswith(".schema.json"):
            continue
        m = json.loads(p.read_text(encoding="utf-8"))
        if "provenance" in m or "max_x" not in m:
            continue
        e = entries.get((m["bus"], int(m["vendor_id"], 16), int(m["product_id"], 16)))
        if e is None:
            continue
        k = e.features
        pairs = [("max_x", "x_max"), ("max_y", "y_max"), ("max_pressure", "pressure_max"),
                 ("max_distance", "distance_max")]
        for ours, theirs in pairs:
            if m.get(ours) != k.get(theirs):
                out.append(f"{p.name}: {ours} {m.get(ours)}, kernel {theirs} {k.get(theirs)}")
        if m["resolution"]["x"] != k.get("x_resolution"):
            res = m["resolution"]["x"]
            out.append(f"{p.name}: resolution {res}, kernel {k.get('x_resolution')}")
    return out


def curated_files(out_dir: Path) -> tuple[set[tuple[str, int, int]], list[Path]]:
    curated, generated = set(), []
    for p in sorted(out_dir.glob("*.json")):
        if p.name.endswith(".schema.json"):
            continue
        try:
            m = json.loads(p.read_text(encoding="utf-8"))
        except json.JSONDecodeError:
            m = {}
        if "provenance" in m:
            generated.append(p)
        elif not {"bus", "vendor_id", "product_id"} <= set(m):
            continue  # broken: rewritten when it has a generated file's name, else left alone
        else:
            curated.add((m["bus"], int(m["vendor_id"], 16), int(m["product_id"], 16)))
    return curated, generated


def render(model: dict[str, Any]) -> str:
    """One key a line; lists of objects (styli, sources) one item a line: diffs stay readable."""
    lines = []
    for key, value in model.items():
        k = json.dumps(key)
        if key == "provenance":
            items = ",\n".join(f"      {json.dumps(src, ensure_ascii=False)}"
                                for src in value["sources"])
            text = (f'{{\n    "generator": {json.dumps(value["generator"])},\n'
                    f'    "sources": [\n{items}\n    ]\n  }}')
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            items = ",\n".join(f"    {json.dumps(v, ensure_ascii=False)}" for v in value)
            text = f"[\n{items}\n  ]"
        else:
            text = json.dumps(value, ensure_ascii=False)
        lines.append(f"  {k}: {text}")
    return "{\n" + ",\n".join(lines) + "\n}\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", type=Path, required=True, help="folder with the source texts")
    ap.add_argument("--out", type=Path, default=OUT_DIR)
    ap.add_argument("--check", action="store_true", help="exit 1 if the files are not current")
    args = ap.parse_args(argv)
    curated, old = curated_files(args.out)
    models = build(args.cache, curated)
    want = {args.out / f"{m['id']}.json": render(m) for m in models}
    stale = [p for p in old if p not in want]
    changed = [p for p, t in want.items() if not p.exists() or p.read_text(encoding="utf-8") != t]
    for line in curated_disagreements(args.cache, args.out):
        print(f"note: curated {line}", file=sys.stderr)
    if args.check:
        for p in stale + changed:
            print(f"{p}: not current", file=sys.stderr)
        return 1 if stale or changed else 0
    for p in stale:
        p.unlink()
    for p in changed:
        p.write_text(want[p], encoding="utf-8")
    families: dict[str, int] = {}
    for m in models:
        families[m["parser"]] = families.get(m["parser"], 0) + 1
    print(f"{len(models)} generated models ({len(changed)} written, {len(stale)} removed; "
          f"{len(curated)} curated ids skipped): "
          + ", ".join(f"{k} {v}" for k, v in sorted(families.items())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
