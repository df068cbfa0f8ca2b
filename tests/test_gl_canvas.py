"""GLCanvas as a backend: strokes, tiles, save/load across backends, bookkeeping, errors.

Multi-step comparisons use the tolerance of test_gl_passes (1e-5 x field scale);
on llvmpipe the two backends agree bitwise.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from station.backends.numpy_canvas import NumpyCanvas
from station.canvas.params import CanvasInputError
from station.canvas.state import CanvasState
from station.errors import BadInput

gl = pytest.importorskip("station.backends.gl")

FIELDS = ("vx", "vy", "w", "wc", "p", "q", "evaporated", "removed_p", "r_composed")
REL_TOL = 1e-5


@pytest.fixture(scope="module")
def ctx():
    try:
        c = gl.create_context()
    except gl.GLUnavailable as exc:
        pytest.skip(f"no OpenGL 4.3 context: {exc}")
    yield c
    c.release()


def stamp(canvas, cx: float, cy: float, r: float, pigments: dict[str, float],
          water: float = 0.4, vel: tuple[float, float] = (6.0, 2.0)) -> None:
    y0, x0 = int(math.floor(cy - r)), int(math.floor(cx - r))
    n = int(2 * r) + 2
    yy, xx = np.mgrid[y0:y0 + n, x0:x0 + n]
    disc = (((xx + 0.5 - cx) ** 2 + (yy + 0.5 - cy) ** 2) <= r * r).astype(np.float32)
    canvas.add_sources(dw=water * disc, dp={k: a * disc for k, a in pigments.items()},
                       dvx=vel[0] * disc, dvy=vel[1] * disc, y0=y0, x0=x0)


def paint(canvas, steps: int = 40, second: bool = True) -> None:
    """A wet-on-dry stroke, then a second stroke laid into it while wet."""
    for i in range(steps):
        if i < 16:
            stamp(canvas, 8 + 2.5 * i, 20 + 4 * math.sin(i / 3), 5,
                  {"French Ultramarine": 0.05, "Burnt Umber": 0.02})
        if second and 10 <= i < 20:
            stamp(canvas, 30, 8 + 2.0 * i - 14, 3, {"Hansa Yellow": 0.08}, vel=(0.0, 8.0))
        canvas.step()


def assert_states_close(a: CanvasState, b: CanvasState, fields=FIELDS) -> None:
    for name in fields:
        x, y = getattr(a, name), getattr(b, name)
        scale = max(1.0, float(np.abs(y).max()))
        err = float(np.abs(x.astype(np.float64) - y).max())
        assert err <= REL_TOL * scale, f"{name}: max abs err {err:.3g}"
    assert np.array_equal(a.tile_ttl, b.tile_ttl)
    assert a.slots == b.slots and a.step_count == b.step_count


@pytest.mark.parametrize("size", [(64, 40), (70, 45)])  # 45 and 70: clipped edge tiles
def test_multi_step_stroke_matches_numpy(ctx, size) -> None:
    w, h = size
    g = gl.GLCanvas(w, h, seed=2, ctx=ctx)
    n = NumpyCanvas(w, h, seed=2)
    for c in (g, n):
        paint(c, 60)
    gs, ns = g.state(), n.state()
    assert_states_close(gs, ns)
    assert gs.w.max() > 0.01 and gs.q.max() > 1e-3  # a real painting, still wet
    # booked on the GPU in double precision (per work group) vs float64 sums on the CPU
    assert abs(gs.water_added - ns.water_added) <= 1e-7 * max(1.0, ns.water_added)
    for k, v in ns.pigment_added.items():
        assert abs(gs.pigment_added[k] - v) <= 1e-7 * max(1.0, v)


def test_tiles_on_and_off_give_the_same_painting(ctx) -> None:
    w, h = 192, 128  # 6 x 4 tiles; the strokes touch the top-left ones
    on = gl.GLCanvas(w, h, seed=3, ctx=ctx, tiling=True)
    off = gl.GLCanvas(w, h, seed=3, ctx=ctx, tiling=False)
    cells = {}
    for name, c in (("on", on), ("off", off)):
        c.take_cells()
        paint(c, 50)
        for _ in range(30):
            c.step()
        cells[name] = c.take_cells()
    a, b = on.state(), off.state()
    for name in ("vx", "vy", "w", "wc", "p", "q", "evaporated"):
        x, y = getattr(a, name), getattr(b, name)
        assert float(np.abs(x - y).max()) <= 1e-6 * max(1.0, float(np.abs(y).max())), name
    assert cells["off"] == 80 * w * h
    assert 0 < cells["on"] < 0.5 * cells["off"]  # tiling really skipped work
    # the tile state itself follows the reference
    n = NumpyCanvas(w, h, seed=3)
    paint(n, 50)
    for _ in range(30):
        n.step()
    assert np.array_equal(a.tile_ttl, n.state().tile_ttl)


def test_switching_tiles_recompiles_for_the_mode_and_keeps_the_painting(ctx) -> None:
    # the passes read their tile from the list only with tiling on (tiles.glsl
    # TILE_LIST): a switch recompiles them, and the painting is the one tiling gives
    w, h = 192, 128  # 6 x 4 tiles; the stroke in the bottom-right ones: the list's
    ref_c = gl.GLCanvas(w, h, seed=3, ctx=ctx, tiling=True)  # entries are not the tiles
    sw = gl.GLCanvas(w, h, seed=3, ctx=ctx, tiling=False)
    for c in (ref_c, sw):
        for i in range(12):
            stamp(c, 120 + 3.0 * i, 96 + 3 * math.sin(i / 3), 5, {"French Ultramarine": 0.05})
            c.step()
    for k in range(12):
        if k == 4:
            sw.set_tiling(True)
            assert sw._tile_list_mode is True
        if k == 8:
            sw.set_tiling(False)
            assert sw._tile_list_mode is False
        ref_c.step()
        sw.step()
    a, b = sw.state(), ref_c.state()
    assert b.w.max() > 0.01
    for name in ("vx", "vy", "w", "wc", "p", "q", "evaporated"):
        x, y = getattr(a, name), getattr(b, name)
        assert float(np.abs(x - y).max()) <= 1e-6 * max(1.0, float(np.abs(y).max())), name


def test_tile_leaving_the_active_set_keeps_both_buffers_in_step(ctx) -> None:
    """Short TTL: tiles drop out and come back while the painting goes on."""
    from station.canvas.params import SimParams

    prm = SimParams(tile_check=3, eps_shallow=0.5, eps_cap=0.3)
    g = gl.GLCanvas(64, 64, ctx=ctx, params=prm)
    n = NumpyCanvas(64, 64, params=prm)
    for c in (g, n):
        for i in range(120):
            if i % 30 < 6:
                stamp(c, 10 + (i % 7) * 6, 10 + (i // 30) * 12, 4, {"Cadmium Red": 0.05})
            c.step()
    assert_states_close(g.state(), n.state())


def test_save_on_gl_load_on_numpy_and_back(ctx, tmp_path) -> None:
    w, h = 64, 48
    g = gl.GLCanvas(w, h, seed=4, ctx=ctx)
    paint(g, 30)
    path = tmp_path / "mid.npz"
    g.save(str(path))
    # numpy continues from the GL save ...
    n = NumpyCanvas(w, h, seed=99)
    n.load(str(path))
    for c in (g, n):
        paint(c, 25, second=False)
    assert_states_close(g.state(), n.state())
    # ... and a GL canvas continues from a numpy save
    path2 = tmp_path / "np.npz"
    n.save(str(path2))
    g2 = gl.GLCanvas(16, 16, ctx=ctx)  # other size: load_state reallocates
    g2.load(str(path2))
    for c in (g2, n):
        for _ in range(20):
            c.step()
    assert_states_close(g2.state(), n.state())
    assert (g2.width, g2.height) == (w, h)


def test_bookkeeping_closes_on_gl(ctx) -> None:
    g = gl.GLCanvas(64, 48, seed=5, ctx=ctx)
    paint(g, 50)
    for _ in range(100):
        g.step()
    s = g.stats()
    assert s["water"]["evaporated"] > 0.5  # evaporation really happened on the GPU
    assert s["balance"]["water_rel_error"] < 1e-3
    assert s["balance"]["pigment_rel_error"] < 1e-3
    g.new_layer()
    paint(g, 20, second=False)
    g.dry()
    s = g.stats()
    assert s["layers"] == 1
    assert s["balance"]["water_rel_error"] < 1e-3
    assert s["balance"]["pigment_rel_error"] < 1e-3
    st = g.state()
    assert st.w.max() == 0 and st.wc.max() == 0 and st.p.max() == 0


def test_operations_match_numpy(ctx) -> None:
    g = gl.GLCanvas(64, 40, seed=6, ctx=ctx)
    n = NumpyCanvas(64, 40, seed=6)
    for c in (g, n):
        paint(c, 25)
        c.new_layer()
        stamp(c, 30, 20, 6, {"Hansa Yellow": 0.1})
        for _ in range(10):
            c.step()
        c.set_profile("ink")
        stamp(c, 20, 20, 4, {"Sumi Ink": 0.1})
        for _ in range(10):
            c.step()
    assert_states_close(g.state(), n.state())
    assert float(np.abs(g.render() - n.render()).max()) < 2e-5
    for c in (g, n):
        c.clear()
    st = g.state()
    assert st.slots == [] and st.q.max() == 0 and st.water_added == 0.0
    assert np.array_equal(st.r_composed, n.state().r_composed)


def test_bad_input_changes_nothing(ctx) -> None:
    g = gl.GLCanvas(32, 32, ctx=ctx, n_slots=4)
    stamp(g, 16, 16, 4, {"Black": 0.1})
    before = g.state()
    disc = np.ones((4, 4), np.float32)
    with pytest.raises(BadInput):
        g.add_sources(dw=disc, dp={"No Such Pigment": disc})
    with pytest.raises(BadInput):
        g.add_sources(dw=disc * np.nan)
    with pytest.raises(BadInput):
        g.add_sources(dp={n: disc for n in ("Cadmium Red", "Hansa Yellow", "Burnt Umber",
                                              "Cerulean Blue")})  # a 5th pigment in 4 slots
    with pytest.raises(CanvasInputError):
        g.step(dt=1.0)
    after = g.state()
    assert_states_close(after, before)
    assert after.slots == ["Black"]


def test_impossible_size_is_bad_input(ctx) -> None:
    with pytest.raises(BadInput):
        gl.GLCanvas(2, 2, ctx=ctx)


def test_renderer_string_and_traffic_count(ctx) -> None:
    g = gl.GLCanvas(32, 32, ctx=ctx)
    assert isinstance(g.renderer, str) and g.renderer
    assert g.renderer == ctx.info["GL_RENDERER"]
    # the pigment layers in use are counted: none, then 1 (4 slots), then 2 (8 slots)
    count = gl.traffic.floats_per_cell_step
    n = int(g.params.jacobi_iters)  # the profile's
    mem = g.params.wet_hold > 0  # the wet-area memory's texture is traffic too
    # the memory: prep and capillary_dry write it (+1 each); blur_x reads it (1) instead of
    # w, wc and mask (3)
    with_mem, without = count(4, n, True), count(4, n)
    assert mem and sum(with_mem.values()) == sum(without.values())
    blur = "blur_x (pass 3's wet area blurred along x)"
    assert (with_mem[blur], without[blur]) == (2, 4)
    jac = "jacobi (pass 3's levelled height; velocity, water, pigment)"
    front = gl.traffic.front_mode(*g.params.standing_front())  # the profile's: over dry paper
    assert front == 1
    shelter = gl.traffic.shelters(g.params.damp_exposure, g.params.flow_outward,
                                  g.params.wet_blur)  # the profile's: on
    assert shelter
    assert g.bytes_per_cell_step() == 4 * sum(count(0, n, mem, front, shelter).values())
    stamp(g, 10, 10, 3, {"Black": 0.1})
    assert g.bytes_per_cell_step() == 4 * sum(count(4, n, mem, front, shelter).values())
    for name in ("Cadmium Red", "Hansa Yellow", "Burnt Umber", "Cerulean Blue"):
        stamp(g, 10, 10, 3, {name: 0.1})
    assert g.bytes_per_cell_step() == 4 * sum(count(8, n, mem, front, shelter).values())
    # with the front pass, it forms pass 3's levelled height (it has M'), not the first
    # Jacobi iteration
    assert count(4, 1, mem, front)[jac] == count(4, 1, mem)[jac] - 3
    assert count(8, 4)[jac] > count(4, 4)[jac]
    # pass 3's levelled height rides in the first Jacobi iteration: no pass of its own, and
    # of its reads only h and bx are new there (w and wb come with aux and jv); one more
    # iteration adds its own reads, not the height's
    assert not any(k.startswith("pressure") for k in count(4, 1))
    assert count(4, 1)[jac] == (7 + 4 + 4 + 4) + 3
    assert count(4, 2)[jac] - count(4, 1)[jac] == 7 + 8 + 4 + 4


def test_evaporation_fold_matches_numpy(ctx, monkeypatch) -> None:
    """Every FOLD_EVERY steps the per-cell evaporated water moves into a float64 total."""
    from station.canvas import operations

    monkeypatch.setattr(operations, "FOLD_EVERY", 7)
    g = gl.GLCanvas(64, 40, seed=8, ctx=ctx)
    n = NumpyCanvas(64, 40, seed=8)
    for c in (g, n):
        paint(c, 45)  # 6 folds, the last at step 42
    gs, ns = g.state(), n.state()
    assert_states_close(gs, ns, fields=("w", "wc", "evaporated", "p", "q"))
    assert ns.evaporated_folded > 0.1
    assert abs(gs.evaporated_folded - ns.evaporated_folded) <= 1e-6 * ns.evaporated_folded
    assert g.stats()["balance"]["water_rel_error"] < 1e-5


def test_all_zero_pigment_source_takes_no_slot(ctx) -> None:
    g = gl.GLCanvas(32, 32, ctx=ctx)
    disc = np.ones((4, 4), np.float32)
    g.add_sources(dw=disc, dp={"Black": disc * 0, "Cadmium Red": disc * 0.1})
    assert g.state().slots == ["Cadmium Red"]


@pytest.mark.parametrize("n_slots", [3, 12])  # one RGBA layer; three layers
def test_other_slot_counts_match_numpy(ctx, n_slots: int) -> None:
    names = ["French Ultramarine", "Cerulean Blue", "Hansa Yellow", "Cadmium Yellow",
             "Quinacridone Rose", "Cadmium Red", "Indian Red", "Burnt Umber",
             "Phthalo Green", "Hookers Green"][:min(n_slots, 10)]
    g = gl.GLCanvas(48, 40, ctx=ctx, n_slots=n_slots)
    n = NumpyCanvas(48, 40, n_slots=n_slots)
    for c in (g, n):
        for i, name in enumerate(names):
            stamp(c, 8 + 3 * i, 20, 4, {name: 0.05})
            c.step()
        for _ in range(10):
            c.step()
    assert_states_close(g.state(), n.state())
    assert float(np.abs(g.render() - n.render()).max()) < 2e-5


@pytest.mark.parametrize("tiling", [True, False])
def test_blur_rows_per_invocation_split_the_work_not_the_maths(ctx, tiling: bool) -> None:
    """blur_x's rows per invocation (4 on a CPU rasterizer, 1 on a GPU; its own indirect
    dispatch with tiling): the same painting bit for bit, the stroke crossing clipped edge
    tiles (70 x 45) with the flow-outward blur on, and both match the reference."""
    assert gl.default_blur_rows("llvmpipe (LLVM 15.0.6, 256 bits)") == 4
    assert gl.default_blur_rows("NVIDIA H100 PCIe/PCIe/SSE2") == 1
    states = {}
    for rows in (1, 2, 4):
        c = gl.GLCanvas(70, 45, seed=2, ctx=ctx, tiling=tiling, blur_rows=rows)
        assert c.params.flow_outward > 0 and c.blur_groups[1] == -(-4 // rows)
        paint(c, 24)
        states[rows] = c.state()
        c.close()
    for rows in (2, 4):
        for name in FIELDS:
            assert np.array_equal(getattr(states[rows], name), getattr(states[1], name)), name
    n = NumpyCanvas(70, 45, seed=2, tiling=tiling)
    paint(n, 24)
    assert_states_close(states[4], n.state())
    with pytest.raises(CanvasInputError):
        gl.GLCanvas(70, 45, ctx=ctx, blur_rows=3)


@pytest.mark.parametrize("constants", [True, False])
def test_slot_values_as_constants_or_uniforms_match_numpy(ctx, constants: bool) -> None:
    """evap_surface's pigment-slot values: constants (a CPU rasterizer's default, the program
    recompiled when a new pigment takes a slot: Hansa Yellow from step 10) or uniforms (a
    GPU's); both follow the reference, deposits included."""
    assert gl.is_cpu_rasterizer("llvmpipe (LLVM 15.0.6, 256 bits)")
    assert not gl.is_cpu_rasterizer("NVIDIA H100 PCIe/PCIe/SSE2")
    c = gl.GLCanvas(70, 45, seed=4, ctx=ctx, slot_constants=constants)
    n = NumpyCanvas(70, 45, seed=4)
    for k in (c, n):
        paint(k, 24)
    a = c.state()
    assert_states_close(a, n.state())
    assert a.q[a.slots.index("Hansa Yellow")].max() > 1e-4  # the late slot deposited
    if constants:
        with pytest.raises(KeyError):  # the constants' program reads no slot uniform
            c._programs["evap_surface"]["u_gamma"]
    else:
        assert c._programs["evap_surface"]["u_gamma"].array_length == c.npl
    c.close()
