"""Small painting scenarios on a backend: footprints, strokes, washes, running to dry.

Used by the tests (effects measured with numbers) and handy for benchmarks. All
footprints are float32 (H, W) arrays in {0, 1}; nothing here paints an effect:
it only adds water/pigment sources and steps the simulation.
"""

from __future__ import annotations

import numpy as np

from station.backends.protocol import CanvasBackend

F32 = np.float32


def disc(height: int, width: int, cy: float, cx: float, radius: float) -> np.ndarray:
    """Cells whose centre lies within ``radius`` of (cy, cx) (cell-index coordinates)."""
    yy, xx = np.mgrid[0:height, 0:width]
    out: np.ndarray = (((yy - cy) ** 2 + (xx - cx) ** 2) <= radius * radius).astype(F32)
    return out


def rect(height: int, width: int, y0: int, y1: int, x0: int, x1: int) -> np.ndarray:
    """Cells of rows [y0, y1) and columns [x0, x1)."""
    out = np.zeros((height, width), F32)
    out[y0:y1, x0:x1] = 1
    return out


def distance_inside(fp: np.ndarray) -> np.ndarray:
    """Chessboard distance (in cells) of each footprint cell to the nearest cell outside.

    1 on the footprint's outermost ring, 2 on the next, ...; 0 outside.
    """
    inside = fp > 0
    dist = np.zeros(fp.shape, np.int32)
    cur = inside.copy()
    k = 0
    while cur.any():
        k += 1
        dist[cur] = k
        pad = np.pad(cur, 1, constant_values=False)
        nxt = cur.copy()
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                nxt &= pad[1 + dy:1 + dy + fp.shape[0], 1 + dx:1 + dx + fp.shape[1]]
        cur = nxt
    return dist


def paint(canvas: CanvasBackend, fp: np.ndarray, water: float,
          pigments: dict[str, float] | None = None, vx: float = 0.0, vy: float = 0.0) -> None:
    """One application of sources over footprint ``fp``."""
    canvas.add_sources(
        dw=fp * F32(water),
        dp={k: fp * F32(v) for k, v in (pigments or {}).items()},
        dvx=fp * F32(vx) if vx else None,
        dvy=fp * F32(vy) if vy else None,
    )


def run_until_dry(canvas: CanvasBackend, max_steps: int = 5000) -> int:
    """Step until no fluid water is left (or ``max_steps``); returns the steps taken."""
    n = 0
    while n < max_steps:
        st = getattr(canvas, "live_state", None) or canvas.state()
        if not (st.w > 0).any():
            break
        canvas.step()
        n += 1
    return n
