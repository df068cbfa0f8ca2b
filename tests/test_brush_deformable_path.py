"""Issue 21 item 8: a deformable brush pulled along a straight pen path paints a stroke that
follows it, without one-cell whiskers at its edges (measured on the brush's deposit)."""

from __future__ import annotations

import numpy as np
import pytest

import station.sim.player as player
from station.backends.numpy_canvas import NumpyCanvas
from station.backends.protocol import CanvasBackend
from station.brush.footprint import prune_spurs
from station.brush.sources import Sources
from station.sim.script import Script

W, H = 200, 64


def _deposit(kind: str, monkeypatch: pytest.MonkeyPatch) -> np.ndarray:
    """Pigment the brush lays for a size-24 loaded stroke pulled right in 1.2 s."""
    got = np.zeros((H, W))
    add = player.add_sources

    def grab(backend: CanvasBackend, src: Sources) -> None:
        for v in src.dp.values():
            got[src.region] += v
        add(backend, src)

    monkeypatch.setattr(player, "add_sources", grab)
    s = Script(W, H, seed=7, rate_hz=120.0)
    s.brush(size=24, water=0.8, pigment={"French Ultramarine": 1.0}, kind=kind)
    s.line((0.1, 0.5), (0.9, 0.5), 1.2, pressure=0.8)
    c = NumpyCanvas(W, H, seed=7)
    player.SessionPlayer(c, W, H).play(s.records)
    return got


def _whiskers(painted: np.ndarray) -> tuple[int, int]:
    """(edge cells, one-cell protrusions: painted cells with at most one painted
    4-neighbour)."""
    pad = np.pad(painted, 1)
    nb = pad[:-2, 1:-1].astype(int) + pad[2:, 1:-1] + pad[1:-1, :-2] + pad[1:-1, 2:]
    return int((painted & (nb < 4)).sum()), int((painted & (nb <= 1)).sum())


@pytest.mark.parametrize("kind", ["round3d", "mop"])
def test_a_deformable_stroke_follows_the_pen_without_whiskers(
        kind: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """round3d: 8.0 whiskers per 100 edge cells before a loaded tuft's lone hair tips
    joined their neighbours, 0.5 after; mop 3.5 -> 0. The stroke's middle stays on the
    pen's line within a cell in every column."""
    dep = _deposit(kind, monkeypatch)
    painted = dep > 0.0
    edge, whiskers = _whiskers(painted)
    assert whiskers <= 0.01 * edge, (whiskers, edge)
    mid = []
    for x in range(30, 160):  # the tuft trails the pen by up to a tuft length
        ys = np.nonzero(painted[:, x])[0]
        assert len(ys), x
        mid.append(0.5 * (ys[0] + ys[-1] + 1))
    assert np.abs(np.array(mid) - 0.5 * H).max() <= 1.0


def test_prune_spurs_clears_one_cell_protrusions_only() -> None:
    a = np.zeros((14, 14), np.float32)
    a[3:11, 3:11] = 1.0  # a body
    a[2, 6] = 0.5  # a one-cell whisker on its top edge
    a[11:13, 5] = 0.7  # a two-cell spur below it
    a[0:2, 12:14] = 0.3  # a 2x2 blob touching nothing: every cell has two neighbours
    out = prune_spurs(a)
    assert out[3:11, 3:11].min() == 1.0
    assert out[2, 6] == 0.0 and out[11:13, 5].max() == 0.0
    assert (out[0:2, 12:14] == np.float32(0.3)).all()
    assert out.dtype == a.dtype
    line = np.zeros((5, 9), np.float32)
    line[2, 1:8] = 1.0  # a rigger's one-cell line is the stroke, not a whisker
    assert (prune_spurs(line) == line).all()
    assert out.dtype == a.dtype
