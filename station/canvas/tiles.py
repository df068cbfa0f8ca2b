"""Dirty tiles with time-to-live (seed 6.2.2).

The canvas is covered by square tiles (``params.tile_size``, 32 by default).
A tile is *active* while its time-to-live ``state.tile_ttl`` is > 0. Touching
cells (sources, tools) sets the TTL of their tiles to an estimate of the drying
time (``SimParams.tile_ttl_steps``). After each step active TTLs count down; a
tile whose TTL reached 0 (or a halo tile) that still holds fluid or capillary
water is renewed, so a tile leaves the active set only when all its cells are
inactive (``w == 0`` and ``wc == 0``), and a quiet tile that receives capillary
water through the one-cell halo joins the active set.

The simulated regions are the bounding boxes of the 8-connected groups of
active tiles, each grown by a one-cell halo (overlapping boxes merged). Every
cell outside the active tiles is inactive and no pass changes an inactive cell
whose neighbours are inactive, so tiling on/off gives the same result (see
``reference.py``).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from station.canvas.state import CanvasState

HALO = 2
"""Cells simulated around the active tiles. Two, not one: a dry cell next to a wet one can
join the wet area (the advancing contact line), receive fluid water, absorb it and pass
capillary water one cell further within the same step."""

def mark_cells(state: CanvasState, y0: int, y1: int, x0: int, x1: int) -> None:
    """Activate the tiles covering cells ``[y0, y1) x [x0, x1)`` (clipped)."""
    ts = int(state.params.tile_size)
    y0, x0 = max(y0, 0), max(x0, 0)
    y1, x1 = min(y1, state.height), min(x1, state.width)
    if y1 <= y0 or x1 <= x0:
        return
    ttl = state.params.tile_ttl_steps()
    view = state.tile_ttl[y0 // ts:(y1 - 1) // ts + 1, x0 // ts:(x1 - 1) // ts + 1]
    np.maximum(view, ttl, out=view)


def mark_nonzero(state: CanvasState, ys: slice, xs: slice, values: np.ndarray) -> None:
    """Activate the tiles in which ``values`` (placed at canvas cells ys, xs) is nonzero."""
    nz = values != 0
    if not nz.any():
        return
    rows = np.nonzero(nz.any(axis=1))[0]
    cols = np.nonzero(nz.any(axis=0))[0]
    ts = int(state.params.tile_size)
    ty = np.unique((rows + ys.start) // ts)
    tx = np.unique((cols + xs.start) // ts)
    # exact per-tile test within the bounding tiles
    ttl = state.params.tile_ttl_steps()
    for t_y in ty:
        r0, r1 = max(t_y * ts - ys.start, 0), min((t_y + 1) * ts - ys.start, nz.shape[0])
        band = nz[r0:r1]
        for t_x in tx:
            c0, c1 = max(t_x * ts - xs.start, 0), min((t_x + 1) * ts - xs.start, nz.shape[1])
            if band[:, c0:c1].any():
                state.tile_ttl[t_y, t_x] = max(int(state.tile_ttl[t_y, t_x]), ttl)


def active_region(state: CanvasState) -> tuple[slice, slice] | None:
    """Bounding box (cells) of the active tiles plus the ``HALO``-cell halo, or None."""
    ty, tx = np.nonzero(state.tile_ttl > 0)
    if ty.size == 0:
        return None
    ts = int(state.params.tile_size)
    y0 = max(int(ty.min()) * ts - HALO, 0)
    y1 = min((int(ty.max()) + 1) * ts + HALO, state.height)
    x0 = max(int(tx.min()) * ts - HALO, 0)
    x1 = min((int(tx.max()) + 1) * ts + HALO, state.width)
    return slice(y0, y1), slice(x0, x1)


def _components(active: np.ndarray) -> np.ndarray:
    """Labels (0 = inactive) of the 8-connected groups of active tiles: each group is
    labelled with 1 + the largest flat (row-major) index of its tiles, so the groups come
    in the same order for any labelling routine (``np.unique`` of the labels)."""
    ny, nx = active.shape
    lab, n = ndimage.label(active, structure=np.ones((3, 3), bool))
    if n == 0:
        return np.zeros((ny, nx), np.int64)
    flat = lab.ravel()
    top = np.zeros(n + 1, np.int64)
    np.maximum.at(top, flat, np.arange(1, ny * nx + 1))
    top[0] = 0
    out: np.ndarray = top[lab]
    return out


def _overlap(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> bool:
    return a[0] < b[1] and b[0] < a[1] and a[2] < b[3] and b[2] < a[3]


def active_regions(state: CanvasState) -> list[tuple[slice, slice]]:
    """Disjoint cell boxes to simulate: one per group of active tiles, plus the halo.

    Each 8-connected group of active tiles gives its bounding box grown by one cell;
    overlapping boxes are merged. Cells outside every box are inactive with inactive
    neighbours, and two boxes never share a cell, so simulating the boxes one after
    the other equals simulating the whole canvas.
    """
    active = state.tile_ttl > 0
    if not active.any():
        return []
    ts = int(state.params.tile_size)
    labels = _components(active)
    boxes: list[tuple[int, int, int, int]] = []
    for lab in np.unique(labels[labels > 0]):
        ty, tx = np.nonzero(labels == lab)
        boxes.append((max(int(ty.min()) * ts - HALO, 0),
                      min((int(ty.max()) + 1) * ts + HALO, state.height),
                      max(int(tx.min()) * ts - HALO, 0),
                      min((int(tx.max()) + 1) * ts + HALO, state.width)))
    return [(slice(b[0], b[1]), slice(b[2], b[3])) for b in sorted(merge_boxes(boxes))]


def merge_boxes(boxes: list[tuple[int, int, int, int]]) -> list[tuple[int, int, int, int]]:
    """Overlapping ``(y0, y1, x0, x1)`` boxes merged in place, pairwise, first pair first
    (few boxes: a plain pairwise merge; the distributed canvas finds the same boxes)."""
    merged = True
    while merged:
        merged = False
        for i in range(len(boxes)):
            for j in range(i + 1, len(boxes)):
                if _overlap(boxes[i], boxes[j]):
                    a, b = boxes[i], boxes[j]
                    boxes[i] = (min(a[0], b[0]), max(a[1], b[1]),
                                min(a[2], b[2]), max(a[3], b[3]))
                    del boxes[j]
                    merged = True
                    break
            if merged:
                break
    return boxes


def tile_alive(state: CanvasState, ys: slice, xs: slice) -> np.ndarray:
    """Per tile covering the tile-aligned region around ``ys, xs``: any w or wc > 0."""
    ts = int(state.params.tile_size)
    ty0, ty1 = ys.start // ts, -(-ys.stop // ts)
    tx0, tx1 = xs.start // ts, -(-xs.stop // ts)
    cy0, cy1 = ty0 * ts, min(ty1 * ts, state.height)
    cx0, cx1 = tx0 * ts, min(tx1 * ts, state.width)
    live = (state.w[cy0:cy1, cx0:cx1] > 0) | (state.wc[cy0:cy1, cx0:cx1] > 0)
    pad = np.zeros(((ty1 - ty0) * ts, (tx1 - tx0) * ts), bool)
    pad[:cy1 - cy0, :cx1 - cx0] = live
    out = np.asarray(pad.reshape(ty1 - ty0, ts, tx1 - tx0, ts).any(axis=(1, 3)))
    return out


def update_tiles(state: CanvasState,
                 regions: tuple[slice, slice] | list[tuple[slice, slice]] | None) -> None:
    """Count active TTLs down; renew expired or halo tiles that still hold water.

    ``regions``: the cell boxes simulated this step (one box, a list, or None).
    """
    ttl = state.tile_ttl
    np.subtract(ttl, 1, out=ttl, where=ttl > 0)
    if regions is None:
        return
    if isinstance(regions, tuple):
        regions = [regions]
    ts = int(state.params.tile_size)
    for ys, xs in regions:
        alive = tile_alive(state, ys, xs)
        ty0, tx0 = ys.start // ts, xs.start // ts
        view = ttl[ty0:ty0 + alive.shape[0], tx0:tx0 + alive.shape[1]]
        renew = alive & (view <= 0)
        view[renew] = state.params.tile_ttl_steps()


def activate_all_live(state: CanvasState) -> None:
    """Activate every tile that holds water (after loading or switching tiling on)."""
    alive = tile_alive(state, slice(0, state.height), slice(0, state.width))
    ttl = state.params.tile_ttl_steps()
    state.tile_ttl[alive & (state.tile_ttl <= 0)] = ttl
