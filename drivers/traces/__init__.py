"""Device traces: read hid-recorder, evemu-record and libinput-record files.

:func:`read_trace` picks the reader by extension (``.hid``/``.hidrec``,
``.evemu``/``.evm``, ``.yaml``/``.yml``) or, failing that, by content, and
returns a :class:`Trace`.  Playing a trace through the same parser and
normaliser as a live device is the pipeline's job
(:func:`station.drivers.pipeline.iter_trace_samples`): the readers stay below it.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path
from typing import IO

from station.drivers.traces.evemu import parse_evemu, read_evemu
from station.drivers.traces.hidrecorder import (
    ANSI_ESCAPE,
    HidRecorderWriter,
    parse_hid_recorder,
    read_hid_recorder,
)
from station.drivers.traces.libinput_record import parse_libinput_record, read_libinput_record
from station.drivers.traces.model import Trace, TraceDevice, TraceError

from station import boundedio
from station.events import PenSample
from station.sessionlog import SessionHeader, SessionLogWriter

__all__ = [
    "HidRecorderWriter",
    "Trace",
    "TraceDevice",
    "TraceError",
    "is_trace_path",
    "parse_evemu",
    "parse_hid_recorder",
    "parse_libinput_record",
    "read_trace",
    "trace_format",
    "write_session_log",
]

_BY_SUFFIX = {
    ".hid": "hid-recorder", ".hidrec": "hid-recorder", ".rec": "hid-recorder",
    ".evemu": "evemu", ".evm": "evemu",
    ".yaml": "libinput-record", ".yml": "libinput-record",
}  # fmt: skip


def is_trace_path(path: str | os.PathLike[str]) -> bool:
    """True for the file names ``station paint`` should treat as device traces."""
    return Path(path).suffix.lower() in _BY_SUFFIX


def trace_format(path: str | os.PathLike[str]) -> str:
    """The reader for ``path``: by suffix, else by the first meaningful lines."""
    fmt = _BY_SUFFIX.get(Path(path).suffix.lower())
    if fmt:
        return fmt
    name = str(path)
    # hid-recorder writes the whole descriptor as comments before 'R:' (hundreds of
    # lines for a big one), so look at the first meaningful lines, not the first lines.
    head: list[str] = []
    comments: list[str] = []
    try:
        boundedio.check_regular(path, str(path))
        with open(path, encoding="utf-8-sig", errors="replace") as fh:
            for n, line in enumerate(fh):
                if n >= 20000 or len(head) >= 50:
                    break
                stripped = ANSI_ESCAPE.sub("", line).strip() if "\x1b" in line else line.strip()
                if stripped.startswith("#"):
                    if len(comments) < 50:
                        comments.append(stripped)
                elif stripped:
                    head.append(stripped)
    except OSError as exc:
        raise TraceError(f"cannot open ({exc.strerror})", name) from None
    # 'R:' only exists in hid-recorder files, whose 'B:' lines are HID-BPF events, so it
    # is tested before evemu's 'A:'/'B:' lines.
    if any(line.startswith("R:") for line in head):
        return "hid-recorder"
    if any("EVEMU" in c for c in comments) or any(line.startswith(("A:", "B:")) for line in head):
        return "evemu"
    if any(line.startswith(("devices:", "version:", "ndevices:")) for line in head):
        return "libinput-record"
    if any(line.startswith(("D:", "E:")) for line in head):
        return "hid-recorder"
    raise TraceError("not a trace this station reads (hid-recorder, evemu, libinput record)",
                     f"{name}:1")


def read_trace(path: str | os.PathLike[str]) -> Trace:
    """Read a whole trace into memory (traces are minutes, not hours)."""
    fmt = trace_format(path)
    if fmt == "evemu":
        return read_evemu(path)
    if fmt == "libinput-record":
        return read_libinput_record(path)
    return read_hid_recorder(path)


def write_session_log(samples: Iterable[PenSample], path: str | os.PathLike[str] | IO[str],
                      source: str = "", width: int = 800, height: int = 600) -> int:
    """Write pen samples as a session log (header first); returns the records written."""
    header = SessionHeader(width=width, height=height,
                           extra={"source": source, "coordinates": "device"} if source else {})
    with SessionLogWriter(path, header) as writer:
        for sample in samples:
            writer.write(sample)
        return writer.count
