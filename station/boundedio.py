"""Reading files the station is handed: regular files only, and never more than a cap.

A path on a command line or in a blueprint may name ``/dev/zero``, a FIFO, a
terminal or a 50 GB file: read whole, each is a hang or a ``MemoryError``.
:func:`read_bytes` and :func:`read_text` open without blocking (a FIFO with no
writer would block ``open`` itself), refuse anything but a regular file, and
refuse a file larger than the cap before reading it (and again if it grows
while read).  :func:`check_regular` does the same check for readers that
stream a file line by line with a line cap of their own.  Devices are opened
by their transports, never through here.

The caps are per kind of file, far above any real one (the largest bundled
blueprint, profile or calibration file is a few KiB; a point set of a long
calibration session a few MiB) and far below what would hurt the machine.
"""

from __future__ import annotations

import os
import stat

from station.errors import BadInput

KiB, MiB = 1024, 1024 * 1024
CAP_CONFIG = 4 * MiB  # blueprints, profiles, calibration files, device data, brush shapes
CAP_POINTS = 64 * MiB  # calibration point sets and tap logs (CSV)


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISCHR, "character device"), (stat.S_ISBLK, "block device"),
                       (stat.S_ISFIFO, "FIFO"), (stat.S_ISSOCK, "socket"),
                       (stat.S_ISDIR, "directory")):
        if test(mode):
            return name
    return "special file"


def _open(path: str | os.PathLike[str], what: str | None) -> tuple[int, int]:
    """An fd on a regular file and its size; OSError from open() propagates (the
    caller's own message for a missing file), BadInput for anything not a file."""
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise BadInput(f"a {_kind(st.st_mode)}, not a regular file: refusing to read it",
                           what or str(path))
        os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    return fd, st.st_size


def check_regular(path: str | os.PathLike[str], what: str | None = None) -> None:
    """Refuse (BadInput) a path that is not a regular file; OSError if it cannot be
    opened.  For readers that stream with a line cap of their own."""
    fd, _size = _open(path, what)
    os.close(fd)


def read_bytes(path: str | os.PathLike[str], cap: int = CAP_CONFIG,
               what: str | None = None) -> bytes:
    """The whole of a regular file of at most ``cap`` bytes (see the module doc)."""
    fd, size = _open(path, what)
    try:
        if size > cap:
            raise BadInput(f"{size} bytes, more than the {_human(cap)} this kind of file "
                           "may have", what or str(path))
        chunks, total = [], 0
        while True:
            chunk = os.read(fd, min(1 * MiB, cap + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > cap:
                raise BadInput(f"grew past {_human(cap)} while read", what or str(path))
        return b"".join(chunks)
    finally:
        os.close(fd)


def read_text(path: str | os.PathLike[str], cap: int = CAP_CONFIG, what: str | None = None,
              encoding: str = "utf-8", errors: str = "strict") -> str:
    """:func:`read_bytes` decoded (``UnicodeDecodeError`` propagates, like
    ``Path.read_text``)."""
    return read_bytes(path, cap, what).decode(encoding, errors)


def _human(n: int) -> str:
    return f"{n // MiB} MiB" if n >= MiB else f"{n // KiB} KiB"

