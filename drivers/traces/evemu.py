"""evemu-record traces: ``N:``, ``I:``, ``P:``, ``B:``, ``A:`` and ``E:`` lines.

``B: type bytes…`` lines give the capability bitmasks (several lines per type
continue the mask); ``A: code min max fuzz flat [resolution]``;
``E: sec.usec type code value`` with type/code hex and the value decimal
(may be negative).  Comments (``#`` to the end of the line) and unknown lines
are skipped; anything malformed is a :class:`TraceError` with ``file:line``.
"""

from __future__ import annotations

import os
from collections.abc import Iterable

from station.drivers.evdev import codes as c
from station.drivers.evdev.frames import AbsInfo, EvdevCaps, InputEvent
from station.drivers.traces.model import Trace, TraceDevice, TraceError, tolerate_cut

from station import boundedio


def _ints(tokens: list[str], base: int, where: str, what: str) -> list[int]:
    try:
        return [int(t, base) for t in tokens]
    except ValueError:
        raise TraceError(f"{what}: {' '.join(tokens)!r} are not numbers", where) from None


def parse_evemu(lines: Iterable[str], name: str) -> Trace:
    """Parse evemu-record text; a last line cut off mid-write is dropped with a warning."""
    return tolerate_cut(_parse_evemu, lines, name)


def _parse_evemu(lines: Iterable[str], name: str) -> Trace:
    dev_name = ""
    ids = [0, 0, 0, 0]
    bitmasks: dict[int, bytearray] = {}
    absinfo: dict[int, AbsInfo] = {}
    events: list[InputEvent] = []
    seen_keys: set[int] = set()
    seen_msc: set[int] = set()
    header_where = f"{name}:1"
    last_t = None
    for line_no, raw_line in enumerate(lines, 1):
        where = f"{name}:{line_no}"
        line = raw_line.split("#", 1)[0].strip()
        if not line:
            continue
        tag, sep, rest = line.partition(":")
        if not sep or len(tag) != 1:
            continue
        tokens = rest.split()
        if tag == "N":
            dev_name = rest.strip()
            header_where = where
        elif tag == "I":
            values = _ints(tokens, 16, where, "'I:' ids")
            if len(values) < 3:
                raise TraceError("'I:' needs bus vid pid [version]", where)
            ids = [*values, 0][:4]
        elif tag == "B":
            values = _ints(tokens, 16, where, "'B:' bitmask")
            if not values or any(not 0 <= v <= 0xFF for v in values):
                raise TraceError("'B:' needs a type and mask bytes 00..ff", where)
            bitmasks.setdefault(values[0], bytearray()).extend(values[1:])
        elif tag == "A":
            if len(tokens) < 5:
                raise TraceError("'A:' needs code min max fuzz flat [resolution]", where)
            (code,) = _ints(tokens[:1], 16, where, "'A:' code")
            values = _ints(tokens[1:], 10, where, "'A:' axis")
            lo, hi, fuzz, flat = values[:4]
            res = values[4] if len(values) > 4 else 0
            if any(not -(1 << 31) <= v < 1 << 31 for v in values):  # input_absinfo: s32
                raise TraceError(f"axis {code:#x}: a value does not fit 32 bits", where)
            if hi < lo:
                raise TraceError(f"axis {code:#x}: max {hi} < min {lo}", where)
            absinfo[code] = AbsInfo(lo, hi, fuzz, flat, res, min(max(0, lo), hi))
        elif tag == "E":
            if len(tokens) != 4:
                raise TraceError("'E:' needs sec.usec type code value", where)
            try:
                t = float(tokens[0])
                etype, code = int(tokens[1], 16), int(tokens[2], 16)
                value = int(tokens[3], 10)
            except ValueError:
                raise TraceError(f"'E:' {rest.strip()!r} is malformed", where) from None
            if not (0 <= t < 1e12) or not (0 <= etype <= 0x1F and 0 <= code <= 0x2FF):
                raise TraceError(f"'E:' {rest.strip()!r} out of range", where)
            if last_t is not None and t + 1e-6 < last_t:
                raise TraceError(f"time {t} goes back (previous {last_t})", where)
            last_t = t
            if etype == c.EV_KEY:
                seen_keys.add(code)
            elif etype == c.EV_MSC:
                seen_msc.add(code)
            events.append(InputEvent(t, etype, code, value))
    if not dev_name and not absinfo:
        raise TraceError("not an evemu recording (no N: or A: lines)", f"{name}:1")

    def bits(ev_type: int) -> set[int]:
        mask = bitmasks.get(ev_type, bytearray())
        return {i * 8 + b for i, byte in enumerate(mask) for b in range(8) if byte >> b & 1}

    keys = bits(c.EV_KEY) or seen_keys
    msc = bits(c.EV_MSC) or seen_msc
    caps = EvdevCaps(name=dev_name, absinfo=absinfo, keys=frozenset(keys), bus=ids[0],
                     vid=ids[1], pid=ids[2], version=ids[3], msc=frozenset(msc))
    device = TraceDevice(index=0, name=dev_name, vid=ids[1], pid=ids[2], bus=ids[0], caps=caps,
                         events=events, where=header_where)
    return Trace(path=name, format="evemu", devices=[device])


def read_evemu(path: str | os.PathLike[str]) -> Trace:
    name = str(path)
    try:
        boundedio.check_regular(path, str(path))
        with open(path, encoding="utf-8-sig") as fh:  # a BOM from Windows editors is dropped
            return parse_evemu(fh, name)
    except UnicodeDecodeError:
        raise TraceError("not a text file", f"{name}:1") from None
    except OSError as exc:
        raise TraceError(f"cannot open ({exc.strerror})", name) from None


def format_evemu(caps: EvdevCaps, events: Iterable[InputEvent]) -> str:
    """An evemu-record text for ``caps`` and ``events`` (what evemu-record 1.3 writes)."""
    lines = ["# EVEMU 1.3", f"N: {caps.name}",
             f"I: {caps.bus:04x} {caps.vid:04x} {caps.pid:04x} {caps.version:04x}",
             "P: 00 00 00 00 00 00 00 00"]

    def mask_lines(ev_type: int, codes: Iterable[int]) -> None:
        codes = sorted(codes)
        if not codes:
            return
        mask = bytearray((codes[-1] // 8 + 8) // 8 * 8)
        for code in codes:
            mask[code // 8] |= 1 << (code % 8)
        for i in range(0, len(mask), 8):
            lines.append(f"B: {ev_type:02x} " + " ".join(f"{b:02x}" for b in mask[i:i + 8]))

    mask_lines(c.EV_SYN, [c.EV_SYN, c.EV_KEY, c.EV_ABS] + ([c.EV_MSC] if caps.msc else []))
    mask_lines(c.EV_KEY, caps.keys)
    mask_lines(c.EV_ABS, caps.absinfo)
    mask_lines(c.EV_MSC, caps.msc)
    for code, a in sorted(caps.absinfo.items()):
        lines.append(f"A: {code:02x} {a.minimum} {a.maximum} {a.fuzz} {a.flat} {a.resolution}")
    for ev in events:
        lines.append(f"E: {ev.time:.6f} {ev.type:04x} {ev.code:04x} {ev.value:04d}")
    return "\n".join(lines) + "\n"
