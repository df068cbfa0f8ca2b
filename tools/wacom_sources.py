"""Reading the source texts ``tools/gen_wacom_devices.py`` generates device files from:
the kernel's Wacom driver (C: its defines, ``wacom_features`` initialisers and id table),
libwacom's ``.tablet`` and ``.stylus`` keyfiles, and the uclogic driver's id table and
init calls.  Facts only (numbers, names, ids); nothing here writes a file.

A sibling of the generator, not an installed module: the generator puts ``tools/`` on
``sys.path`` to import it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

WACOM = 0x056A
VENDOR_MACROS = {"USB_VENDOR_ID_WACOM": WACOM, "USB_VENDOR_ID_LENOVO": 0x17EF}
BUS_MACROS = {"USB_DEVICE_WACOM": "usb", "BT_DEVICE_WACOM": "bluetooth",
              "I2C_DEVICE_WACOM": "i2c", "USB_DEVICE_LENOVO": "usb"}  # fmt: skip
VENDOR_OF_MACRO = {"USB_DEVICE_LENOVO": 0x17EF}

# The positional members of struct wacom_features (wacom_wac.h), in order.
FEATURE_FIELDS = ["name", "x_max", "y_max", "pressure_max", "distance_max", "type",
                  "x_resolution", "y_resolution", "numbered_buttons", "offset_left",
                  "offset_right", "offset_top", "offset_bottom", "device_type", "x_phy",
                  "y_phy", "unit", "unitExpo", "x_fuzz", "y_fuzz", "pressure_fuzz",
                  "distance_fuzz", "tilt_fuzz", "quirks", "touch_max", "oVid", "oPid",
                  "pktlen", "check_for_hid_type", "hid_type"]  # fmt: skip


CValue = int | str
"""A value in a C initialiser: a number, a string, or an enum or flag name kept as text
(``true``/``false`` read as bools, which are ints)."""
Features = dict[str, CValue]
"""One ``struct wacom_features`` initialiser: member name -> value."""
Styli = dict[str, dict[str, str]]
"""libwacom's .stylus sections by ``vvvv:sssss`` (vendor id, stylus id): key -> value."""
StylusGroups = dict[str, list[str]]
"""libwacom's stylus groups: name -> stylus keys."""


@dataclass
class Source:
    repo: str
    commit: str
    path: str

    def ref(self, entry: str | None = None) -> dict[str, str]:
        out = {"repo": self.repo, "commit": self.commit, "path": self.path}
        if entry:
            out["entry"] = entry
        return out


@dataclass
class KernelEntry:
    pid: int
    vid: int
    bus: str
    macro_arg: str
    features: Features


@dataclass
class Tablet:
    file: str
    name: str
    model_name: str
    matches: list[tuple[str, int, int, str]]
    width_mm: float | None
    height_mm: float | None
    integrated: list[str]
    styli: list[str]
    stylus: bool
    touch: bool
    tablet_class: str
    extra: dict[str, Any] = field(default_factory=dict)


# -- C text -------------------------------------------------------------------------------------
def strip_c_comments(text: str) -> str:
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    return re.sub(r"//[^\n]*", " ", text)


def c_defines(text: str) -> dict[str, str]:
    out = {}
    for m in re.finditer(r"^#define[ \t]+(\w+)[ \t]+([^\n]+)$", text, flags=re.M):
        out[m.group(1)] = m.group(2).strip()
    return out


def c_value(token: str, defines: dict[str, str]) -> CValue:
    token = token.strip()
    if token.startswith('"'):
        return token.strip('"')
    if token in ("true", "false"):
        return token == "true"
    if token in VENDOR_MACROS:
        return VENDOR_MACROS[token]
    if token == "HID_ANY_ID":
        return -1
    if re.fullmatch(r"0[xX][0-9a-fA-F]+|\d+", token):
        return int(token, 0)
    if token in defines and defines[token] != token:
        return c_value(defines[token], defines)
    if re.fullmatch(r"[A-Z0-9_]+(\s*\|\s*[A-Z0-9_]+)*", token):
        return token  # an enum or flag name: kept as text
    raise ValueError(f"cannot read C value {token!r}")


