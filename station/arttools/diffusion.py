"""The diffusion controller (seed 8.4.2): per-cell blocking values that steer the spread of
wet pigment.

The canvas already carries ``block`` (1 free ... 0 blocked) and ``block_time`` (when it
was written); pass 5 of every backend uses ``beta_c = min(1 - block_paper (1 - h),
block + (1 - block) age)``, ``age = (sim_time - block_time) / block_fade`` clamped to
[0, 1], as the conductance of each face: the paper height is mixed in through the
profile's ``block_paper``, and a written pattern ages back to no blocking in
``block_fade`` seconds. Diffusion stays exactly mass-conserving (it only scales face
fluxes). This module writes the pattern: a procedural one (``stripes``, ``rings``,
``dots``, ``checks``, of ``period`` cells, turned by ``angle``) or a drawn one (any
float array in [0, 1], 1 = blocked), under a disc, by the brush at intervals along a
stroke (see the player's ``diffusion`` command).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from station.arttools.footprint import F32, check, window
from station.canvas.errors import CanvasInputError
from station.canvas.reference import blocking
from station.canvas.state import CanvasState

PATTERNS = ("stripes", "rings", "dots", "checks")


@dataclass(frozen=True)
class Controller:
    """pattern (one of :data:`PATTERNS`); period [cells]; angle [deg] of the stripes'
    direction (paint spreads along it); strength: blocking of the pattern's lines [0, 1]
    (1: nothing crosses them); interval: brush samples between two writes [count]."""

    pattern: str = "stripes"
    period: float = 4.0
    angle: float = 0.0
    strength: float = 1.0
    interval: int = 1

    def __post_init__(self) -> None:
        if self.pattern not in PATTERNS:
            raise CanvasInputError(f"diffusion pattern {self.pattern!r} must be one of "
                                   f"{', '.join(PATTERNS)}", "diffusion")
        check("period", self.period, 2.0, 512.0, "diffusion")
        check("angle", self.angle, -360.0, 360.0, "diffusion")
        check("strength", self.strength, 0.0, 1.0, "diffusion")
        check("interval", self.interval, 1, 1000, "diffusion")

    def field(self, height: int, width: int) -> np.ndarray:
        """The pattern over the canvas, float32 (H, W) in [0, 1] (1 = a blocking line)."""
        yy, xx = np.mgrid[0:height, 0:width].astype(np.float64) + 0.5
        a = math.radians(self.angle)
        u = xx * math.cos(a) + yy * math.sin(a)  # along the stripes
        v = -xx * math.sin(a) + yy * math.cos(a)  # across them
        per = self.period
        if self.pattern == "stripes":
            line = np.floor(v) % round(per) == 0
        elif self.pattern == "rings":
            r = np.hypot(xx - width / 2.0, yy - height / 2.0)
            line = np.floor(r) % round(per) == 0
        elif self.pattern == "checks":
            line = (np.floor(v) % round(per) == 0) | (np.floor(u) % round(per) == 0)
        else:  # dots: blocked islands the paint flows around
            line = (np.hypot((u % per) - per / 2, (v % per) - per / 2) < per / 4)
        out: np.ndarray = line.astype(F32)
        return out


def write(state: CanvasState, pattern: np.ndarray, strength: float, cx: float, cy: float,
          radius: float) -> int:
    """Write ``pattern`` (canvas-sized, 1 = blocked) with ``strength`` into the cells
    within ``radius`` of (cx, cy): each gets ``block = min(what blocks it now,
    1 - strength * pattern)`` and ``block_time = sim_time`` (it ages from now). Returns
    the number of cells written."""
    if pattern.shape != (state.height, state.width):
        raise CanvasInputError("diffusion pattern has the wrong shape", "diffusion")
    win = window(state, cx, cy, radius)
    if win is None:
        return 0
    ys, xs, d2 = win
    inside = d2 <= radius * radius
    now = blocking(np.ones_like(state.h[ys, xs]), state.block[ys, xs],
                   state.block_time[ys, xs], state.sim_time,
                   state.params.replace(block_paper=0.0))
    fresh = F32(1) - F32(strength) * pattern[ys, xs]
    state.block[ys, xs] = np.where(inside, np.minimum(now, fresh), state.block[ys, xs])
    state.block_time[ys, xs] = np.where(inside, F32(state.sim_time), state.block_time[ys, xs])
    return int(inside.sum())
