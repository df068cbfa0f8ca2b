"""Issue 21 items 3 and 8: a front that creeps past its footprint into dry paper (the
demo's mountain crests, the far tree masses) dried as rectangular battlements 1-3 cells
in size. The advancing height read cell by cell from the paper height let single columns
run ahead, and the two-neighbour pinning grew them into tabs two or three cells wide with
right-angle walls. The meniscus's curvature (``SimParams.advance_curvature``,
``stencils.front_curvature``) makes a tip ahead of the front need more water and a notch
behind it less, so the edge stays rough at the paper's tooth without steps."""

from __future__ import annotations

import math

import numpy as np

from station.backends.numpy_canvas import NumpyCanvas
from station.pictures.measure import crenels
from station.sim.player import SessionPlayer
from station.sim.script import Script, taper

W, H = 80, 40


def _crest(x: float) -> float:
    return (0.36 - 0.08 * math.sin(2 * math.pi * (1.1 * x + 0.1))
            - 0.04 * math.sin(2 * math.pi * (2.6 * x + 0.3)))


def _crest_scene(seed: int) -> NumpyCanvas:
    """The demo's mountain stage, small: clear water under a crest soaked in for 2.5 s
    (damp, the paper above it dry), the crest laid wet on it, the range's body pulled down
    its slopes, blown dry. The crest's water creeps up past the footprint into drier
    paper."""
    s = Script(W, H, profile="watercolor", seed=seed, rate_hz=60.0)
    xs = [-0.02 + 1.04 * i / 8 for i in range(9)]
    s.brush(size=8.0, water=1.0, pigment={})
    y, k = -0.02, 0
    while True:
        pts = [(x, min(_crest(x) + y, 0.9)) for x in xs]
        s.curve(pts if k % 2 == 0 else pts[::-1], 0.5, pressure=taper(0.85, 0.7, 0.7))
        if all(py >= 0.9 for _, py in pts):
            break
        y += 0.1
        k += 1
    s.wait(2.5)
    s.brush(size=5.6, water=0.7, pigment={"French Ultramarine": 0.4, "Burnt Umber": 0.12,
                                          "Quinacridone Rose": 0.12})
    s.curve([(x, _crest(x)) for x in xs], 0.6, pressure=taper(0.8, 0.5, 0.5))
    s.brush(size=9.6, water=0.85, pigment={"French Ultramarine": 0.3, "Burnt Umber": 0.08,
                                           "Quinacridone Rose": 0.1})
    for k in range(7):
        x = (k + 0.5) / 7
        s.curve([(x, _crest(x) + 0.02), (x + 0.01, _crest(x) + 0.25), (x + 0.02, 0.9)], 0.4,
                pressure=taper(0.75, 0.6, 0.2))
    s.cmd("hairdryer", x=0.5, y=0.5, radius=500, seconds=8.0)
    s.wait(8.0)
    s.dry()
    c = NumpyCanvas(W, H, seed=seed, profile="watercolor")
    SessionPlayer(c, W, H).play(s.records)
    return c


def test_a_crest_crept_into_dry_paper_dries_without_battlements() -> None:
    """Before: 15 tabs and notches per 100 columns (1-3 columns wide, 2+ cells tall), 62 %
    of the edge's travel in right-angle walls of 2+ cells, on four seeds. The wall share
    is taken over two papers: one paper's few walls are a handful of columns (seeds 1 and
    2: 0.18 and 0.25 in session 13; 0.30 and 0.08 with session 14's slower absorption)."""
    walls = []
    for seed in (1, 2):
        c = _crest_scene(seed)
        q = c.live_state.q.sum(axis=0)
        m = crenels(q, slice(3, W - 3))
        assert m.per_100 <= 3.0, m
        walls.append(m.wall_share)
        # still rough at the paper's tooth: no ruler lines, no smooth vector curve
        assert m.tooth >= 0.3, m
        # the crest crept past its footprint: the front is the one under test
        assert q[:, 3:W - 3].any(axis=0).all()
        assert np.isfinite(q).all()
    assert float(np.mean(walls)) <= 0.3, walls
