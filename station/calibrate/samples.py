"""Pen samples of a recording for ``station calibrate --from-trace``: a session log
(``.jsonl``) or a device trace read through the drivers' readers."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

from station.drivers.traces.replay import iter_trace_samples
from station.events import PenSample
from station.sessionlog import SessionLogReader


def iter_samples(path: str | os.PathLike[str]) -> Iterator[PenSample]:
    """Pen samples of a session log (``.jsonl``) or a device trace (drivers' readers)."""
    p = Path(path)
    if p.suffix.lower() in (".jsonl", ".json"):
        with SessionLogReader(p) as reader:
            for rec in reader:
                if isinstance(rec, PenSample):
                    yield rec
        return
    yield from iter_trace_samples(p)
