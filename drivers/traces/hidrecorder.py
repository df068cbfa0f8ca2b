"""hid-recorder (hid-tools) traces: reader and writer.

Format (every recorder version seen): ``#`` comments; ``D: n`` selects the
device the following lines belong to (no ``D:`` = device 0); ``R: len hex…``
report descriptor; ``N: name``; ``P: phys``; ``I: bus vid pid`` (hex);
``E: sec.usec len hex…`` one input report.  Times may start anywhere, hex may
be upper or lower case and zero-padded or not; unknown lines are skipped; an
``R:`` line wrapped onto lines of bare hex bytes is joined.  A
length that does not match the bytes, a non-hex byte or a byte above 0xff is
a :class:`TraceError` naming ``file:line``.
"""

from __future__ import annotations

import logging
import os
import re
import string
from collections.abc import Iterable
from typing import IO

from station.drivers.traces.model import Trace, TraceDevice, TraceError, tolerate_cut
from station.drivers.transport.base import TimedReport

from station import boundedio

log = logging.getLogger(__name__)
# ANSI colour sequences: the Rust hid-recorder colours its output by whether *stdout*
# is a terminal, also when it writes to --output-file.
ANSI_ESCAPE = re.compile(r"\x1b\[[0-9;:]*[A-Za-z]")
MAX_REPORT = 16384  # the kernel's HID_MAX_BUFFER_SIZE (report ID included)
MAX_DESCRIPTOR = 4096


def _hex_bytes(tokens: list[str], where: str, what: str) -> bytes:
    out = bytearray()
    for tok in tokens:
        if not tok or any(ch not in string.hexdigits for ch in tok):
            raise TraceError(f"{what}: {tok!r} is not a hex byte", where)
        value = int(tok, 16)
        if value > 0xFF:
            raise TraceError(f"{what}: {tok!r} is not a byte (00..ff)", where)
        out.append(value)
    return bytes(out)


def _length(tok: str, where: str, what: str, limit: int) -> int:
    try:
        n = int(tok, 10)
    except ValueError:
        raise TraceError(f"{what}: length {tok!r} is not a decimal number", where) from None
    if not 0 < n <= limit:
        raise TraceError(f"{what}: length {n} outside 1..{limit}", where)
    return n


def _ids(tokens: list[str], rest: str, where: str) -> tuple[int, int, int]:
    """An ``I: bus vid pid`` line (hex)."""
    if len(tokens) < 3:
        raise TraceError(f"'I:' needs bus vid pid, got {rest.strip()!r}", where)
    try:
        bus, vid, pid = (int(t, 16) for t in tokens[:3])
    except ValueError:
        raise TraceError(f"'I:' ids {rest.strip()!r} are not hex", where) from None
    if not (0 <= vid <= 0xFFFF and 0 <= pid <= 0xFFFF):
        raise TraceError(f"'I:' ids {rest.strip()!r} out of range", where)
    return bus, vid, pid


def _event(tokens: list[str], where: str) -> tuple[float, bytes]:
    """An ``E: sec.usec len hex…`` line: the report's time and bytes."""
    if len(tokens) < 2:
        raise TraceError("'E:' needs a time, a length and the bytes", where)
    try:
        t = float(tokens[0])
    except ValueError:
        raise TraceError(f"'E:' time {tokens[0]!r} is not sec.usec", where) from None
    if not (t == t and 0 <= t < 1e12):
        raise TraceError(f"'E:' time {tokens[0]!r} out of range", where)
    n = _length(tokens[1], where, "report", MAX_REPORT)
    data = _hex_bytes(tokens[2:], where, "report")
    if len(data) != n:
        raise TraceError(f"report says {n} bytes but has {len(data)} (truncated?)", where)
    return t, data


def parse_hid_recorder(lines: Iterable[str], name: str) -> Trace:
    """Parse hid-recorder text; ``name`` is used in ``file:line`` messages.

    A last line cut off mid-write is dropped with a warning (:func:`tolerate_cut`)."""
    return tolerate_cut(_parse_hid_recorder, lines, name)


