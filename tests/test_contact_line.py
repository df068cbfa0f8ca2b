"""Issue 21 item 8: a dried flat brush stroke carried one-cell whiskers (2.6 per 100 edge
cells) in cells the brush never touched. A lone cell of high paper past the stroke's
straight wet edge took the water (the contact line creeps where the paper lets it), and the
outward flow filled that dead end with pigment to the brim (q exactly 1.0 once dry). On dry
paper a front now advances only with a neighbour beside it (``stencils.pinned``)."""

from __future__ import annotations

import numpy as np

import station.sim.player as player
from station.backends.numpy_canvas import NumpyCanvas
from station.canvas import stencils
from station.canvas.paper import make_paper
from station.canvas.params import SimParams
from station.canvas.profiles import get_profile
from station.pictures.scenarios import run_until_dry
from station.sim.script import Script


def _edge(h: np.ndarray, prm: SimParams, wc: np.ndarray | None = None) -> np.ndarray:
    """The wet mask of a 9x12 sheet whose rows 5.. stand in water 0.6 deep (a straight
    edge along row 5), on paper ``h``."""
    w = np.zeros((9, 12), np.float32)
    w[5:] = 0.6
    wc = np.zeros_like(w) if wc is None else wc
    return stencils.wet_mask(w, wc, np.zeros_like(w), prm, h)


def test_a_front_on_dry_paper_does_not_send_out_one_cell_fingers() -> None:
    prm = SimParams(advance_height=0.7, damp_sat=0.65)
    h = np.full((9, 12), 0.2, np.float32)  # low paper: the edge holds (0.7 * 1.3 > 0.6)
    h[4, 3] = 0.9  # one cell of high paper past the edge: 0.7 * 0.6 < 0.6
    h[4, 7:9] = 0.9  # ... and two side by side
    wet = _edge(h, prm)
    assert not wet[4, 3]  # a lone cell: the meniscus would bend over one cell
    assert wet[4, 7] and wet[4, 8]  # a tongue two cells wide creeps on
    assert not wet[:4].any() and wet[5:].all()
    # on damp paper (past damp_sat) the front runs on in the capillary film, fingers and
    # all (a bloom's): the lone cell joins
    cap = stencils.capacity(h, prm)
    assert _edge(h, prm, wc=(0.8 * cap).astype(np.float32))[4, 3]


def test_a_dried_flat_stroke_has_no_whiskers() -> None:
    """The flat brush pulled right, loaded, on the watercolor profile, dried: one-cell
    protrusions of its pigment (cells with at most one painted 4-neighbour) per 100 edge
    cells. 2.6 (10 of 381, each q = 1.0, raw deposit 0) before the front was pinned."""
    w_, h_ = 200, 64
    s = Script(w_, h_, seed=7, rate_hz=120.0)
    s.brush(size=24, water=0.8, pigment={"French Ultramarine": 1.0}, kind="flat")
    s.line((0.1, 0.5), (0.9, 0.5), 1.2, pressure=0.8)
    c = NumpyCanvas(w_, h_, seed=7)
    player.SessionPlayer(c, w_, h_).play(s.records)
    run_until_dry(c, 6000)
    c.dry()
    painted = c.live_state.q.sum(axis=0) > 1e-4
    pad = np.pad(painted, 1)
    nb = pad[:-2, 1:-1].astype(int) + pad[2:, 1:-1] + pad[1:-1, :-2] + pad[1:-1, 2:]
    edge, whiskers = int((painted & (nb < 4)).sum()), int((painted & (nb <= 1)).sum())
    assert edge > 300
    assert whiskers <= 0.01 * edge, (whiskers, edge)


def test_a_front_crept_into_damp_paper_does_not_trace_the_papers_blobs() -> None:
    """The demo's crests crept into damp paper in whole-cell battlements (session 9): the
    advancing height ``advance_height (1.5 - h)`` read the paper height cell by cell, so on
    cold-press paper (height blobs several cells across) a straight edge crept on over the
    low blobs and stopped at the high ones. Watercolor's ``advance_grain`` 0 sets the same
    height on every damp cell: at one saturation the edge moves as a line (here: not at
    all). Dry paper keeps ``1.5 - h``."""
    prof = get_profile("watercolor")
    prm = prof.params
    assert prm.advance_grain == 0.0
    h = make_paper("cold-press", 9, 200, 11)
    cap = stencils.capacity(h, prm)
    # the water 0.45 deep, the paper past the edge 66 % full (just damp): each row-4 cell
    # joins when 0.45 > 0.7 * (the grain's height term) * the damp factor
    wc = (0.66 * cap).astype(np.float32)
    w = np.zeros((9, 200), np.float32)
    w[5:] = 0.45
    joined = stencils.wet_mask(w, wc, np.zeros_like(w), prm, h)[4]
    old = stencils.wet_mask(w, wc, np.zeros_like(w), prm.replace(advance_grain=1.0), h)[4]
    # the old rule: the row breaks into runs of joined and pinned cells (the battlements)
    runs_old = int(np.count_nonzero(np.diff(old.astype(np.int8))))
    assert 0.1 < old.mean() < 0.9 and runs_old >= 20, (old.mean(), runs_old)
    # now: the whole row either joins or holds
    assert joined.all() or not joined.any(), joined.mean()
    # on drier paper the meniscus still pins on the paper's relief: a wet-on-dry edge keeps
    # following the tooth (the rule and its pattern are the old ones)
    w[5:] = 0.6
    dry = (0.5 * cap).astype(np.float32)
    ragged = stencils.wet_mask(w, dry, np.zeros_like(w), prm, h)[4]
    assert np.array_equal(ragged, stencils.wet_mask(w, dry, np.zeros_like(w),
                                                    prm.replace(advance_grain=1.0), h)[4])
    assert int(np.count_nonzero(np.diff(ragged.astype(np.int8)))) >= 10
