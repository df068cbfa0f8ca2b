"""Canvas tilt (issue 14, item 8): gravity in pass 3 of all three backends."""

from __future__ import annotations

import numpy as np
import pytest

from station.backends.factory import create_backend, numba_available
from station.canvas import reference as ref
from station.canvas.params import SimParams
from station.canvas.stats import canvas_stats

W, H = 40, 48
TILTED = SimParams(tilt=30.0, tilt_direction=90.0)


def paint_blob(b) -> None:
    yy, xx = np.mgrid[0:12, 0:12]
    disc = (((yy - 5.5) ** 2 + (xx - 5.5) ** 2) <= 30).astype(np.float32)
    b.add_sources(0.8 * disc, {"French Ultramarine": 0.3 * disc}, y0=6, x0=14)


def run(backend: str, prm: SimParams, steps: int = 45):
    b = create_backend(backend, W, H, "watercolor", seed=4, params=prm)
    paint_blob(b)
    for _ in range(steps):
        b.step()
    return b


def centroid_y(a: np.ndarray) -> float:
    ys = np.arange(a.shape[-2], dtype=np.float64)[:, None]
    return float((a * ys).sum() / a.sum())


def test_tilt_moves_paint_downhill_and_conserves_mass() -> None:
    flat = run("numpy", SimParams()).state()
    tilted = run("numpy", TILTED).state()
    pig_flat = flat.p[0] + flat.q[0]
    pig_tilt = tilted.p[0] + tilted.q[0]
    water_flat = flat.w + flat.wc
    water_tilt = tilted.w + tilted.wc
    # the paint's centre of mass moved down the slope (+y), not sideways
    assert centroid_y(pig_tilt) > centroid_y(pig_flat) + 1.5
    assert centroid_y(water_tilt) > centroid_y(water_flat) + 1.5
    xs = np.arange(W, dtype=np.float64)
    cx = float((pig_tilt.sum(axis=0) * xs).sum() / pig_tilt.sum())
    assert abs(cx - 19.5) < 0.5
    # the runs leave the footprint: paint below where it was put
    assert pig_tilt[18:].sum() > 5 * max(pig_flat[18:].sum(), 1e-3)
    st = canvas_stats(tilted, "numpy")
    assert st["balance"]["water_rel_error"] < 1e-5 and st["balance"]["pigment_rel_error"] < 1e-5


def test_tilt_direction_turns_the_flow() -> None:
    right = run("numpy", SimParams(tilt=30.0, tilt_direction=0.0)).state()
    xs = np.arange(W, dtype=np.float64)
    pig = right.p[0] + right.q[0]
    assert float((pig.sum(axis=0) * xs).sum() / pig.sum()) > 19.5 + 1.5
    with pytest.raises(Exception, match="tilt"):
        SimParams(tilt=95.0)


def test_pass3_adds_gravity_only_on_wet_cells() -> None:
    wet = np.zeros((6, 6), bool)
    wet[1:5, 1:5] = True
    z = np.zeros((6, 6), np.float32)
    w = np.where(wet, np.float32(0.5), z)
    vx, vy = ref.water_height_and_boundary(z, z, w, wet, TILTED, TILTED.dt)
    kick = ref.tilt_kick(TILTED, TILTED.dt)[1]
    assert abs(kick - 100.0 * 0.5 * TILTED.dt) < 1e-6  # g sin(30 deg) dt, straight down
    assert np.all(vy[2:4, 1:5] == kick)  # interior wet cells
    assert np.all(vy[4, 1:5] == 0)  # the downhill edge: no flow into dry cells
    assert np.all(vy[~wet] == 0) and np.all(vx == 0)


@pytest.mark.skipif(not numba_available(), reason="numba missing")
def test_cpu_backend_is_bit_identical_with_tilt() -> None:
    prm = SimParams(tilt=40.0, tilt_direction=120.0)
    a = run("numpy", prm, 20).state()
    b = run("cpu", prm, 20).state()
    for name in ("vx", "vy", "w", "wc", "p", "q", "evaporated"):
        assert getattr(a, name).tobytes() == getattr(b, name).tobytes(), name


def test_gl_step_with_tilt_matches_reference() -> None:
    gl = pytest.importorskip("station.backends.gl")
    try:
        ctx = gl.create_context()
    except gl.GLUnavailable as exc:
        pytest.skip(f"no OpenGL 4.3 context: {exc}")
    prm = SimParams(tilt=40.0, tilt_direction=120.0)
    b = create_backend("numpy", W, H, "watercolor", seed=4, params=prm, tiling=False)
    paint_blob(b)
    for _ in range(3):
        b.step()
    st = b.state()
    c = gl.GLCanvas(W, H, ctx=ctx, tiling=False, params=prm)
    c.load_state(st)
    c.step()
    b.step()
    want, got = b.state(), c.state()
    for name in ("vx", "vy", "w", "p"):
        err = float(np.abs(getattr(got, name).astype(np.float64) - getattr(want, name)).max())
        assert err <= 2e-5 * max(1.0, float(np.abs(getattr(want, name)).max())), name
    assert np.abs(want.vy).max() > 0.5
