"""Canvas sizes given as text (``WIDTHxHEIGHT``): one parser for every command that
takes one. It lives on the floor so that a driver process (``station driver --canvas``)
checks a size without loading the simulation."""

from __future__ import annotations

import re

from station.errors import BadInput

MAX_CELLS = 4096 * 4096
"""Largest canvas accepted (cells): ~16.8 M cells, a few GiB of state."""


def parse_size(text: str, where: str = "--size",
               error: type[BadInput] = BadInput) -> tuple[int, int]:
    """``"WxH"`` → ``(W, H)``; anything impossible raises ``error``."""
    m = re.fullmatch(r"\s*(\d{1,6})\s*[xX×]\s*(\d{1,6})\s*", text or "")
    if not m:
        raise error(f"canvas size {text!r} is not WIDTHxHEIGHT (e.g. 800x600)", where)
    w, h = int(m.group(1)), int(m.group(2))
    check_size(w, h, where, error)
    return w, h


def check_size(w: int, h: int, where: str, error: type[BadInput] = BadInput) -> None:
    """Refuse a canvas below 8x8 cells or above 16384 a side and :data:`MAX_CELLS`."""
    if w < 8 or h < 8:
        raise error(f"canvas size {w}x{h} is too small (at least 8x8 cells)", where)
    if w > 16384 or h > 16384 or w * h > MAX_CELLS:
        raise error(
            f"canvas size {w}x{h} is too large (at most 16384 a side and {MAX_CELLS} cells)",
            where)


# Peak memory of a painting canvas per cell, measured (station paint of a stroke and a
# wait, ru_maxrss slope between 512x512 and 1024x1024): numpy backend 805 B, cpu (numba)
# 830 B; rounded up.  A 4096x4096 canvas needs about 15 GB.
BYTES_PER_CELL = 900
MEMORY_SHARE = 0.8  # of the memory available now: the rest is the OS's, the window's, …


def available_memory() -> int | None:
    """Bytes of memory available now (``MemAvailable``), None where unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def check_memory(w: int, h: int, where: str, error: type[BadInput] = BadInput,
                 available: int | None = None) -> None:
    """Refuse a canvas larger than the memory here allows (one line giving the size and
    the memory), before anything is made."""
    avail = available_memory() if available is None else available
    need = w * h * BYTES_PER_CELL
    if avail is not None and need > MEMORY_SHARE * avail:
        most = int(MEMORY_SHARE * avail / BYTES_PER_CELL)
        side = int(most ** 0.5)
        raise error(
            f"canvas size {w}x{h} needs about {need / 1e9:.1f} GB ({BYTES_PER_CELL} B a "
            f"cell), more than {MEMORY_SHARE:.0%} of the {avail / 1e9:.1f} GB available "
            f"here: at most {most} cells (about {side}x{side})", where)
