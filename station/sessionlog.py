"""The session log: one JSON object per line (interfaces.md).

The reader streams (a multi-hour session never loads whole), warns about
unknown record types and keys, and raises :class:`SessionLogError` naming
``file:line`` for a malformed line.  The writer flushes at least once a second
so a crash loses at most the last second.
"""

from __future__ import annotations

import io
import json
import logging
import math
import os
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from station import boundedio
from station.errors import EventError, SessionLogError
from station.events import Command, PenSample

log = logging.getLogger(__name__)

FORMAT_NAME = "station-session"
FORMAT_VERSION = 1
MAX_LINE_BYTES = 1 << 20  # a line longer than this is not a session-log record
PROFILES = ("watercolor", "gouache", "ink")


@dataclass(frozen=True, slots=True)
class SessionHeader:
    """The first line of a session log.

    Attributes:
        width: canvas width in cells.
        height: canvas height in cells.
        profile: paint profile name.
        seed: random seed of the paper and any stochastic part.
        extra: unknown header keys, kept for round trips.
    """

    width: int = 800
    height: int = 600
    profile: str = "watercolor"
    seed: int = 0
    extra: dict[str, Any] = field(default_factory=dict)

    def to_record(self) -> dict[str, object]:
        rec: dict[str, object] = {
            "format": FORMAT_NAME,
            "version": FORMAT_VERSION,
            "canvas": {"width": self.width, "height": self.height},
            "profile": self.profile,
            "seed": self.seed,
        }
        rec.update(self.extra)
        return rec

    @classmethod
    def from_record(cls, rec: object, where: str) -> SessionHeader:
        if not isinstance(rec, dict) or rec.get("format") != FORMAT_NAME:
            raise SessionLogError(
                f"first line is not a session header (needs \"format\": \"{FORMAT_NAME}\")", where
            )
        version = rec.get("version")
        if version != FORMAT_VERSION:
            raise SessionLogError(
                f"session log version {version!r} is not supported (this station reads "
                f"version {FORMAT_VERSION})",
                where,
            )
        canvas = rec.get("canvas", {})
        if not isinstance(canvas, dict):
            raise SessionLogError("header 'canvas' must be an object", where)
        width, height = canvas.get("width", 800), canvas.get("height", 600)
        for name, v in (("width", width), ("height", height)):
            if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= 16384:
                raise SessionLogError(f"canvas {name} {v!r} must be an integer 1..16384", where)
        profile = rec.get("profile", "watercolor")
        if not isinstance(profile, str):
            raise SessionLogError(f"profile {profile!r} must be a name", where)
        seed = rec.get("seed", 0)
        if isinstance(seed, bool) or not isinstance(seed, int):
            raise SessionLogError(f"seed {seed!r} must be an integer", where)
        known = {"format", "version", "canvas", "profile", "seed"}
        extra = {k: v for k, v in rec.items() if k not in known}
        return cls(width=width, height=height, profile=profile, seed=seed, extra=extra)


Record = PenSample | Command


def _reject_constant(name: str) -> float:
    raise ValueError(f"{name} is not a JSON number")


def _loads(text: str, where: str, header: bool = False) -> object:
    """JSON of one line; malformed or absurdly nested text is a :class:`SessionLogError`."""
    prefix = "header is " if header else ""
    try:
        return json.loads(text, parse_constant=_reject_constant)
    except ValueError as exc:
        raise SessionLogError(f"{prefix}not valid JSON ({exc})", where) from None
    except RecursionError:  # "[[[[…" 50,000 deep: the decoder recurses per level
        raise SessionLogError(f"{prefix}not valid JSON (nested too deeply)", where) from None


def parse_line(text: str, where: str, warn: bool = True) -> Record | None:
    """Parse one non-header line; ``None`` for an unknown record type (warned)."""
    rec = _loads(text, where)
    if not isinstance(rec, dict):
        raise SessionLogError("a record must be a JSON object", where)
    kind = rec.get("type")
    try:
        if kind == "pen":
            unknown: list[str] = []
            sample = PenSample.from_record(rec, where, unknown)
            if unknown and warn:
                log.warning("%s: ignoring unknown pen keys %s", where, ", ".join(unknown))
            return sample
        if kind == "cmd":
            command = Command.from_record(rec, where)
            if not command.known and warn:
                log.warning("%s: unknown command %r passed on", where, command.cmd)
            return command
    except EventError as exc:
        raise SessionLogError(str(exc).removeprefix(f"{where}: "), where) from None
    if warn:
        log.warning("%s: ignoring unknown record type %r", where, kind)
    return None


