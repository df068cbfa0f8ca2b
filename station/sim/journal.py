"""The live simulation's session log on disk: append-only, never truncated, never lost.

:class:`SessionJournal` appends records to a session log (interfaces.md).  A
new log is created exclusively (``O_EXCL``: an existing file is never
overwritten); a recovered session appends to its old log.  Records are
buffered in memory and handed to the kernel by :meth:`SessionJournal.flush`,
which the simulation calls before every step, so a ``kill -9`` loses nothing
that was painted; :meth:`SessionJournal.sync` also fsyncs (once a second, and
before every autosave).

A full disk or an unwritable path does not stop the painting: the failure is
reported once (:class:`StorageReport`), the records stay in memory and the
journal retries (reopening the file when it could not be created), so when
space comes back the log catches up.  A write that stopped halfway resumes
exactly where it stopped: the bytes already on disk are never rewritten.

Where logs live: ``--log`` or, by default,
``$STATION_DATA_DIR/sessions`` (else ``$XDG_DATA_HOME/station/sessions``, else
``~/.local/share/station/sessions``), one ``session-YYYYmmdd-HHMMSS-PID.jsonl``
per run; the autosave sits next to it as ``<log stem>.autosave.npz``.
"""

from __future__ import annotations

import errno
import json
import logging
import os
import time
from pathlib import Path

from station import paths
from station.durable import PartialWrite, write_all
from station.events import Command, PenSample
from station.sessionlog import SessionHeader

log = logging.getLogger(__name__)

MAX_PENDING_BYTES = 256 << 20  # records kept in memory while the disk refuses them
RETRY_S = 2.0  # how often a failing log is retried


def data_dir() -> Path:
    """The user's station data directory (sessions live in ``sessions/`` under it)."""
    return paths.data_dir()


def sessions_dir() -> Path:
    return data_dir() / "sessions"


def default_log_path() -> Path:
    """A new log name in :func:`sessions_dir` (created, mode 0700: paintings are private)."""
    d = sessions_dir()
    d.mkdir(mode=0o700, parents=True, exist_ok=True)
    stamp = time.strftime("%Y%m%d-%H%M%S", time.localtime())
    return free_path(d / f"session-{stamp}-{os.getpid()}.jsonl")


def free_path(path: Path) -> Path:
    """``path`` if nothing is there, else the first free ``stem-N.suffix`` (N >= 2)."""
    if not os.path.lexists(path):
        return path
    n = 2
    while True:
        cand = path.with_name(f"{path.stem}-{n}{path.suffix}")
        if not os.path.lexists(cand):
            return cand
        n += 1


def autosave_path(log_path: str | os.PathLike[str]) -> Path:
    """Where the autosave of the session logged at ``log_path`` goes."""
    p = Path(log_path)
    return p.with_name(f"{p.stem}.autosave.npz")


def latest_log() -> Path | None:
    """The most recently written log in :func:`sessions_dir`, if any."""
    try:
        logs = [p for p in sessions_dir().glob("*.jsonl") if p.is_file()]
    except OSError:
        return None
    return max(logs, key=lambda p: p.stat().st_mtime, default=None)


def record_line(record: PenSample | Command | SessionHeader) -> bytes:
    """One log line, formatted as :class:`station.sessionlog.SessionLogWriter` does."""
    rec: dict[str, object] = record.to_record()
    return (json.dumps(rec, separators=(", ", ": "), allow_nan=False) + "\n").encode()


class StorageReport:
    """Storage failures, each kind reported once (a full disk must not flood the log)."""

    def __init__(self) -> None:
        self.failures = 0
        self.problems: dict[str, str] = {}  # what -> first error text
        self._reported = False

    def failed(self, what: str, exc: OSError) -> None:
        """One failure; the first of an episode is logged as an error, the rest counted
        (a full disk fails the log, the autosave and the image alike)."""
        self.failures += 1
        if what in self.problems:
            return
        text = f"{exc.strerror or exc}" + (f" ({errno.errorcode.get(exc.errno, '')})"
                                           if exc.errno else "")
        self.problems[what] = text
        if not self._reported:
            self._reported = True
            log.error("cannot write %s: %s; painting goes on, will retry", what, text)
        else:
            log.info("cannot write %s either: %s", what, text)

    def recovered(self, what: str) -> None:
        if self.problems.pop(what, None) is not None and not self.problems:
            self._reported = False
            log.warning("storage works again (%s written)", what)


