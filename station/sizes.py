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
