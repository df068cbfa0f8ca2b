"""Footprints shared by the tools: a disc of ``radius`` cells around a centre, clipped to
the canvas."""

from __future__ import annotations

import math

import numpy as np

from station.canvas.errors import CanvasInputError
from station.canvas.state import CanvasState

F32 = np.float32


def check(name: str, value: float, lo: float, hi: float, tool: str) -> float:
    """``value`` as a float when it is a finite number in [lo, hi], else bad input."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not math.isfinite(value) or not lo <= value <= hi:
        raise CanvasInputError(f"{tool} {name} {value!r:.40} must be a number in "
                               f"[{lo:g}, {hi:g}]", tool)
    return float(value)


def window(state: CanvasState, cx: float, cy: float, radius: float
           ) -> tuple[slice, slice, np.ndarray] | None:
    """Rows, columns and the squared distance [cells^2] from (cx, cy) of the cells of the
    disc's bounding box (cell centres at integer + 0.5, like the brush's)."""
    r = int(math.ceil(radius)) + 1
    y0, y1 = max(int(math.floor(cy)) - r, 0), min(int(math.floor(cy)) + r + 1, state.height)
    x0, x1 = max(int(math.floor(cx)) - r, 0), min(int(math.floor(cx)) + r + 1, state.width)
    if y1 <= y0 or x1 <= x0:
        return None
    yy = np.arange(y0, y1, dtype=np.float64)[:, None] + 0.5 - cy
    xx = np.arange(x0, x1, dtype=np.float64)[None, :] + 0.5 - cx
    return slice(y0, y1), slice(x0, x1), yy * yy + xx * xx


def soft(d2: np.ndarray, radius: float) -> np.ndarray:
    """A soft footprint: ``(1 - (d/r)^2)^2`` inside the disc, 0 outside (float32)."""
    t = np.clip(1.0 - d2 / (radius * radius), 0.0, 1.0)
    return (t * t).astype(F32)
