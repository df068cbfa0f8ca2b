"""The selective eraser (seed 8.4.4): removes a chosen fraction of chosen fields under a
soft footprint, skipping the cells the previous dab of the same stroke hit (so a slow
stroke does not erase a cell over and over).

Fields are ``"w"`` (fluid water), ``"wc"`` (capillary water), ``"p:<pigment>"`` (that
pigment suspended in the fluid layer) and ``"q:<pigment>"`` (deposited on the surface);
``"p:*"`` / ``"q:*"`` mean every pigment of the layer. Everything removed is booked
(``removed_w``, ``removed_p``), so the balance in the stats still closes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from station.arttools.footprint import F32, check, soft, window
from station.canvas.errors import CanvasInputError
from station.canvas.state import CanvasState

FIELDS = ("w", "wc", "p", "q")


@dataclass(frozen=True)
class Eraser:
    """fields: what it erases (see module docstring); fraction: share removed at the
    footprint's centre at full pressure [1]; radius [cells]."""

    fields: tuple[str, ...] = ("p:*", "q:*")
    fraction: float = 0.5
    radius: float = 8.0

    def __post_init__(self) -> None:
        check("fraction", self.fraction, 0.0, 1.0, "eraser")
        check("radius", self.radius, 0.5, 512.0, "eraser")
        if not self.fields:
            raise CanvasInputError("eraser needs at least one field", "eraser")
        for f in self.fields:
            kind = f.split(":", 1)[0]
            if not isinstance(f, str) or kind not in FIELDS or (kind in ("p", "q")) != (":" in f):
                raise CanvasInputError(
                    f"eraser field {f!r} must be w, wc, p:<pigment> or q:<pigment>", "eraser")


def erase(state: CanvasState, er: Eraser, cx: float, cy: float, pressure: float = 1.0,
          previous: np.ndarray | None = None) -> np.ndarray:
    """One dab at (cx, cy) [cells]; returns the canvas-sized bool map of the cells it hit
    (pass it as ``previous`` to the next dab of the stroke). Pigments not in the active
    layer are skipped (there is nothing of them to erase)."""
    hit = np.zeros((state.height, state.width), bool)
    win = window(state, cx, cy, er.radius)
    if win is None:
        return hit
    ys, xs, d2 = win
    share = soft(d2, er.radius) * F32(er.fraction * min(max(pressure, 0.0), 1.0))
    if previous is not None:
        share = np.where(previous[ys, xs], F32(0), share)
    hit[ys, xs] = share > 0
    for f in er.fields:
        kind, _, name = f.partition(":")
        if kind == "w":
            take = state.w[ys, xs] * share
            state.w[ys, xs] -= take
            state.removed_w[ys, xs] += take
        elif kind == "wc":
            take = state.wc[ys, xs] * share
            state.wc[ys, xs] -= take
            state.removed_w[ys, xs] += take
            # paper dried out: no wet phase left there (pass 10's rule for wet_area)
            area = state.wet_area[ys, xs]
            state.wet_area[ys, xs] = np.where(state.wc[ys, xs] > 0, area, F32(0))
        else:
            arr = state.p if kind == "p" else state.q
            if name == "*":
                slots = list(range(len(state.slots)))
            else:
                pig = state.palette.get(name).name  # unknown name: bad input
                slots = [state.slots.index(pig)] if pig in state.slots else []
            for k in slots:
                take = arr[k, ys, xs] * share
                arr[k, ys, xs] -= take
                state.removed_p[k, ys, xs] += take
    return hit