def _parse_hid_recorder(lines: Iterable[str], name: str) -> Trace:
    devices: dict[int, TraceDevice] = {}
    current = -1

    def device(index: int, where: str) -> TraceDevice:
        if index not in devices:
            devices[index] = TraceDevice(index=index, where=where)
        return devices[index]

    last_time: dict[int, float] = {}
    # An 'R:' line wrapped onto following lines of bare hex bytes (mail clients and
    # bug trackers wrap long lines): (device, declared length, bytes so far, where).
    wrapped: tuple[TraceDevice, int, bytearray, str] | None = None
    for line_no, raw_line in enumerate(lines, 1):
        where = f"{name}:{line_no}"
        if "\x1b" in raw_line:  # colours of `hid-recorder --output-file` run on a terminal
            raw_line = ANSI_ESCAPE.sub("", raw_line)
        line = raw_line.strip()
        if not line or line.startswith("#"):
            continue
        if wrapped is not None:
            wdev, n, sofar, rwhere = wrapped
            if ":" not in line:
                sofar += _hex_bytes(line.split(), where, "report descriptor")
                if len(sofar) >= n:
                    if len(sofar) != n:
                        raise TraceError(f"report descriptor says {n} bytes but has "
                                         f"{len(sofar)}", rwhere)
                    wdev.descriptor = bytes(sofar)
                    wrapped = None
                continue
            raise TraceError(f"report descriptor says {n} bytes but has {len(sofar)}", rwhere)
        tag, sep, rest = line.partition(":")
        if not sep or len(tag) != 1:
            log.debug("%s: skipping unknown line", where)
            continue
        tokens = rest.split()
        if tag == "D":
            if len(tokens) != 1 or not tokens[0].isdigit():
                raise TraceError(f"'D:' needs one device number, got {rest.strip()!r}", where)
            current = int(tokens[0])
            device(current, where)
            continue
        dev = device(max(current, 0), where)
        if tag == "R":
            if not tokens:
                raise TraceError("'R:' without a length", where)
            n = _length(tokens[0], where, "report descriptor", MAX_DESCRIPTOR)
            data = _hex_bytes(tokens[1:], where, "report descriptor")
            if len(data) < n:
                wrapped = (dev, n, bytearray(data), where)
                continue
            if len(data) != n:
                raise TraceError(f"report descriptor says {n} bytes but has {len(data)}", where)
            dev.descriptor = data
        elif tag == "N":
            dev.name = rest.strip()
        elif tag == "P":
            dev.phys = rest.strip()
        elif tag == "I":
            dev.bus, dev.vid, dev.pid = _ids(tokens, rest, where)
        elif tag == "E":
            t, data = _event(tokens, where)
            index = dev.index
            if t + 1e-6 < last_time.get(index, t):
                raise TraceError(f"time {t} goes back (previous {last_time[index]})", where)
            last_time[index] = t
            dev.reports.append(TimedReport(t, data))
        else:
            log.debug("%s: skipping unknown line %r", where, tag)
    if wrapped is not None:
        raise TraceError(f"report descriptor says {wrapped[1]} bytes but has "
                         f"{len(wrapped[2])}", wrapped[3])
    if not devices:
        raise TraceError("no device in this hid-recorder trace", f"{name}:1")
    return Trace(path=name, format="hid-recorder", devices=[devices[k] for k in sorted(devices)])


def read_hid_recorder(path: str | os.PathLike[str]) -> Trace:
    name = str(path)
    try:
        boundedio.check_regular(path, str(path))
        with open(path, encoding="utf-8-sig", errors="strict") as fh:  # BOM: Windows editors
            return parse_hid_recorder(fh, name)
    except UnicodeDecodeError:
        raise TraceError("not a text file", f"{name}:1") from None
    except OSError as exc:
        raise TraceError(f"cannot open ({exc.strerror})", name) from None


class HidRecorderWriter:
    """The station's one writer of hid-recorder text: ``station record`` streams
    reports through it as they arrive; :func:`station.drivers.synth.write_hid_recorder`
    writes whole synthetic recordings, in the variants other recorders write.

    The file is flushed after each line group, so Ctrl-C loses nothing.  Spelling:

    - ``upper``: upper-case hex; ``pad``: zero-padded hex bytes and ids (``0a``,
      ``056a``), else bare (``a``, ``56a``); ``pad_seconds``: ``000001.500000``, else
      ``1.500000``.
    - ``origin``: the time written as zero (seconds, on the reports' clock); ``None``
      takes the first report's time, as hid-recorder does.
    - ``device_lines``: ``None`` writes ``D: n`` before each device and, with more
      than one device, whenever the reporting device changes (hid-recorder's way);
      ``True`` also before the first report; ``False`` never (a one-device file).
    - ``comment``: a ``#`` line at the top.
    """

    def __init__(self, out: IO[str], *, upper: bool = False, pad: bool = True,
                 pad_seconds: bool = False, origin: float | None = None,
                 device_lines: bool | None = None, comment: str | None = None) -> None:
        self._out = out
        self._upper = upper
        self._pad = pad
        self._pad_seconds = pad_seconds
        self._t0 = origin
        self._device_lines = device_lines
        self._devices = 0
        self._current = -1  # the device of the last D: line (or header)
        self._last_report_device = -1
        self.reports = 0
        if comment is not None:
            out.write(f"# {comment}\n")

    def _hex(self, data: bytes) -> str:
        if self._pad:  # the common spelling, at the speed of a 1 kHz device
            text = data.hex(" ")
            return text.upper() if self._upper else text
        return " ".join(("{:X}" if self._upper else "{:x}").format(b) for b in data)

    def add_device(self, name: str, vid: int, pid: int, bus: int, descriptor: bytes | None,
                   phys: str = "", comment: str | None = None) -> int:
        """Write one device's header lines; returns its index (``D: n``)."""
        index = self._devices
        self._devices += 1
        w = self._out.write
        if self._device_lines is not False:
            w(f"D: {index}\n")
        if comment is not None:
            w(f"# {comment}\n")
        if descriptor:
            w(f"R: {len(descriptor)} {self._hex(descriptor)}\n")
        w(f"N: {name}\n")
        w(f"P: {phys}\n")
        ids = f"{bus:x} {vid:04x} {pid:04x}" if self._pad else f"{bus:x} {vid:x} {pid:x}"
        w(f"I: {ids.upper() if self._upper else ids}\n")
        self._out.flush()
        self._current = index
        return index

    def write_report(self, time: float, data: bytes, device: int = 0) -> None:
        """One input report of ``device``, ``time`` seconds on the reports' clock."""
        if self._t0 is None:
            self._t0 = time
        if self._device_lines is True:
            new_device = device != self._last_report_device
        else:
            new_device = self._device_lines is None and self._devices > 1 and \
                device != self._current
        if new_device:
            self._out.write(f"D: {device}\n")
            self._current = device
        self._last_report_device = device
        t = max(0.0, time - self._t0)
        stamp = f"{t:013.6f}" if self._pad_seconds else f"{t:.6f}"
        self._out.write(f"E: {stamp} {len(data)} {self._hex(data)}\n")
        self._out.flush()
        self.reports += 1
