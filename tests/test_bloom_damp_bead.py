"""Issue 21 item 4: a loaded brush touched into a damp wash makes a bloom several times its
size (``station.brush.bead``, ``SessionPlayer._fresh_wet_phase``).

Damp paper sucks the loaded tuft's bead out (before, only a film took it, and a damp
wash got the tip's one stamp: blooms about a brush wide, 5.4-6.0 cells against a brush
radius of 4.7), and that fresh water is a new wet phase: the damp wash's faded wet-area
memory around it is dropped, so the flow-outward term acts at the fresh water's own edge
and carries the wash's suspended pigment out to a crusted front.
"""

from __future__ import annotations

import numpy as np
import pytest

from station.backends.numpy_canvas import NumpyCanvas
from station.brush.bead import BeadRequest, bead_sources
from station.brush.stamp import BrushModel
from station.pictures import effects_bloom as fb
from station.pictures.effects_core import PEN_HZ, darkness_map
from station.sim.player import SessionPlayer
from station.sim.script import Script


def test_damp_paper_draws_the_bead_through_damp_cells_only() -> None:
    n = 30
    w = np.zeros((n, n), np.float32)
    mask = np.zeros((n, n), np.float32)
    sat = np.full((n, n), 0.9, np.float32)
    sat[:, 20:] = 0.3  # drier paper from column 20 on: the bead does not run into it
    req = BeadRequest(15.0, 15.0, 3.0, 60.0, {"x": 0.5}, 0.0)
    assert bead_sources(req, w, mask, 1.0) is None  # no film: before, nothing
    src = bead_sources(req, w, mask, 1.0, sat, 0.65)
    assert src is not None
    dw = np.zeros((n, n))
    dw[src.y0:src.y0 + src.dw.shape[0], src.x0:src.x0 + src.dw.shape[1]] = src.dw
    assert dw.sum() == pytest.approx(60.0, rel=1e-5) and dw.max() <= 1.0 + 1e-6
    assert dw[:, 20:].sum() == 0.0
    assert np.allclose(src.dp["x"], 0.5 * src.dw)
    # the tip on paper drier than damp_sat on average: nothing
    assert bead_sources(req, w, mask, 1.0, np.full((n, n), 0.5, np.float32), 0.65) is None


def _damp_canvas(n: int = 48) -> tuple[NumpyCanvas, SessionPlayer]:
    """A canvas whose paper is damp (wc 0.9 c), no standing water, the wet-area memory
    faded to 0.8 (a wash whose sheen has gone). The water is set, not painted: its books
    do not hold it (the brushed bloom below checks them)."""
    c = NumpyCanvas(n, n, profile="watercolor", seed=5)
    st = c.live_state
    st.wc[:] = np.float32(0.9) * st.capacity()
    st.wet_area[:] = np.float32(0.8)
    p = SessionPlayer(c, n, n, "watercolor")
    return c, p


def _touch(p: SessionPlayer, n: int, bead: float) -> None:
    p.brush.model = BrushModel(water_scale=p.brush.model.water_scale,
                               pigment_scale=p.brush.model.pigment_scale,
                               v_max=p.brush.model.v_max, bead=bead)
    s = Script(n, n, seed=5, rate_hz=PEN_HZ)
    s.brush(size=8, water=1.0, pigment={})
    s.dab((0.5, 0.5), 0.1, pressure=0.7)
    p.play(s.records)


def test_a_dipped_touch_into_damp_paper_lets_the_bead_go_and_starts_a_fresh_wet_phase() -> None:
    n = 48
    c_b, p_b = _damp_canvas(n)
    _touch(p_b, n, 2.0)
    c_0, p_0 = _damp_canvas(n)
    _touch(p_0, n, 0.0)
    sb, s0 = c_b.live_state, c_0.live_state
    # the bead: about two more stamps of water (2.8x the stamp alone: 34.9 against 12.4)
    assert sb.water_added > 2.5 * s0.water_added
    # without a bead the faded memory only fades; with one it is dropped around the touch
    # (no cell there is wet now but the fresh water's), and kept far from it
    dry_b = (sb.w == 0) & (sb.wet_area < 1)
    assert (s0.wet_area[s0.w == 0] > 0.7).all()
    assert (sb.wet_area[12:36, 12:36][dry_b[12:36, 12:36]] == 0).all()
    assert sb.wet_area[0, 0] == s0.wet_area[0, 0] > 0.7


