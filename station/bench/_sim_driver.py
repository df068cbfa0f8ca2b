"""The scenarios of ``station bench sim`` and the child that runs them for ``--baseline``.

This module imports nothing of ``station`` at module level: ``station bench sim
--baseline REV`` runs its source in child processes (``python -c``) whose ``PYTHONPATH``
points either at an extracted copy of the commit ``REV`` or at the running tree, so the
same scenario code drives both versions of the canvas and a ratio measured in one run
compares the simulations only.

Child protocol (one JSON object per line): the child prints ``{"ready": true,
"station": <path of the station package it imported>}``, then answers each request
``{"scenario": "wash" | "stroke", "width": W, "height": H, "backend": B, "warmup": N,
"steps": M}`` with ``{"steps": M, "seconds": S, "cpu_seconds": T, "cells_per_step": C}`` (``T``: the
process's CPU time, all threads) (a fresh canvas
per request, ``N`` untimed steps, then ``M`` timed steps), until stdin closes.
"""

from __future__ import annotations

import json
import math
import sys
import time
from typing import Any

import numpy as np


def pigments() -> list[str]:
    return ["French Ultramarine", "Burnt Umber"]


def wash(canvas: Any, width: int, height: int) -> None:
    """Wet the whole canvas: water, two pigments and a slow swirl of velocity."""
    rng = np.random.default_rng(7)
    dw = (0.6 + 0.2 * rng.random((height, width))).astype(np.float32)
    names = pigments()
    dp = {names[0]: (0.05 * rng.random((height, width))).astype(np.float32),
          names[1]: (0.05 * rng.random((height, width))).astype(np.float32)}
    yy, xx = np.mgrid[0:height, 0:width].astype(np.float32)
    dvx = (6.0 * np.sin(yy * 2 * np.pi / height)).astype(np.float32)
    dvy = (6.0 * np.cos(xx * 2 * np.pi / width)).astype(np.float32)
    canvas.add_sources(dw=dw, dp=dp, dvx=dvx, dvy=dvy)


class StrokePath:
    """One live stroke: a round footprint (radius 12 cells) moving 3 cells per step
    along a gentle wave, adding water and one pigment each step."""

    def __init__(self, canvas: Any, width: int, height: int, radius: float = 12.0,
                 speed: float = 3.0) -> None:
        self.canvas, self.width, self.height = canvas, width, height
        self.radius, self.speed = radius, speed
        self.x = 2.0 * radius
        self.pigment = pigments()[0]

    def advance(self) -> None:
        r = self.radius
        self.x += self.speed
        if self.x > self.width - 2 * r:
            self.x = 2 * r
        cy = self.height / 2 + self.height / 6 * math.sin(self.x / 60.0)
        x_lo, x_hi = int(max(0, self.x - r - 1)), int(min(self.width, self.x + r + 2))
        y_lo, y_hi = int(max(0, cy - r - 1)), int(min(self.height, cy + r + 2))
        yy, xx = np.mgrid[y_lo:y_hi, x_lo:x_hi]
        disc = ((xx + 0.5 - self.x) ** 2 + (yy + 0.5 - cy) ** 2 <= r * r).astype(np.float32)
        self.canvas.add_sources(dw=0.3 * disc, dp={self.pigment: 0.02 * disc},
                                dvx=(self.speed * 4.0) * disc, dvy=0.0 * disc,
                                y0=y_lo, x0=x_lo)


def cells_last_step(canvas: Any) -> int:
    if hasattr(canvas, "cells_last_step"):
        return int(canvas.cells_last_step())
    st = canvas.live_state
    return int(st.width * st.height)


def run_fixed(backend: str, width: int, height: int, scenario: str, warmup: int,
              steps: int) -> dict[str, Any]:
    """A fresh canvas, ``warmup`` untimed steps, then ``steps`` timed ones (the stroke
    paints before every step, timed too: it is part of a live stroke's cost)."""
    # in the function: this source also runs against older checkouts (``--baseline``),
    # whose factory lived in ``station.canvas.backend``
    try:
        from station.backends.factory import create_backend  # this tree's
    except ImportError:  # an older checkout's path (before the house of issue 23)
        from station.canvas.backend import create_backend  # type: ignore[no-redef]

    canvas = create_backend(backend, width, height, "watercolor", 1,
                            tiling=(scenario == "stroke"))
    stroke = None
    if scenario == "wash":
        wash(canvas, width, height)
    else:
        stroke = StrokePath(canvas, width, height)
    for _ in range(warmup):
        if stroke:
            stroke.advance()
        canvas.step()
    take_cells = getattr(canvas, "take_cells", None)  # GL counts its cells on the GPU
    if take_cells is not None:
        if hasattr(canvas, "sync"):
            canvas.sync()
        take_cells()
    cells = 0
    t0, c0 = time.perf_counter(), time.process_time()
    for _ in range(steps):
        if stroke:
            stroke.advance()
        canvas.step()
        if take_cells is None:
            cells += cells_last_step(canvas)
    if hasattr(canvas, "sync"):
        canvas.sync()
    if take_cells is not None:
        cells = int(take_cells())
    seconds = time.perf_counter() - t0
    cpu_seconds = max(time.process_time() - c0, 1e-9)
    if hasattr(canvas, "close"):
        canvas.close()
    return {"steps": steps, "seconds": seconds, "cpu_seconds": cpu_seconds,
            "cells_per_step": cells / max(steps, 1)}


def child_main() -> None:
    """Serve requests on stdin/stdout (see the module docstring)."""
    import station  # in the function: the PYTHONPATH of the child picks which station

    print(json.dumps({"ready": True, "station": str(station.__file__)}), flush=True)
    for line in sys.stdin:
        if not line.strip():
            continue
        req = json.loads(line)
        try:
            out = run_fixed(str(req["backend"]), int(req["width"]), int(req["height"]),
                            str(req["scenario"]), int(req["warmup"]), int(req["steps"]))
        except Exception as exc:  # reported to the parent as one line, not a traceback
            out = {"error": f"{type(exc).__name__}: {exc}"}
        print(json.dumps(out), flush=True)


if __name__ == "__main__":
    child_main()
