"""libinput record YAML traces.

``devices: [{evdev: {name, id: [bus, vid, pid, version], codes: {type: [code…]},
absinfo: {code: [min, max, fuzz, flat, resolution]}}, hid: [bytes…],
events: [{evdev: [[sec, usec, type, code, value], …]}, …]}]``; unknown keys
(``libinput``, ``udev``, ``quirks`` …) are ignored.  YAML errors carry the
line; structural errors name the device and event index.
"""

from __future__ import annotations

import os
import re

import yaml
from station.drivers.evdev import codes as c
from station.drivers.evdev.frames import AbsInfo, EvdevCaps, InputEvent
from station.drivers.traces.model import Trace, TraceDevice, TraceError
from yaml.composer import ComposerError

from station import boundedio


def _int(value: object, where: str, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise TraceError(f"{what} {value!r} is not an integer", where)
    return value


class _Loader(yaml.SafeLoader):
    """Safe YAML without aliases: libinput record never writes them, and aliases let a
    small file expand into an enormous document ("billion laughs")."""

    def compose_node(self, parent: yaml.Node | None, index: int) -> yaml.Node | None:
        if self.check_event(yaml.AliasEvent):
            raise ComposerError(None, None, "aliases (*name) are not used by libinput record",
                                self.peek_event().start_mark)
        return super().compose_node(parent, index)


MAX_SECONDS = 1e9  # event times beyond this (31 years) are not a recording


MAX_NESTING = 64  # libinput record nests 4-5 levels; pure-Python YAML slows per level
_BRACKETS = re.compile(r"[\[\]{}]")
_DEEP_BLOCK = re.compile(rf"(?:-[ \t]+){{{MAX_NESTING},}}")


def _too_deep(text: str) -> bool:
    """Flow (``[[[…``) or block (``- - - …``) nesting past :data:`MAX_NESTING`: refused
    before the parser, which takes seconds per 50,000 levels on a loaded machine."""
    depth = 0
    for m in _BRACKETS.finditer(text):
        depth += 1 if m.group() in "[{" else -1
        if depth > MAX_NESTING:
            return True
        depth = max(depth, 0)
    return _DEEP_BLOCK.search(text) is not None


def parse_libinput_record(text: str, name: str) -> Trace:
    if _too_deep(text):
        raise TraceError(f"not valid YAML (nested more than {MAX_NESTING} levels)", f"{name}:1")
    try:
        doc = yaml.load(text, Loader=_Loader)  # a SafeLoader without aliases
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = (mark.line + 1) if mark is not None else 1
        raise TraceError(f"not valid YAML ({getattr(exc, 'problem', exc)})",
                         f"{name}:{line}") from None
    except RecursionError:  # the composer recurses per nesting level
        raise TraceError("not valid YAML (nested too deeply)", f"{name}:1") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("devices"), list):
        raise TraceError("not a libinput recording (no 'devices' list)", f"{name}:1")
    devices: list[TraceDevice] = []
    for index, entry in enumerate(doc["devices"]):
        where = f"{name}: devices[{index}]"
        if not isinstance(entry, dict) or not isinstance(entry.get("evdev"), dict):
            raise TraceError("device without an 'evdev' section", where)
        ev = entry["evdev"]
        ids = ev.get("id", [0, 0, 0, 0])
        if not isinstance(ids, list) or len(ids) < 3:
            raise TraceError(f"evdev id {ids!r} needs [bus, vid, pid, version]", where)
        ids = [_int(v, where, "id") for v in ids] + [0]
        codes = ev.get("codes", {}) or {}
        if not isinstance(codes, dict):
            raise TraceError("evdev codes must be a mapping type: [codes]", where)
        keys = {_int(k, where, "key code") for k in codes.get(c.EV_KEY, []) or []}
        msc = {_int(k, where, "msc code") for k in codes.get(c.EV_MSC, []) or []}
        absinfo: dict[int, AbsInfo] = {}
        for code, values in (ev.get("absinfo", {}) or {}).items():
            if not isinstance(values, list) or len(values) < 4:
                raise TraceError(f"absinfo {code}: {values!r} needs min max fuzz flat [res]",
                                 where)
            vals = [_int(v, where, f"absinfo {code}") for v in values]
            if any(not -(1 << 31) <= v < 1 << 31 for v in vals):  # struct input_absinfo: s32
                raise TraceError(f"absinfo {code}: {values!r:.80} does not fit 32 bits", where)
            if vals[1] < vals[0]:
                raise TraceError(f"absinfo {code}: max {vals[1]} < min {vals[0]}", where)
            res = vals[4] if len(vals) > 4 else 0
            rest = min(max(0, vals[0]), vals[1])  # value at rest: not recorded
            absinfo[_int(code, where, "abs code")] = AbsInfo(vals[0], vals[1], vals[2], vals[3],
                                                             res, rest)
        descriptor = None
        hid = entry.get("hid")
        if isinstance(hid, list) and hid:
            try:
                descriptor = bytes(_int(b, where, "hid byte") for b in hid)
            except ValueError:
                raise TraceError("hid descriptor bytes must be 0..255", where) from None
        events: list[InputEvent] = []
        last_t = None
        for n, frame in enumerate(entry.get("events", []) or []):
            if not isinstance(frame, dict):
                raise TraceError(f"events[{n}] is not a mapping", where)
            for m, item in enumerate(frame.get("evdev", []) or []):
                ew = f"{where} events[{n}].evdev[{m}]"
                if not isinstance(item, list) or len(item) != 5:
                    raise TraceError(f"{item!r} is not [sec, usec, type, code, value]", ew)
                sec, usec, etype, code, value = (_int(v, ew, "event field") for v in item)
                if not (0 <= sec < MAX_SECONDS and 0 <= usec < 1_000_000 and 0 <= etype <= 0x1F
                        and 0 <= code <= 0x2FF and -(1 << 31) <= value < 1 << 31):
                    raise TraceError(f"{item!r:.80} out of range", ew)
                t = sec + usec / 1e6
                if not t >= 0:
                    raise TraceError(f"{item!r} out of range", ew)
                if last_t is not None and t + 1e-6 < last_t:
                    raise TraceError(f"time {t} goes back (previous {last_t})", ew)
                last_t = t
                if etype == c.EV_KEY:
                    keys.add(code)
                events.append(InputEvent(t, etype, code, value))
        dev_name = str(ev.get("name", ""))
        caps = EvdevCaps(name=dev_name, absinfo=absinfo, keys=frozenset(keys), bus=ids[0],
                         vid=ids[1], pid=ids[2], version=ids[3], msc=frozenset(msc),
                         path=str(entry.get("node", "")))
        devices.append(TraceDevice(index=index, name=dev_name, vid=ids[1], pid=ids[2],
                                   bus=ids[0], descriptor=descriptor, caps=caps, events=events,
                                   where=where))
    if not devices:
        raise TraceError("libinput recording with no devices", f"{name}:1")
    return Trace(path=name, format="libinput-record", devices=devices)