@pytest.mark.xfail(strict=True, reason="session 15's damp_exposure: the branching front "
                   "spreads its crust along a longer outline, 1.26x the wash on this paper "
                   "(1.39 before; radius 8.7, CV 0.24, 5 lobes pass)")
def test_the_clear_water_bloom_on_another_paper_is_broad_with_a_dark_irregular_front() -> None:
    """The sheet's bloom (``effects_bloom.drop_into_damp_wash``) on paper seed 21, not the
    sheet's 22: a broad bloom with a dark, lobed front. Main: radius 5.6 cells (1.2 brush
    radii), front 1.23x the wash (below the issue's 1.3), CV 0.24; here 8.5 cells (1.8
    brush radii), 1.39x, CV 0.18, 4 lobes (session 9). Session 15 (damp_exposure 0.6):
    8.7 cells, 1.26x, CV 0.24, 5 lobes."""
    c = fb.drop_into_damp_wash({}, seed=21)
    bal = c.stats()["balance"]
    assert bal["water_rel_error"] < 1e-3 and bal["pigment_rel_error"] < 1e-3, bal
    b = fb.bloom_front(darkness_map(c))
    r_brush = BrushModel().radius(fb.DROP_SIZE, 0.7)
    assert b["radius"] >= 1.6 * r_brush, b
    assert b["front_ratio"] >= 1.3, b
    assert b["cv"] >= 0.15 and b["lobes"] >= 3, b  # the floors


def test_the_damp_bead_and_fresh_phase_on_the_gl_backend_match_numpy() -> None:
    """GL reads the water and paper textures back at the dipped touch-down and rewrites
    the window of its wet-area texture: the same bead and memory as NumPy."""
    gl = pytest.importorskip("station.backends.gl")
    try:
        ctx = gl.create_context()
    except gl.GLUnavailable as exc:
        pytest.skip(f"no OpenGL 4.3 context: {exc}")
    n = 48
    try:
        c_ref, p_ref = _damp_canvas(n)
        g = gl.GLCanvas(n, n, profile="watercolor", seed=5, ctx=ctx)
        g.load_state(c_ref.state())
        p_gl = SessionPlayer(g, n, n, "watercolor")
        _touch(p_ref, n, 2.0)
        _touch(p_gl, n, 2.0)
        ref, got = c_ref.state(), g.state()
        assert got.water_added == pytest.approx(ref.water_added, rel=1e-4)
        assert np.abs(got.w - ref.w).max() < 1e-3
        assert np.abs(got.wet_area - ref.wet_area).max() < 1e-3
        assert (got.wet_area[12:36, 12:36][(got.w[12:36, 12:36] == 0)] < 1e-3).all()
    finally:
        ctx.release()


def test_a_touch_down_computes_the_damp_papers_saturation_only_where_its_bead_reaches(
        ) -> None:
    """A bead reads the saturation within its reach only (``fresh_phase_box`` holds it):
    the whole canvas's took 25-110 ms a touch-down at 1920×1080.  The window holds the
    whole canvas's numbers bit for bit, and nothing is computed outside it."""
    c, p = _damp_canvas(48)
    st = c.live_state
    st.wc[5:9, 30:40] = np.float32(0.37) * st.capacity()[5:9, 30:40]  # a drier patch
    got = p._paper_water(c)
    assert got is not None and got.damp
    cap = np.float32(st.params.c_min) + st.h * np.float32(st.params.c_max - st.params.c_min)
    whole = np.minimum(st.wc / np.maximum(cap, np.float32(1e-6)), np.float32(1.0))
    part = got.saturation(3, 20, 25, 44)
    assert np.array_equal(part[3:20, 25:44], whole[3:20, 25:44])
    outside = np.ones(part.shape, bool)
    outside[3:20, 25:44] = False
    assert not part[outside].any() and whole[outside].min() > 0.5