def split_initializer(body: str) -> list[str]:
    items: list[str] = []
    cur: list[str] = []
    depth = 0
    for ch in body:
        if ch in "({":
            depth += 1
        elif ch in ")}":
            depth -= 1
        if ch == "," and depth == 0:
            items.append("".join(cur).strip())
            cur = []
        else:
            cur.append(ch)
    if "".join(cur).strip():
        items.append("".join(cur).strip())
    return items


def parse_features(text: str, defines: dict[str, str]) -> dict[str, Features]:
    """``wacom_features_<suffix>`` initialisers -> {suffix: {member: value}} (C rules)."""
    out = {}
    pat = r"static const struct wacom_features wacom_features_(\w+)\s*=\s*\{(.*?)\};"
    for m in re.finditer(pat, text, flags=re.S):
        feats: Features = {}
        pos = 0
        for item in split_initializer(m.group(2)):
            d = re.fullmatch(r"\.(\w+)\s*=\s*(.+)", item, flags=re.S)
            if d:
                name, value = d.group(1), d.group(2)
                pos = FEATURE_FIELDS.index(name) + 1
            else:
                name, value = FEATURE_FIELDS[pos], item
                pos += 1
            feats[name] = c_value(" ".join(value.split()), defines)
        out[m.group(1)] = feats
    return out


def parse_id_table(text: str, features: dict[str, Features]) -> list[KernelEntry]:
    start = text.index("wacom_ids[] = {")
    table = text[start:text.index("};", start)]
    out = []
    for m in re.finditer(r"\{\s*(\w+_DEVICE_\w+)\((\w+)\)\s*\}", table):
        macro, arg = m.group(1), m.group(2)
        if arg == "HID_ANY_ID" or macro not in BUS_MACROS:
            continue
        out.append(KernelEntry(pid=int(arg, 16), vid=VENDOR_OF_MACRO.get(macro, WACOM),
                               bus=BUS_MACROS[macro], macro_arg=arg,
                               features=features[arg]))  # fmt: skip
    return out


def enum_order(header: str) -> list[str]:
    body = header[header.index("PENPARTNER = 0"):]
    body = body[:body.index("}")]
    return [w.split("=")[0].strip() for w in strip_c_comments(body).split(",") if w.strip()]


# -- libwacom ------------------------------------------------------------------------------------
def read_keyfile(path: Path) -> dict[str, dict[str, str]]:
    sections: dict[str, dict[str, str]] = {}
    cur: dict[str, str] | None = None
    for raw in path.read_text(encoding="utf-8").splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if line.startswith("[") and line.endswith("]"):
            cur = sections.setdefault(line[1:-1], {})
        elif "=" in line and cur is not None:
            k, v = line.split("=", 1)
            cur[k.strip()] = v.split("#", 1)[0].strip()  # values may carry a comment
    return sections


def _parts(value: str) -> list[str]:
    return [p for p in (s.strip() for s in value.split(";")) if p]


def parse_tablet(path: Path) -> Tablet | None:
    s = read_keyfile(path)
    dev, feats = s.get("Device", {}), s.get("Features", {})
    matches = []
    for m in _parts(dev.get("DeviceMatch", "")):
        bits = m.split("|")
        if len(bits) < 3 or bits[0] not in ("usb", "bluetooth", "i2c"):
            continue
        matches.append((bits[0], int(bits[1], 16), int(bits[2], 16),
                        bits[3] if len(bits) > 3 else ""))  # fmt: skip
    styli = _parts(dev.get("Styli", ""))
    stylus = feats.get("Stylus", "true" if styli else "false").lower() == "true"

    def mm(key: str) -> float | None:
        v = dev.get(key)
        return float(v) if v and float(v) > 0 else None

    return Tablet(file=path.name, name=dev.get("Name", path.stem),
                  model_name=dev.get("ModelName", ""),
                  matches=matches, width_mm=mm("Width"), height_mm=mm("Height"),
                  integrated=_parts(dev.get("IntegratedIn", "")), styli=styli, stylus=stylus,
                  touch=feats.get("Touch", "false").lower() == "true",
                  tablet_class=dev.get("Class", ""))  # fmt: skip