def read_libinput_record(path: str | os.PathLike[str]) -> Trace:
    name = str(path)
    try:
        boundedio.check_regular(path, str(path))
        with open(path, encoding="utf-8-sig") as fh:  # a BOM from Windows editors is dropped
            text = fh.read()
    except UnicodeDecodeError:
        raise TraceError("not a text file", f"{name}:1") from None
    except OSError as exc:
        raise TraceError(f"cannot open ({exc.strerror})", name) from None
    return parse_libinput_record(text, name)


def format_libinput_record(devices: list[tuple[EvdevCaps, list[InputEvent]]]) -> str:
    """A libinput-record YAML document for (caps, events) pairs (one frame per SYN_REPORT)."""
    described: list[dict[str, object]] = []
    doc: dict[str, object] = {"version": 1, "ndevices": len(devices),
                              "libinput": {"version": "station"}, "devices": described}
    for caps, events in devices:
        frames: list[dict[str, object]] = []
        frame: list[list[int]] = []
        for ev in events:
            sec = int(ev.time)
            frame.append([sec, round((ev.time - sec) * 1e6), ev.type, ev.code, ev.value])
            if ev.type == c.EV_SYN and ev.code == c.SYN_REPORT:
                frames.append({"evdev": frame})
                frame = []
        codes = {c.EV_SYN: [0], c.EV_KEY: sorted(caps.keys), c.EV_ABS: sorted(caps.absinfo)}
        if caps.msc:
            codes[c.EV_MSC] = sorted(caps.msc)
        described.append({
            "node": caps.path or "/dev/input/event0",
            "evdev": {
                "name": caps.name, "id": [caps.bus, caps.vid, caps.pid, caps.version],
                "codes": codes,
                "absinfo": {k: [a.minimum, a.maximum, a.fuzz, a.flat, a.resolution]
                            for k, a in sorted(caps.absinfo.items())},
                "properties": [1],
            },
            "udev": {"properties": ["ID_INPUT=1"]},
            "events": frames,
        })
    return yaml.safe_dump(doc, sort_keys=False, default_flow_style=None)
