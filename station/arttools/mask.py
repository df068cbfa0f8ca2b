"""Masking fluid (seed 8.4.3): painted with a brush as a special medium.

Masked cells (``state.mask == 1``) take no part in the step: they are never wet, receive
no sources, no flow, no absorption and no capillary water from their neighbours, so paint
put over them leaves them exactly as they were (on paper without fluid water under the
mask, as masking fluid is used: on dry paper or dry paint). Rubbing the mask off
(:func:`rub_off`, the ``mask_remove`` command) lifts the fluid water and suspended pigment
on it with it and leaves the paper, or the dried paint under it, with the crisp edge of
the masked disc cells. :func:`overlay` shows the mask on screen as diagonal hatching.
"""

from __future__ import annotations

import numpy as np

from station.arttools.footprint import F32, window
from station.canvas import operations
from station.canvas.state import CanvasState


def paint(state: CanvasState, cx: float, cy: float, radius: float) -> int:
    """Put masking fluid on the cells whose centre lies within ``radius`` of (cx, cy)
    [cells]; returns the number of cells newly masked. A hard edge: masking fluid dries
    where it is put."""
    win = window(state, cx, cy, radius)
    if win is None:
        return 0
    ys, xs, d2 = win
    inside = d2 <= radius * radius
    before = state.mask[ys, xs]
    new = int((inside & (before == 0)).sum())
    state.mask[ys, xs] = np.where(inside, F32(1.0), before)
    return new


def rub_off(state: CanvasState) -> int:
    """Remove all masking fluid (what it held is booked as removed); cells unmasked."""
    n = int((state.mask > 0).sum())
    operations.remove_mask(state)
    return n


def overlay(rgb: np.ndarray, mask: np.ndarray, period: int = 6) -> np.ndarray:
    """``rgb`` (H, W, 3 in [0, 1]) with masked cells shown in the masking fluid's pale
    yellow-green, hatched with diagonal lines every ``period`` cells (a copy)."""
    out = np.array(rgb, dtype=F32, copy=True)
    yy, xx = np.mgrid[0:mask.shape[0], 0:mask.shape[1]]
    hatch = ((yy + xx) % period) == 0
    m = mask > 0
    tint = np.array([0.93, 0.95, 0.70], F32)
    out[m] = 0.5 * out[m] + 0.5 * tint
    out[m & hatch] = np.array([0.55, 0.60, 0.25], F32)
    return out
