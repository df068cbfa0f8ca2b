"""Recovering a live session after a crash: the last autosave plus the log since it.

``station sim --recover [LOG]`` (and the kiosk) calls :func:`plan`: it reads
the log's header, takes the autosave next to the log when it belongs to this
log (its ``session.log.header`` is the log's first line, and the log holds at
least the ``session.log.records`` records it counted), and otherwise starts
from the state the log itself started from (blank paper, or the header's
``resumed_from`` state).  :class:`~station.sim.live.LiveCore` then replays the
records after that point exactly as they were applied live and appends to the
same log.

A log whose last line was cut off mid-write (a machine crash; the live sim
itself writes whole lines or resumes a cut one) loses that fragment: it was
never a record, and appending after it would merge two lines.  The fragment's
size is reported.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from station.canvas.state import CanvasState, read_extra
from station.errors import BadInput
from station.events import Command, PenSample
from station.sessionlog import SessionHeader, SessionLogReader
from station.sim.journal import autosave_path, latest_log

log = logging.getLogger(__name__)

CHECKPOINT_VERSION = 1


class RecoveryError(BadInput):
    """The log cannot be recovered (missing, not a session log, base state gone)."""


@dataclass
class Plan:
    """How to rebuild a session: start state, the records to replay, where to log."""

    log_path: Path
    header: SessionHeader
    header_line: str
    rate: float | None
    state: CanvasState | None  # None: blank paper from the header
    session: dict[str, Any] | None  # the autosave's player/counters, None without one
    records_total: int  # records in the log
    skip: int  # records the state already holds
    replayed: int = 0

    def seqs_before(self) -> dict[str, int]:
        """Each device's last pen seq in the records the start state already holds: a
        crash just after an autosave leaves none after it, and the samples lost while
        no sim listened are still counted from these."""
        last: dict[str, int] = {}
        with SessionLogReader(self.log_path) as reader:
            for i, rec in enumerate(reader):
                if i >= self.skip:
                    break
                if isinstance(rec, PenSample) and rec.seq:
                    last[rec.device] = rec.seq
        return last

    def records(self) -> Iterator[PenSample | Command]:
        """The records after the start state, in log order."""
        with SessionLogReader(self.log_path) as reader:
            for i, rec in enumerate(reader):
                if i >= self.skip:
                    self.replayed += 1
                    yield rec


def resolve_log(target: str | None) -> Path:
    """The log ``--recover`` names, or the newest one in the sessions directory."""
    if target and target != "latest":
        path = Path(target)
        if not path.is_file():
            raise RecoveryError("no such session log", target)
        return path
    found = latest_log()
    if found is None:
        raise RecoveryError("no session log to recover in the sessions directory", "--recover")
    return found


def _drop_cut_tail(path: Path) -> None:
    with open(path, "rb+") as fh:
        size = fh.seek(0, os.SEEK_END)
        if size == 0:
            return
        fh.seek(size - 1)
        if fh.read(1) == b"\n":
            return
        back = min(size, 1 << 20)
        fh.seek(size - back)
        tail = fh.read(back)
        cut = tail.rfind(b"\n")
        keep = size - back + cut + 1 if cut >= 0 else 0
        if keep == 0:
            raise RecoveryError("the log holds no complete line", str(path))
        log.warning("%s: the last line was cut off mid-write; its %d bytes are dropped",
                    path, size - keep)
        fh.truncate(keep)


def _count_records(path: Path) -> tuple[str, int]:
    """The header line and the number of non-empty lines after it."""
    count, header = 0, None
    with open(path, "rb") as fh:
        for raw in fh:
            if not raw.strip():
                continue
            if header is None:
                header = raw.decode("utf-8", "replace").rstrip("\n")
            else:
                count += 1
    return header or "", count


def _check_session(s: object) -> dict[str, Any]:
    """The autosave's session entry, every field read once (ValueError if malformed)."""
    if not isinstance(s, dict) or s.get("version") != CHECKPOINT_VERSION:
        raise ValueError("unknown checkpoint version")
    lg, ps, ls = s["log"], s["player"], s["live"]
    int(lg["records"]), str(lg["header"])
    for k in ("steps", "samples", "stamps", "brush_samples", "eraser_samples", "strokes"):
        if int(ps[k]) < 0:
            raise ValueError(f"negative {k}")
    for k in ("waited", "last_t", "waited_s"):
        if not math.isfinite(float(ps[k])):
            raise ValueError(f"{k} is not finite")
    b = ps["brush"]
    str(b["kind"]), float(b["size"]), float(b["water"])
    {str(k): float(v) for k, v in b["pigment"].items()}
    [str(n) for n in ps["layer_pigments"]]
    str(ps["profile"])
    {str(k): int(v) for k, v in ps["commands"].items()}
    {str(k): int(v) for k, v in ps["skipped_commands"].items()}
    float(ls["last_t"])
    for k in ("samples", "commands", "bad_commands", "bad_samples", "dropped_sources",
              "synthetic_pen_ups"):
        int(ls[k])
    return s


def plan(target: str | None) -> Plan:
    """Work out the recovery of the session logged at ``target`` (see module doc)."""
    path = resolve_log(target)
    _drop_cut_tail(path)
    with SessionLogReader(path) as reader:
        header = reader.header
    header_line, total = _count_records(path)
    sim = header.extra.get("sim")
    rate = sim.get("rate") if isinstance(sim, dict) else None
    if not (isinstance(rate, (int, float)) and not isinstance(rate, bool)
            and math.isfinite(rate) and rate > 0):
        rate = None
    state, session, skip = None, None, 0
    cp = autosave_path(path)
    if cp.exists():
        try:
            session = _check_session(read_extra(cp, "session"))
            if session["log"]["header"] != header_line:
                raise ValueError("it belongs to another log")
            if int(session["log"]["records"]) > total:
                raise ValueError("it counts more records than the log holds")
            state = CanvasState.load(cp)
            if (state.width, state.height) != (header.width, header.height):
                raise ValueError("its canvas size differs from the log's")
            skip = int(session["log"]["records"])
        except (BadInput, ValueError, KeyError, TypeError, AttributeError) as exc:
            log.warning("autosave %s not used (%s): replaying the whole log", cp, exc)
            state, session, skip = None, None, 0
    if state is None and "resumed_from" in header.extra:
        base = header.extra["resumed_from"]
        if not isinstance(base, str):
            raise RecoveryError("header 'resumed_from' must be a file name", str(path))
        state = CanvasState.load(base)
    return Plan(log_path=path, header=header, header_line=header_line, rate=rate,
                state=state, session=session, records_total=total, skip=skip)
