"""The gallery on disk: one directory per painting, its id (its link), files
written private (0700/0600), expiry.  See :mod:`station.kiosk.gallery`."""

from __future__ import annotations

import io
import json
import os
import re
import secrets
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from station.errors import BadInput, StationError
from station.kiosk.gallery.animation import export_replay
from station.render.km import to_srgb8
from station.render.upscale import render_scaled

# so its address is its key (nobody finds a painting they were not given).  Ids of
# older galleries (24 random bits) still name their directories but are not served.
ID_RE = re.compile(r"^[0-9]{8}-[0-9]{6}-(?:[0-9a-f]{6}|[0-9a-f]{32})$")
LINK_RE = re.compile(r"^[0-9]{8}-[0-9]{6}-[0-9a-f]{32}$")
LINK_BITS = 128
PNG, LOG, META, REPLAY = "painting.png", "session.jsonl", "meta.json", "replay.webp"
PRINT = "painting-2x.png"
MAKE_LOG = "make.log"  # what `station gallery make` said (empty when all went well)
FAILED = "replay.failed"  # the replay cannot be made: why (the negative cache)
PRINT_SCALE = 2
MAKE_TIMEOUT_S = 600.0  # a replay asked for by the web page waits at most this long


class GalleryError(StationError):
    """The gallery directory cannot be used."""


def new_id(now: float | None = None) -> str:
    """A painting id: UTC time (sortable) and 128 random bits (its link cannot be
    guessed: the only way to a painting is to be given its address)."""
    stamp = time.strftime("%Y%m%d-%H%M%S", time.gmtime(time.time() if now is None else now))
    return f"{stamp}-{secrets.token_hex(LINK_BITS // 8)}"


def check_id(pid: str) -> str:
    if not isinstance(pid, str) or not ID_RE.match(pid):
        raise BadInput(f"painting id {str(pid)[:80]!r} is not of the form "
                       "YYYYMMDD-HHMMSS-<32 hex digits>")
    return pid


def _write_private(path: Path, data: bytes) -> None:
    """Write ``path`` whole (a temporary renamed over it), readable by its owner only:
    a painting and its log are a visitor's, like the session logs (0600)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.unlink(missing_ok=True)  # a stale one may carry wider bits
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    os.replace(tmp, path)


@dataclass
class Gallery:
    """Paintings under ``root`` (created 0700 if missing; one the operator made is
    used as it is)."""

    root: Path

    def __post_init__(self) -> None:
        self.root = Path(self.root)
        try:
            self.root.mkdir(mode=0o700, parents=True, exist_ok=True)
        except OSError as exc:
            raise GalleryError(f"cannot create gallery directory {self.root}: "
                               f"{exc.strerror}") from None

    def path(self, pid: str, name: str = "") -> Path:
        return self.root / check_id(pid) / name

    def save(self, pid: str, srgb8: np.ndarray, log_source: str | os.PathLike[str] | None,
             meta: dict[str, Any]) -> Path:
        """Write (or overwrite) painting ``pid``: PNG, a copy of the log, metadata; the
        directory 0700, the files 0600."""
        from PIL import Image

        d = self.path(pid)
        d.mkdir(mode=0o700, parents=True, exist_ok=True)
        buf = io.BytesIO()
        Image.fromarray(np.ascontiguousarray(srgb8, np.uint8)).save(buf, format="PNG")
        _write_private(d / PNG, buf.getvalue())
        if log_source is not None and Path(log_source).exists():
            _write_private(d / LOG, Path(log_source).read_bytes())
        for stale in (REPLAY, PRINT, FAILED):  # made from the painting before it changed
            (d / stale).unlink(missing_ok=True)
        meta = {**meta, "id": pid, "saved": time.time()}
        _write_private(d / META, json.dumps(meta, indent=1, sort_keys=True).encode())
        return d

    def meta(self, pid: str) -> dict[str, Any] | None:
        try:
            data = json.loads(self.path(pid, META).read_text())
        except (OSError, ValueError):
            return None
        return data if isinstance(data, dict) else None

    def ids(self) -> list[str]:
        """Painting ids, newest first."""
        out = [p.name for p in self.root.iterdir() if ID_RE.match(p.name) and
               (p / PNG).exists()]
        return sorted(out, reverse=True)

    def failed(self, pid: str) -> str | None:
        """Why ``pid``'s replay cannot be made (the negative cache), or None."""
        try:
            return self.path(pid, FAILED).read_text(errors="replace")[:500].strip() or "failed"
        except OSError:
            return None

    def mark_failed(self, pid: str, why: str) -> None:
        """Remember that ``pid``'s replay cannot be made, so no request tries again
        until the painting is saved anew."""
        line = (why.strip().splitlines() or ["failed"])[-1][:500]
        _write_private(self.path(pid, FAILED), (line + "\n").encode())

    def expire(self, keep_days: float, now: float | None = None) -> list[str]:
        """Delete the paintings saved more than ``keep_days`` days ago (the operator's
        retention setting); returns their ids."""
        if not (keep_days > 0 and np.isfinite(keep_days)):
            raise BadInput(f"must be a number of days > 0, not {keep_days!r}", "--keep-days")
        cutoff = (time.time() if now is None else now) - keep_days * 86400.0
        gone = []
        for pid in self.ids():
            meta = self.meta(pid) or {}
            saved = meta.get("saved")
            if not isinstance(saved, (int, float)) or not np.isfinite(saved):
                try:  # no readable time in its metadata: the PNG's
                    saved = self.path(pid, PNG).stat().st_mtime
                except OSError:
                    continue
            if saved < cutoff:
                shutil.rmtree(self.path(pid), ignore_errors=True)
                gone.append(pid)
        return gone

    def prepare(self, pid: str) -> subprocess.Popen[bytes]:
        """Start ``station gallery make`` for ``pid`` (the replay and the print) in a
        process of its own; it lowers its own priority.  Not waited for."""
        d = self.path(pid)  # a bad id raises here, before any process starts
        fd = os.open(d / MAKE_LOG, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with open(fd, "wb") as err:  # what went wrong, for the page and people
            return subprocess.Popen(
                [sys.executable, "-m", "station", "gallery", "make", "--root",
                 str(self.root), pid], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                stderr=err, start_new_session=True)

    def make(self, pid: str, frames: int = 48, width: int = 400) -> list[Path]:
        """Replay ``pid``'s log once: write its replay animation and its print; returns
        the files written."""
        log = self.path(pid, LOG)
        if not log.exists():
            raise GalleryError(f"painting {pid} has no session log to replay")
        d = self.path(pid)

        def print_png(canvas: Any, renderer: str) -> None:
            from PIL import Image


            img = to_srgb8(render_scaled(canvas.state(), renderer, PRINT_SCALE))
            buf = io.BytesIO()
            Image.fromarray(img).save(buf, format="PNG")
            _write_private(d / PRINT, buf.getvalue())

        export_replay(log, d / REPLAY, frames=frames, width=width, final=print_png)
        os.chmod(d / REPLAY, 0o600)
        return [d / REPLAY, d / PRINT]

