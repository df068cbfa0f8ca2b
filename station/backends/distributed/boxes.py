"""The dirty-tile boxes of ``tiles.active_regions``, found in a few array sweeps.

Every rank of a distributed canvas computes the boxes of the whole canvas each step
(they are replicated metadata), so their cost is not divided among the ranks: the
sweeps of ``tiles._components`` (one tile of propagation each, a group's diameter of
them) take about a tenth of a 4096² corner-stroke step, which capped the speedup of a
small painted region. Here each sweep is followed by pointer jumping (a label is the
flat index + 1 of a tile of the same group, so ``label -> label of that tile`` halves
the distance still to go), which needs about log2(diameter) sweeps. The fixed point
is the same as ``_components``' (every tile labelled with its group's largest flat
index + 1), and the groups are merged exactly as ``tiles.active_regions`` merges them,
in the same order, so the boxes are identical
(``tests/test_distributed.py::test_fast_boxes_are_the_tiles_boxes``). (``scipy.ndimage
.label`` would do too, but importing it costs ``station sim --distributed`` half a
second at start, while pen samples already arrive.)
"""

from __future__ import annotations

import numpy as np

from station.canvas.state import CanvasState
from station.canvas.tiles import HALO, merge_boxes


def labels(active: np.ndarray) -> np.ndarray:
    """Labels (largest flat index + 1 of the group; 0 = inactive) of the 8-connected
    groups of ``active`` tiles (``tiles._components``' labels)."""
    ny, nx = active.shape
    lab = np.where(active, np.arange(1, ny * nx + 1).reshape(ny, nx), 0)
    while True:
        pad = np.pad(lab, 1)
        best = lab.copy()
        for dy in (0, 1, 2):
            for dx in (0, 1, 2):
                np.maximum(best, pad[dy:dy + ny, dx:dx + nx], out=best)
        best = np.where(active, best, 0)
        flat = best.ravel()
        while True:  # pointer jumping: take the label of the tile the label names
            jumped = np.where(flat > 0, flat[np.maximum(flat, 1) - 1], 0)
            if np.array_equal(jumped, flat):
                break
            flat = jumped
        best = flat.reshape(ny, nx)
        if np.array_equal(best, lab):
            return lab
        lab = best


def active_regions(state: CanvasState) -> list[tuple[slice, slice]]:
    """``tiles.active_regions(state)``: disjoint cell boxes of the active tile groups."""
    active = state.tile_ttl > 0
    if not active.any():
        return []
    ts = int(state.params.tile_size)
    lab = labels(active)
    ty, tx = np.nonzero(active)
    groups = lab[ty, tx]
    order = np.argsort(groups, kind="stable")
    g, ty, tx = groups[order], ty[order], tx[order]
    starts = np.flatnonzero(np.r_[True, g[1:] != g[:-1]])  # groups by label, ascending
    y0, y1 = np.minimum.reduceat(ty, starts), np.maximum.reduceat(ty, starts)
    x0, x1 = np.minimum.reduceat(tx, starts), np.maximum.reduceat(tx, starts)
    boxes = [(max(int(a) * ts - HALO, 0), min((int(b) + 1) * ts + HALO, state.height),
              max(int(c) * ts - HALO, 0), min((int(d) + 1) * ts + HALO, state.width))
             for a, b, c, d in zip(y0, y1, x0, x1, strict=True)]
    return [(slice(b[0], b[1]), slice(b[2], b[3])) for b in sorted(merge_boxes(boxes))]