class SessionJournal:
    """An append-only session log (see the module docstring).

    Args:
        path: the log file.
        header: written first for a new log; ``None`` to append to an existing one.
        report: where storage failures go.
        records: records already in an appended log (for the checkpoint count).
    """

    def __init__(self, path: str | os.PathLike[str], header: SessionHeader | None,
                 report: StorageReport | None = None, records: int = 0) -> None:
        self.path = Path(path)
        self.report = report or StorageReport()
        self.append = header is None
        self.records = records  # records accepted (on disk or pending)
        self.records_written = records  # records wholly handed to the kernel
        self._pending: list[bytes] = [] if header is None else [record_line(header)]
        self._pending_records: list[int] = [] if header is None else [0]
        self._pending_bytes = sum(map(len, self._pending))
        self._offset = 0  # bytes of _pending[0] already written
        self.dropped = 0  # records dropped because memory ran out (counted, reported)
        self._fd: int | None = None
        self._next_retry = 0.0
        self._last_sync = time.monotonic()
        self._open()

    # -- file ------------------------------------------------------------------
    def _open(self) -> bool:
        flags = os.O_WRONLY | os.O_APPEND | os.O_CLOEXEC
        if not self.append:
            flags |= os.O_CREAT | os.O_EXCL  # never overwrite a log
        try:
            self._fd = os.open(self.path, flags, 0o600)
        except FileExistsError:
            if self._next_retry == 0.0:  # at start: the caller picked this name
                raise
            # Someone made the file while we waited for the disk: use another name.
            self.path = free_path(self.path)
            log.warning("session log goes to %s instead", self.path)
            return self._open()
        except OSError as exc:
            self.report.failed(f"session log {self.path}", exc)
            self._next_retry = time.monotonic() + RETRY_S
            return False
        return True

    @property
    def pending_bytes(self) -> int:
        return self._pending_bytes - self._offset

    @property
    def healthy(self) -> bool:
        """Everything accepted is on disk (in the kernel) and the file is open."""
        return self._fd is not None and not self._pending

    # -- records -----------------------------------------------------------------
    def write(self, record: PenSample | Command) -> None:
        line = record_line(record)
        if self._pending_bytes + len(line) > MAX_PENDING_BYTES:
            self.dropped += 1
            self.report.failed(f"session log {self.path} (memory full: records dropped)",
                               OSError(errno.ENOMEM, "pending records exceed 256 MiB"))
            return
        self.records += 1
        self._pending.append(line)
        self._pending_records.append(1)
        self._pending_bytes += len(line)

    def flush(self) -> bool:
        """Hand pending records to the kernel; ``True`` when nothing is pending."""
        if not self._pending:
            return True
        if self._fd is None and (time.monotonic() < self._next_retry or not self._open()):
            return False
        assert self._fd is not None
        data = b"".join(self._pending)
        try:
            written = write_all(self._fd, memoryview(data)[self._offset:])
        except PartialWrite as exc:
            self._consume(self._offset + exc.written)
            self.report.failed(f"session log {self.path}", exc)
            return False
        self._consume(self._offset + written)
        self.report.recovered(f"session log {self.path}")
        return True

    def _consume(self, nbytes: int) -> None:
        """Drop the first ``nbytes`` of the pending data (written)."""
        while self._pending and nbytes >= len(self._pending[0]):
            line = self._pending.pop(0)
            nbytes -= len(line)
            self._pending_bytes -= len(line)
            self.records_written += self._pending_records.pop(0)
        self._offset = nbytes

    def sync(self) -> bool:
        """Flush and fsync; ``True`` when every accepted record is durable."""
        ok = self.flush()
        if self._fd is not None:
            try:
                os.fsync(self._fd)
            except OSError as exc:
                self.report.failed(f"session log {self.path}", exc)
                ok = False
        self._last_sync = time.monotonic()
        return ok

    def sync_due(self, every: float = 1.0) -> bool:
        """Whether the last fsync is ``every`` seconds old."""
        return time.monotonic() - self._last_sync >= every

    def fsync_flushed(self) -> bool:
        """fsync what was handed to the kernel, without handing more: a host may run it
        beside the thread that appends records (the kiosk: its simulation thread, without
        the lock the window's records need; an fsync took the window's frame with it)."""
        fd = self._fd
        self._last_sync = time.monotonic()
        if fd is None:
            return False
        try:
            os.fsync(fd)
        except OSError as exc:
            self.report.failed(f"session log {self.path}", exc)
            return False
        return True

    def maybe_sync(self, every: float = 1.0) -> None:
        """Flush now, fsync when the last one is ``every`` seconds old."""
        if time.monotonic() - self._last_sync >= every:
            self.sync()
        else:
            self.flush()

    def size(self) -> int:
        """Bytes of the log file handed to the kernel so far."""
        try:
            return self.path.stat().st_size
        except OSError:
            return 0

    def close(self) -> None:
        self.sync()
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
        if self._pending:
            log.error("session log %s: %d bytes could not be written", self.path,
                      self.pending_bytes)