def stylus_key(bits: list[str]) -> tuple[int, int]:
    """``[vid, id]`` or ``[id]`` (a Wacom stylus) of a ``0x56a:0x802`` style reference."""
    if len(bits) == 2:
        return int(bits[0], 16), int(bits[1], 16)
    return WACOM, int(bits[0], 16)


def parse_styli(paths: list[Path]) -> tuple[Styli, StylusGroups]:
    """All styli by ``vvvv:iiiii`` key, and the keys of each group in file order."""
    styli: dict[str, dict[str, str]] = {}
    groups: dict[str, list[str]] = {}
    for path in paths:
        for sec, kv in read_keyfile(path).items():
            bits = sec.split(":")
            vid, sid = stylus_key(bits)
            key = f"{vid:04x}:{sid:05x}"
            styli[key] = kv
            if "Group" in kv:
                groups.setdefault(kv["Group"], []).append(key)
    return styli, groups


def resolve_styli(refs: list[str], styli: Styli, groups: StylusGroups) -> list[dict[str, Any]]:
    keys: list[str] = []
    for ref in refs:
        if ref.startswith("@"):
            keys.extend(groups.get(ref[1:], []))
        else:
            bits = ref.split(":")
            vendor, stylus = stylus_key(bits)
            keys.append(f"{vendor:04x}:{stylus:05x}")
    out = []
    for key in dict.fromkeys(keys):
        kv = styli.get(key)
        if kv is None:
            continue
        vid, sid = key.split(":")
        if "AliasOf" in kv:  # same tool under another id: the alias's facts
            kv = {**styli.get(f"{vid}:{int(kv['AliasOf'], 16):05x}", {}), **kv}
        entry: dict[str, Any] = {"vendor_id": vid, "tool_id": f"0x{int(sid, 16):x}",
                                 "name": kv.get("Name", "")}
        if kv.get("Type"):
            entry["type"] = kv["Type"].lower()
        if kv.get("EraserType"):
            entry["eraser"] = kv["EraserType"].lower()
        if kv.get("Buttons"):
            entry["buttons"] = int(kv["Buttons"])
        axes = _parts(kv.get("Axes", ""))
        if axes:
            entry["axes"] = [a.lower() for a in axes]
        out.append(entry)
    return out


# -- uclogic ---------------------------------------------------------------------------------
def uclogic_ids(core: str, ids_h: str) -> set[tuple[int, int]]:
    defines = c_defines(ids_h)
    start = core.index("uclogic_devices[] = {")
    table = core[start:core.index("};", start)]
    out = set()
    for m in re.finditer(r"HID_USB_DEVICE\(\s*(\w+)\s*,\s*(\w+)\s*\)", table):
        out.add((int(defines[m.group(1)], 16), int(defines[m.group(2)], 16)))
    return out


UCLOGIC_INIT_CALLS = (("uclogic_params_huion_init", "huion"),
                      ("uclogic_params_ugee_v2_init", "ugee-v2"),
                      ("uclogic_params_pen_init_v1", "v1"), ("WITH_OPT_DESC", "fixed-descriptor"))


def uclogic_init_kinds(params_c: str, ids_h: str) -> dict[tuple[int, int], str]:
    """(vid, pid) -> how uclogic_params_init() sets the tablet up (first call after its cases)."""
    defines = c_defines(ids_h)
    start = params_c.index("switch (VID_PID(hdev->vendor, hdev->product))")
    body = strip_c_comments(params_c[start:])
    out: dict[tuple[int, int], str] = {}
    pending: list[tuple[int, int]] = []
    for m in re.finditer(r"case VID_PID\(\s*(\w+)\s*,\s*(\w+)\s*\)\s*:|(\w+)\s*\(", body):
        if m.group(1):
            pending.append((int(defines[m.group(1)], 16), int(defines[m.group(2)], 16)))
            continue
        kind = dict(UCLOGIC_INIT_CALLS).get(m.group(3))
        if kind and pending:
            for key in pending:
                out[key] = kind
            pending = []
        if m.group(3) == "default" or body[m.start():m.start() + 8] == "default:":
            break
    return out
