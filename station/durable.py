"""Files that survive crashes: all-or-nothing replacement and complete writes.

:func:`atomic_write` writes a whole file next to its destination, fsyncs it and
renames it over the old one (then fsyncs the directory), so a reader, a crash
or a full disk sees the old file or the new one, never half of either.
Everything goes through :func:`write_all` (``os.write``), the one place a
failing disk shows up as :class:`OSError` (``ENOSPC``, ``EACCES``, ``EIO``).
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path


def write_all(fd: int, data: bytes | memoryview) -> int:
    """Write ``data`` to ``fd``; returns the bytes written before an error.

    Raises :class:`PartialWrite` (an :class:`OSError` carrying ``written``) when
    the file system refuses the rest, so a caller can retry from where it stopped.
    """
    view = memoryview(data)
    done = 0
    while done < len(view):
        try:
            n = os.write(fd, view[done:])
        except OSError as exc:
            raise PartialWrite(exc.errno or 0, exc.strerror or str(exc), done) from None
        if n <= 0:
            raise PartialWrite(0, "write returned 0 bytes", done)
        done += n
    return done


class PartialWrite(OSError):
    """A write that stopped after ``written`` bytes."""

    def __init__(self, err: int, text: str, written: int) -> None:
        super().__init__(err, text)
        self.written = written


def fsync_dir(path: Path) -> None:
    """Make a rename in ``path`` durable (best effort where directories cannot sync)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def atomic_write(path: str | os.PathLike[str], data: bytes, mode: int = 0o644) -> None:
    """Replace ``path`` by ``data`` all at once (write a temporary, fsync, rename).

    On any error the temporary is removed, ``path`` is left as it was and the
    :class:`OSError` propagates.
    """
    dest = Path(path)
    tmp = dest.with_name(f".{dest.name}.tmp-{os.getpid()}")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, mode)
    try:
        try:
            write_all(fd, data)
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, dest)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    fsync_dir(dest.parent)
