"""Issue 21 item 4 through the brush: water touched into a damp wash makes a bloom.

A brushed Ultramarine wash is left until no standing water remains in its middle (the
paper still damp); the round brush then touches clear water into it. Before the backrun
physics (``damp_ease``, ``suspend_sat``) the damp wash had deposited all its pigment and
its damp cells counted as wet, so the water spread without a front: no bloom at all.
"""

from __future__ import annotations

import numpy as np

from station.brush.stamp import BrushModel
from station.pictures import effects_bloom as fb
from station.pictures.effects_core import darkness_map
from station.pictures.scenarios import run_until_dry


def test_clear_water_in_a_damp_wash_pushes_the_pigment_to_a_dark_irregular_front() -> None:
    c, p = fb.damp_wash()
    st = c.live_state
    k = st.slots.index(fb.WASH_PIGMENT)
    inner = (slice(20, 60), slice(20, 60))
    assert not (st.w[inner] > 0).any()  # no standing water left ...
    assert (st.wc[inner] > 0.5 * st.capacity()[inner]).all()  # ... the paper still damp
    # damp paper keeps the wash's pigment in suspension: it can still be moved
    assert st.p[k][inner].sum() > 0.3 * (st.p[k] + st.q[k])[inner].sum()
    drop = fb._later(p, fb.N, fb.N, 22)
    drop.brush(size=fb.DROP_SIZE, water=1.0, pigment={})
    drop.dab((0.5, 0.5), fb.DROP_S, pressure=0.7)
    p.play(drop.records)
    run_until_dry(c, 6000)
    c.dry()
    bal = c.stats()["balance"]
    assert bal["water_rel_error"] < 1e-3 and bal["pigment_rel_error"] < 1e-3, bal
    amount = st.q[k] + st.p[k]
    b = fb.bloom_front(amount)
    r_brush = BrushModel().radius(fb.DROP_SIZE, 0.7)
    assert b["radius"] >= r_brush, b  # the water ran on into the damp wash
    # and carried the wash's pigment to its front: 1.50 with lift_gain 5 (lift7), 1.35 without,
    # 1.37 with 4 Jacobi sweeps (main before the backrun physics: no front at all)
    assert b["front_ratio"] >= 1.3, b
    assert b["cv"] >= 0.12, b  # along an outline the paper shaped, not a circle
    centre = amount[36:44, 36:44].mean() / np.median(amount[8:72, 8:72])
    assert centre < 0.85  # the bloom's heart is paler than the wash
    # as a painter sees it, in darkness: 1.327 (CV 0.163, 7 lobes) with the returning water
    # lifting settled pigment 5x faster than it settled (lift_gain 5, lift7); 1.252 (CV 0.23)
    # without (main before lift7), 1.222 with paper damp from 70 % full; the floors
    seen = fb.bloom_front(darkness_map(c))
    assert seen["front_ratio"] >= 1.3, seen
    assert seen["cv"] >= 0.15 and seen["lobes"] >= 3, seen  # irregular, branching
    # a loaded brush touched into damp paper lets its bead go, a fresh wet phase (session
    # 9): 7.85 cells, 1.67 brush radii (main: 5.36, about a brush wide)
    assert seen["radius"] >= 1.5 * r_brush, seen
