"""The diffusion controller (issue 14, item 2): a written pattern steers the spread of wet
pigment, conserves it, and ages back to no blocking."""

from __future__ import annotations

import numpy as np
import pytest

from station.arttools import diffusion
from station.backends.factory import create_backend, numba_available
from station.canvas import reference as ref
from station.canvas.params import SimParams
from station.canvas.stats import canvas_stats
from station.events import Command, PenSample
from station.sim.player import SessionPlayer

W = H = 40
BLUE = "French Ultramarine"
# still water everywhere (no flow-outward edge, no evaporation): pigment moves by diffusion
STILL = SimParams(flow_outward=0.0, eps_shallow=0.0, surface_rate=0.0, nu_p=4.0,
                  block_fade=100.0)


def spread(backend: str, ctrl: diffusion.Controller | None, angle_check: bool = False
           ) -> tuple[float, float, object]:
    b = create_backend(backend, W, H, seed=1, params=STILL, tiling=False)
    b.add_sources(np.full((H, W), 0.5, np.float32))
    dot = np.zeros((H, W), np.float32)
    dot[19:21, 19:21] = 0.8
    b.add_sources(None, {BLUE: dot})
    st = b.live_state
    if ctrl is not None:
        diffusion.write(st, ctrl.field(H, W), ctrl.strength, 20.0, 20.0, 30.0)
    for _ in range(40):
        b.step()
    s = b.state()
    pig = (s.p[0] + s.q[0]).astype(np.float64)
    yy, xx = np.mgrid[0:H, 0:W] + 0.5
    m = pig.sum()
    vx = float((pig * (xx - (pig * xx).sum() / m) ** 2).sum() / m)
    vy = float((pig * (yy - (pig * yy).sum() / m) ** 2).sum() / m)
    return vx, vy, s


def test_stripes_steer_the_spread_along_the_pattern() -> None:
    vx0, vy0, _ = spread("numpy", None)
    assert 0.7 < vx0 / vy0 < 1.4  # without the controller: round
    vx, vy, s = spread("numpy", diffusion.Controller("stripes", period=4, angle=0.0))
    assert vx >= 2.0 * vy, (vx, vy)
    vx90, vy90, _ = spread("numpy", diffusion.Controller("stripes", period=4, angle=90.0))
    assert vy90 >= 2.0 * vx90
    b = canvas_stats(s, "numpy")["balance"]  # mass-conserving
    assert b["pigment_rel_error"] < 1e-5 and b["water_rel_error"] < 1e-5


def test_pattern_ages_back_to_free() -> None:
    st = create_backend("numpy", W, H, seed=1, params=SimParams(block_fade=2.0)).live_state
    ctrl = diffusion.Controller("stripes", period=4)
    n = diffusion.write(st, ctrl.field(H, W), 1.0, 20.0, 20.0, 6.0)
    assert n > 100
    beta = ref.blocking(st.h, st.block, st.block_time, st.sim_time, st.params)
    assert beta.min() == 0 and beta[0, 0] == 1  # written only under the disc
    st.sim_time += 1.0
    beta = ref.blocking(st.h, st.block, st.block_time, st.sim_time, st.params)
    assert abs(float(beta.min()) - 0.5) < 1e-6
    st.sim_time += 1.0
    assert ref.blocking(st.h, st.block, st.block_time, st.sim_time, st.params).min() == 1


@pytest.mark.skipif(not numba_available(), reason="numba missing")
def test_controller_is_bit_identical_on_the_cpu_backend() -> None:
    ctrl = diffusion.Controller("dots", period=6)
    a = spread("numpy", ctrl)[2]
    c = spread("cpu", ctrl)[2]
    assert a.p.tobytes() == c.p.tobytes() and a.q.tobytes() == c.q.tobytes()


def test_the_brush_writes_the_pattern_at_intervals_along_a_stroke() -> None:
    b = create_backend("numpy", W, H, seed=1)
    p = SessionPlayer(b, W, H)
    pen = [PenSample(t=0.1 + 0.02 * i, device="d", tool="pen", x=0.2 + 0.03 * i, y=0.5,  # type: ignore
                     pressure=0.8, touching=True) for i in range(20)]
    p.play([Command(t=0.0, cmd="diffusion", args={"pattern": "stripes", "period": 3,
                                                  "interval": 5}),
            Command(t=0.0, cmd="brush", args={"size": 6}), *pen])
    st = b.live_state
    written = st.block < 1
    assert written.any() and not written[:12].any() and not written[28:].any()
    cols = np.flatnonzero(written.any(axis=0))
    assert cols.min() >= 4 and cols.max() <= 36
    with pytest.raises(Exception, match="pattern"):
        p.play([Command(t=1.0, cmd="diffusion", args={"pattern": "zigzag"})])
