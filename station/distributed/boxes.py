"""The dirty-tile boxes of ``tiles.active_regions``, labelled by ``scipy.ndimage``.

Every rank of a distributed canvas computes the boxes of the whole canvas each step
(they are replicated metadata), so their cost is not divided among the ranks: the
propagation sweeps of ``tiles._components`` take about a tenth of a 4096² corner-stroke
step, which caps the speedup of a small painted region. ``ndimage.label`` finds the
same 8-connected groups in one pass; the groups are then merged exactly as
``tiles.active_regions`` merges them, in the same order (by each group's largest flat
tile index, which is the label ``_components`` gives it), so the boxes are identical
(``tests/test_distributed.py::test_fast_boxes_are_the_tiles_boxes``).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from station.canvas.state import CanvasState
from station.canvas.tiles import HALO

EIGHT = np.ones((3, 3), bool)


def active_regions(state: CanvasState) -> list[tuple[slice, slice]]:
    """``tiles.active_regions(state)``: disjoint cell boxes of the active tile groups."""
    active = state.tile_ttl > 0
    if not active.any():
        return []
    ts = int(state.params.tile_size)
    labels, n = ndimage.label(active, structure=EIGHT)
    flat = np.arange(active.size, dtype=np.int64).reshape(active.shape)
    order = np.argsort(ndimage.maximum(flat, labels, np.arange(1, n + 1)), kind="stable")
    found = ndimage.find_objects(labels)
    boxes: list[tuple[int, int, int, int]] = []
    for k in order:
        ty, tx = found[int(k)]
        boxes.append((max(ty.start * ts - HALO, 0), min(ty.stop * ts + HALO, state.height),
                      max(tx.start * ts - HALO, 0), min(tx.stop * ts + HALO, state.width)))
    return [(slice(b[0], b[1]), slice(b[2], b[3])) for b in sorted(_merge(boxes))]


def _overlap(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> bool:
    return a[0] < b[1] and b[0] < a[1] and a[2] < b[3] and b[2] < a[3]


def _merge(boxes: list[tuple[int, int, int, int]]) -> list[tuple[int, int, int, int]]:
    """Overlapping boxes merged pairwise, first pair first (``tiles.active_regions``)."""
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
