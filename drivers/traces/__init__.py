"""Device traces: read hid-recorder, evemu-record and libinput-record files.

:func:`read_trace` picks the reader by extension (``.hid``/``.hidrec``,
``.evemu``/``.evm``, ``.yaml``/``.yml``) or, failing that, by content, and
returns a :class:`Trace`.  :func:`iter_trace_samples` plays a trace through
the same parser and normaliser as a live device and yields the
device-normalised pen samples (``station paint`` and ``station replay`` use it).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO, TYPE_CHECKING

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
from station.errors import BadInput

if TYPE_CHECKING:
    from station.drivers.normalise import NormaliserConfig

    from station.events import PenSample

__all__ = [
    "HidRecorderWriter",
    "Trace",
    "TraceDevice",
    "TraceError",
    "is_trace_path",
    "iter_trace_samples",
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


def iter_trace_samples(path: str | os.PathLike[str], device: str | None = None,
                       config: NormaliserConfig | None = None) -> Iterator[PenSample]:
    """Pen samples of every pen device in the trace, in time order.

    Device-normalised unless ``config`` names a canvas to map them onto.  A
    trace without a pen device raises :class:`~station.errors.BadInput`.
    """
    from station.drivers.pipeline import TraceReplay

    replay = TraceReplay(read_trace(path), config=config, device_name=device)
    if not replay.pen_devices:
        raise BadInput(f"no pen device in this trace ({replay.skipped_text()})", str(path))
    yield from replay.samples()


def write_session_log(samples: Iterable[PenSample], path: str | os.PathLike[str] | IO[str],
                      source: str = "", width: int = 800, height: int = 600) -> int:
    """Write pen samples as a session log (header first); returns the records written."""
    from station.sessionlog import SessionHeader, SessionLogWriter

    header = SessionHeader(width=width, height=height,
                           extra={"source": source, "coordinates": "device"} if source else {})
    with SessionLogWriter(path, header) as writer:
        for sample in samples:
            writer.write(sample)
        return writer.count
