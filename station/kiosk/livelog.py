"""The live logs of paintings in progress: which one a restarted kiosk resumes, and the
lock that keeps a second kiosk on the same gallery off it."""

from __future__ import annotations

import fcntl
import logging
import os
from pathlib import Path

from station.sim.journal import autosave_path

log = logging.getLogger(__name__)


def painting_in_progress(live_dir: Path) -> Path | None:
    """The live log of the painting a killed or restarted kiosk left in ``live_dir``, or
    ``None``: the newest log that holds a stroke (the tip down on the paper).  A log
    without one is a fresh canvas nobody painted on (an idle kiosk saves its painting
    and starts such a one): it and its autosave go, and the kiosk starts fresh."""
    logs = sorted(live_dir.glob("*.jsonl"), key=lambda p: p.stat().st_mtime, reverse=True)
    found: Path | None = None
    for path in logs:
        if _held_by_another(path):  # a kiosk beside this one paints on it (one gallery)
            continue
        if not _has_stroke(path):
            path.unlink(missing_ok=True)
            autosave_path(path).unlink(missing_ok=True)
        elif found is None:
            found = path
        else:  # an older crash's painting: kept for the operator (station paint repaints it)
            log.warning("an older painting in progress is left in %s", path)
    return found


def hold_live_log(path: Path) -> int | None:
    """An exclusive lock on a live log for as long as this kiosk paints on it (the file
    descriptor; the system lets go when the process dies, ``kill -9`` included): another
    kiosk on the same gallery neither resumes nor removes it."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_CREAT, 0o600)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        return None
    return fd


def _held_by_another(path: Path) -> bool:
    fd = hold_live_log(path)
    if fd is None:
        return path.exists()
    os.close(fd)  # closing lets the lock go
    return False


def _has_stroke(path: Path) -> bool:
    """Whether the session log at ``path`` holds a pen sample with the tip down."""
    try:
        with path.open("rb") as f:
            for line in f:
                if b'"touching": true' in line or b'"touching":true' in line:
                    return True
    except OSError:
        return False
    return False