class SessionLogReader:
    """Streams a session log: ``header`` first, then records in file order.

    Use as ``with SessionLogReader(path) as r: for rec in r: …``.  Timestamps
    must not go backwards; ``unknown`` counts the records that were skipped.
    """

    def __init__(self, source: str | os.PathLike[str] | IO[str], name: str | None = None) -> None:
        if isinstance(source, (str, os.PathLike)):
            self.name = name or str(source)
            try:
                boundedio.check_regular(source, self.name)  # not /dev/zero, not a FIFO
                self._fh: IO[str] = open(source, encoding="utf-8", newline="")  # noqa: SIM115
            except OSError as exc:
                raise SessionLogError(f"cannot open ({exc.strerror})", self.name) from None
            self._owns = True
        else:
            self.name = str(name or getattr(source, "name", "<stream>"))
            self._fh = source
            self._owns = False
        self.line_no = 0
        self.unknown = 0
        self.cut: str | None = None  # ``file:line`` of a cut-off last line that was skipped
        self.header = self._read_header()

    def _next_line(self) -> str | None:
        try:
            line = self._fh.readline(MAX_LINE_BYTES + 1)
        except UnicodeDecodeError:
            raise SessionLogError("not UTF-8 text", f"{self.name}:{self.line_no + 1}") from None
        if not line:
            return None
        self.line_no += 1
        if len(line) > MAX_LINE_BYTES:
            raise SessionLogError("line longer than 1 MiB", f"{self.name}:{self.line_no}")
        return line

    def _read_header(self) -> SessionHeader:
        while True:
            line = self._next_line()
            if line is None:
                raise SessionLogError("empty file: no session header", f"{self.name}:1")
            if line.strip():
                break
        where = f"{self.name}:{self.line_no}"
        return SessionHeader.from_record(_loads(line, where, header=True), where)

    def __iter__(self) -> Iterator[Record]:
        last_t = 0.0
        while True:
            line = self._next_line()
            if line is None:
                return
            if not line.strip():
                continue
            where = f"{self.name}:{self.line_no}"
            try:
                rec = parse_line(line, where)
            except SessionLogError as exc:
                if line.endswith(("\n", "\r")):
                    raise
                # The last line without its newline: the writer was killed mid-line.
                self.cut = where
                log.warning("%s: last line cut off (the station stopped mid-write?): %s; "
                            "playing the log up to it", where,
                            str(exc).removeprefix(f"{where}: "))
                return
            if rec is None:
                self.unknown += 1
                continue
            if rec.t + 1e-9 < last_t:
                raise SessionLogError(f"time {rec.t} goes back (previous {last_t})", where)
            last_t = rec.t
            yield rec

    def close(self) -> None:
        if self._owns:
            self._fh.close()

    def __enter__(self) -> SessionLogReader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def read_session(path: str | os.PathLike[str]) -> tuple[SessionHeader, list[Record]]:
    """Read a whole (small) log; for long sessions iterate a reader instead."""
    with SessionLogReader(path) as reader:
        return reader.header, list(reader)


class SessionLogWriter:
    """Writes a session log, flushing (and fsyncing) at least every ``flush_every`` s.

    Records are written in the order given; ``t`` must not go backwards.
    """

    def __init__(
        self,
        target: str | os.PathLike[str] | IO[str],
        header: SessionHeader,
        flush_every: float = 1.0,
        line_buffered: bool = False,
    ) -> None:
        if isinstance(target, (str, os.PathLike)):
            self.path: Path | None = Path(target)
            # line_buffered: every record reaches the OS at once (a process killed from
            # outside leaves whole lines; fsync still follows flush_every)
            self._fh: IO[str] = open(target, "w", encoding="utf-8", newline="\n",  # noqa: SIM115
                                     buffering=1 if line_buffered else -1)
            self._owns = True
        else:
            self.path = None
            self._fh = target
            self._owns = False
        self.flush_every = flush_every
        self._last_flush = time.monotonic()
        self._last_t = 0.0
        self.count = 0
        self._write(header.to_record())
        self.flush()

    def _write(self, rec: Mapping[str, object]) -> None:
        self._fh.write(json.dumps(rec, separators=(", ", ": "), allow_nan=False) + "\n")

    def write(self, record: Record) -> None:
        if record.t + 1e-9 < self._last_t:
            raise SessionLogError(f"record time {record.t} before previous {self._last_t}")
        self._last_t = max(self._last_t, record.t)
        self._write(record.to_record())
        self.count += 1
        now = time.monotonic()
        if now - self._last_flush >= self.flush_every:
            self.flush()

    def flush(self) -> None:
        self._fh.flush()
        if self._owns:
            try:
                os.fsync(self._fh.fileno())
            except (OSError, io.UnsupportedOperation):
                pass
        self._last_flush = time.monotonic()

    def close(self) -> None:
        if self._fh.closed:
            return
        self.flush()
        if self._owns:
            self._fh.close()

    def __enter__(self) -> SessionLogWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def summarise(reader: SessionLogReader) -> dict[str, object]:
    """Statistics of a log for ``station log stats`` (streams; constant memory)."""
    pens = cmds = strokes = 0
    devices: dict[str, int] = {}
    tools: dict[str, int] = {}
    commands: dict[str, int] = {}
    first_t = last_t = None
    touching: dict[str, bool] = {}
    max_gap = 0.0
    prev_pen_t: dict[str, float] = {}
    for rec in reader:
        first_t = rec.t if first_t is None else first_t
        last_t = rec.t
        if isinstance(rec, PenSample):
            pens += 1
            devices[rec.device] = devices.get(rec.device, 0) + 1
            tools[rec.tool.value] = tools.get(rec.tool.value, 0) + 1
            if rec.touching and not touching.get(rec.device, False):
                strokes += 1
            touching[rec.device] = rec.touching
            if rec.device in prev_pen_t and rec.proximity:
                max_gap = max(max_gap, rec.t - prev_pen_t[rec.device])
            prev_pen_t[rec.device] = rec.t
        else:
            cmds += 1
            commands[rec.cmd] = commands.get(rec.cmd, 0) + 1
    duration = (last_t - first_t) if first_t is not None and last_t is not None else 0.0
    h = reader.header
    return {
        "file": reader.name,
        "canvas": {"width": h.width, "height": h.height},
        "profile": h.profile,
        "seed": h.seed,
        "records": pens + cmds,
        "pen_samples": pens,
        "commands": commands,
        "command_count": cmds,
        "unknown_records": reader.unknown,
        "devices": devices,
        "tools": tools,
        "strokes": strokes,
        "duration_s": duration,
        "pen_rate_hz": (pens / duration) if duration > 0 and not math.isclose(duration, 0) else 0.0,
        "max_pen_gap_s": max_gap,
    }
