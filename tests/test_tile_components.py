"""``tiles._components`` (scipy labelling) against the plain max-label propagation it
replaced: the same labels, hence the same boxes in the same order."""

from __future__ import annotations

import numpy as np

from station.canvas import tiles


def _propagated(active: np.ndarray) -> np.ndarray:
    ny, nx = active.shape
    labels = np.where(active, np.arange(1, ny * nx + 1).reshape(ny, nx), 0)
    while True:
        pad = np.pad(labels, 1)
        best = labels.copy()
        for dy in (0, 1, 2):
            for dx in (0, 1, 2):
                np.maximum(best, pad[dy:dy + ny, dx:dx + nx], out=best)
        best = np.where(active, best, 0)
        if np.array_equal(best, labels):
            return labels
        labels = best


def test_components_equal_the_propagated_labels() -> None:
    rng = np.random.default_rng(0)
    groups = 0
    for _ in range(400):
        shape = (int(rng.integers(1, 20)), int(rng.integers(1, 24)))
        active = rng.random(shape) < rng.random()
        got = tiles._components(active)
        assert np.array_equal(got, _propagated(active))
        groups += len(np.unique(got[got > 0]))
    assert groups > 400  # many multi-group cases
    assert not tiles._components(np.zeros((3, 4), bool)).any()
