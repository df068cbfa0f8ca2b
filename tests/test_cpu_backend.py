"""The ``cpu`` backend (numba) against the NumPy reference: pass by pass, over strokes,
tiles on/off, save/load, bookkeeping, factory and benchmark hooks.

Tolerance: every field within ``TOL = 1e-5`` x its scale (``max(1, max |field|)``) of the
reference. The kernels do the reference's float32 operations in the reference's order,
so in practice the results are bitwise equal; ``test_multi_step_stroke_is_bitwise_equal``
pins that down for a long stroke.
"""

from __future__ import annotations

import dataclasses
import json
from typing import Any

import numpy as np
import pytest

pytest.importorskip("numba", reason="numba is not installed: the cpu backend needs it")

from station.backends.cpu import CpuCanvas, traffic
from station.backends.cpu import step as cpu_step
from station.backends.factory import create_backend, fastest_cpu_backend, resolve_auto
from station.backends.numpy_canvas import NumpyCanvas
from station.canvas import reference as ref
from station.canvas.params import SimParams
from station.canvas.profiles import get_profile
from station.canvas.state import CanvasState

TOL = 1e-5
FIELDS = ("w", "wc", "vx", "vy", "p", "q", "evaporated", "wet_area")
PIGMENTS = ("French Ultramarine", "Burnt Umber", "Quinacridone Rose")


def _max_rel_err(a: CanvasState, b: CanvasState) -> dict[str, float]:
    """Per field: max |a - b| / max(1, max |a|)."""
    out = {}
    for f in FIELDS:
        x, y = getattr(a, f), getattr(b, f)
        scale = max(1.0, float(np.abs(x).max()))
        out[f] = float(np.abs(x.astype(np.float64) - y).max()) / scale
    return out


def _step_both_bitwise(a: NumpyCanvas, b: NumpyCanvas, steps: int) -> None:
    """Step the reference ``a`` and the cpu canvas ``b`` ``steps`` times; every field bit
    for bit."""
    for _ in range(steps):
        a.step()
        b.step()
    for f in FIELDS:
        assert np.array_equal(getattr(a.live_state, f), getattr(b.live_state, f)), f


def _random_canvas(cls: type[NumpyCanvas], seed: int, h: int = 40, w: int = 52,
                   profile: str = "watercolor", tiling: bool = False,
                   params: SimParams | None = None) -> NumpyCanvas:
    """A plausible mid-painting state: a wet stroke with a dry island, moist capillary
    cells, masked cells, a brush-written blocking pattern, three pigments, deposits."""
    rng = np.random.default_rng(seed)
    c = cls(w, h, profile=profile, seed=seed, tiling=tiling, params=params)
    fp = np.zeros((h, w), np.float32)
    fp[5:31, 6:41] = 1
    fp[12:17, 15:21] = 0
    dp = {name: fp * rng.uniform(0, 0.5, (h, w)).astype(np.float32) for name in PIGMENTS}
    c.add_sources(dw=fp * rng.uniform(0.05, 1.2, (h, w)).astype(np.float32), dp=dp,
                  dvx=fp * rng.uniform(-25, 25, (h, w)).astype(np.float32),
                  dvy=fp * rng.uniform(-25, 25, (h, w)).astype(np.float32))
    st = c.live_state
    st.wc[...] = (rng.uniform(0, 1, (h, w)) * st.capacity()).astype(np.float32) * (fp > 0)
    st.wc[20:24, 42:48] = 0.9 * st.capacity()[20:24, 42:48]  # moist cells outside the stroke
    st.q[:3] = (0.3 * fp * rng.uniform(0, 1, (3, h, w))).astype(np.float32)
    st.block[8:20, 8:30] = rng.uniform(0, 1, (12, 22)).astype(np.float32)
    st.block_time[8:20, 8:30] = np.float32(0.0)
    st.sim_time = 0.7
    st.mask[25:29, 30:36] = 1
    st.w[25:29, 30:36] = 0
    st.w[3, 3] = np.float32(4e-6)  # a tiny height that dries at once
    # a wet-area memory on damp paper (cells that were wet earlier in this wet phase)
    st.wet_area[...] = (rng.uniform(0, 1, (h, w)) * (st.wc > 0)).astype(np.float32)
    return c


@pytest.mark.parametrize("stop_after", ref.PASS_ORDER)
def test_each_pass_matches_the_reference(stop_after: str) -> None:
    a = _random_canvas(NumpyCanvas, 11)
    b = _random_canvas(CpuCanvas, 11)
    sa, sb = a.live_state, b.live_state
    box = (slice(0, sa.height), slice(0, sa.width))
    ref.step_region(sa, box, sa.params.dt, stop_after=stop_after)
    assert isinstance(b, CpuCanvas)
    cpu_step.step_region(sb, box, sb.params.dt, b._scratch(), stop_after=stop_after)
    err = _max_rel_err(sa, sb)
    assert max(err.values()) <= TOL, (stop_after, err)
    # the pass did something to the fields it owns (the comparison is not vacuous)
    fresh = _random_canvas(NumpyCanvas, 11).live_state
    changed = {f for f in FIELDS if not np.array_equal(getattr(fresh, f), getattr(sa, f))}
    assert changed, stop_after


@pytest.mark.parametrize("profile", ["watercolor", "ink", "gouache"])
def test_multi_step_stroke_matches_on_every_profile(profile: str) -> None:
    a = _random_canvas(NumpyCanvas, 5, profile=profile, tiling=True)
    b = _random_canvas(CpuCanvas, 5, profile=profile, tiling=True)
    fp = np.zeros((6, 6), np.float32) + 1
    for k in range(40):
        for c in (a, b):  # the brush keeps painting while the stroke flows
            c.add_sources(dw=0.2 * fp, dp={PIGMENTS[k % 2]: 0.05 * fp}, dvx=10 * fp,
                          y0=8 + k // 4, x0=4 + k)
            c.step()
        assert a.cells_last_step() == b.cells_last_step()
    err = _max_rel_err(a.live_state, b.live_state)
    assert max(err.values()) <= TOL, err
    assert np.array_equal(a.live_state.tile_ttl, b.live_state.tile_ttl)


def test_multi_step_stroke_is_bitwise_equal() -> None:
    a = _random_canvas(NumpyCanvas, 8)
    b = _random_canvas(CpuCanvas, 8)
    for _ in range(60):
        a.step()
        b.step()
    for f in FIELDS:
        assert np.array_equal(getattr(a.live_state, f), getattr(b.live_state, f)), f
    assert a.live_state.w.sum() > 0  # still wet: the flow was exercised to the end


@pytest.mark.parametrize("change", [{"jacobi_iters": 1}, {"jacobi_iters": 3},
                                    {"nu_w": 0.0, "viscosity": 0.0},
                                    {"nu_p": 0.0, "standing_nu_p": 0.0, "cap_diffusion": 0.0,
                                     "block_fade": 0.0},
                                    {"flow_outward": 0.0, "advance_height": 0.0},
                                    {"flow_outward": 0.8, "wet_blur": 4.0, "temperature": 35.0,
                                     "humidity": 0.2, "advance_height": 0.3},
                                    {"advance_grain": 0.4}, {"advance_grain": 1.0},
                                    {"advance_curvature": 0.0},
                                    {"advance_curvature": 2.5, "fibre_wick": 0.5},
                                    {"paper_relief": 0.6}, {"paper_relief": 0.4,
                                                            "flow_outward": 0.0},
                                    {"paper_relief": 0.0, "flow_outward": 0.0},
                                    {"damp_ease": 0.0, "suspend_sat": 0.0,
                                     "moist_threshold": 0.25},
                                    {"damp_ease": 6.0, "damp_sat": 0.4, "suspend_sat": 0.8},
                                    {"damp_ease": 2.0, "fibre_wick": 0.7},
                                    {"lift_gain": 1.0}, {"lift_gain": 37.0},
                                    {"wet_hold": 0.0}, {"wet_hold": 0.2},
                                    {"wet_hold": 3.0, "moist_threshold": 0.25},
                                    {"fibre_permeability": 1.0, "nu_p": 0.02,
                                     "fibre_dispersivity": 9.0},
                                    {"fibre_permeability": 0.35, "paper_relief": 0.3},
                                    {"standing_front_dry": 0.0},
                                    {"rim_sharpness": 0.0},
                                    {"rim_sharpness": 0.4, "rim_onset": 0.1, "rim_full": 0.5},
                                    {"rim_sharpness": 0.6, "standing_front_pull": 0.0},
                                    {"rim_sharpness": 0.8, "jacobi_iters": 2},
                                    {"standing_front_dry": 0.0, "jacobi_iters": 2,
                                     "block_fade": 0.0},
                                    {"damp_exposure": 0.0}, {"damp_exposure": 0.7,
                                                             "damp_sat": 0.3},
                                    {"damp_exposure": 0.5, "jacobi_iters": 3,
                                     "wet_hold": 0.0}])
def test_parameter_variants_match(change: dict[str, Any]) -> None:
    prm = dataclasses.replace(get_profile("watercolor").params, **change)
    a = _random_canvas(NumpyCanvas, 3, params=prm)
    b = _random_canvas(CpuCanvas, 3, params=prm)
    for _ in range(12):
        a.step()
        b.step()
    err = _max_rel_err(a.live_state, b.live_state)
    assert max(err.values()) <= TOL, (change, err)


def test_many_slots_match_the_reference() -> None:
    """12 slots per layer, 10 in use (the scratch grows beyond its first slot count)."""
    from station.canvas.palette import default_palette

    names = default_palette().names()[:10]
    assert len(names) == 10
    runs = []
    for cls in (NumpyCanvas, CpuCanvas):
        c = cls(48, 40, seed=1, n_slots=12)
        rng = np.random.default_rng(2)
        fp = np.zeros((40, 48), np.float32)
        fp[4:36, 5:44] = 1
        c.add_sources(dw=0.6 * fp, dp={fp_name: fp * rng.uniform(0, 0.1, fp.shape)
                                        .astype(np.float32) for fp_name in names[:1]},
                      dvx=8 * fp)
        c.step()  # the scratch is made for one slot here ...
        c.add_sources(dp={n: fp * rng.uniform(0, 0.1, fp.shape).astype(np.float32)
                          for n in names[1:]})
        for _ in range(10):  # ... and has to grow to ten
            c.step()
        runs.append(c.live_state)
    assert len(runs[1].slots) == 10
    err = _max_rel_err(runs[0], runs[1])
    assert max(err.values()) <= TOL, err


def test_tiles_on_and_off_give_the_same_painting() -> None:
    on = CpuCanvas(96, 80, seed=2, tiling=True)
    off = CpuCanvas(96, 80, seed=2, tiling=False)
    fp = np.ones((7, 7), np.float32)
    for k in range(50):
        for c in (on, off):
            if k < 25:
                c.add_sources(dw=0.4 * fp, dp={PIGMENTS[0]: 0.04 * fp}, dvx=15 * fp,
                              y0=20 + k // 3, x0=5 + 2 * k)
            c.step()
    assert on.cells_last_step() < 96 * 80  # tiles really skipped cells
    err = _max_rel_err(off.live_state, on.live_state)
    assert max(err.values()) <= TOL, err
    assert on.live_state.q.sum() > 0


def test_several_boxes_per_step_match_the_reference() -> None:
    """Two strokes far apart: two tile boxes of different shapes in every step (the
    scratch ring is re-zeroed between them)."""
    from station.canvas import tiles

    a = NumpyCanvas(160, 96, seed=9, tiling=True)
    b = CpuCanvas(160, 96, seed=9, tiling=True)
    small = np.ones((5, 5), np.float32)
    big = np.ones((14, 9), np.float32)
    boxes = 0
    for k in range(40):
        for c in (a, b):
            if k < 20:
                c.add_sources(dw=0.5 * small, dp={PIGMENTS[0]: 0.05 * small}, dvx=12 * small,
                              y0=6, x0=4 + k)
                c.add_sources(dw=0.3 * big, dp={PIGMENTS[2]: 0.08 * big}, dvy=-9 * big,
                              y0=70 - k, x0=120)
            c.step()
        boxes = max(boxes, len(tiles.active_regions(b.live_state)))
    assert boxes >= 2
    err = _max_rel_err(a.live_state, b.live_state)
    assert max(err.values()) <= TOL, err
    assert np.array_equal(a.live_state.tile_ttl, b.live_state.tile_ttl)


def test_save_load_continues_exactly(tmp_path) -> None:
    a = _random_canvas(CpuCanvas, 4, tiling=True)
    for _ in range(10):
        a.step()
    path = tmp_path / "canvas.npz"
    a.save(str(path))
    b = CpuCanvas(8, 8)
    b.load(str(path))
    for _ in range(15):
        a.step()
        b.step()
    for f in (*FIELDS, "tile_ttl"):
        assert np.array_equal(getattr(a.live_state, f), getattr(b.live_state, f)), f
    # and a cpu save continues identically on the reference
    n = NumpyCanvas(8, 8)
    n.load(str(path))
    c = CpuCanvas(8, 8)
    c.load(str(path))
    for _ in range(5):
        n.step()
        c.step()
    assert max(_max_rel_err(n.live_state, c.live_state).values()) <= TOL


def test_bookkeeping_closes() -> None:
    c = CpuCanvas(64, 48, seed=6)
    fp = np.ones((9, 9), np.float32)
    for k in range(120):
        if k < 40:
            c.add_sources(dw=0.5 * fp, dp={PIGMENTS[k % 3]: 0.05 * fp}, dvx=20 * fp,
                          y0=10 + k // 4, x0=2 + k)
        c.step()
        if k == 70:
            c.new_layer()
    bal = c.stats()["balance"]
    assert bal["water_rel_error"] < 1e-3 and bal["pigment_rel_error"] < 1e-3, bal
    assert c.live_state.evaporated.sum() + c.live_state.evaporated_folded > 0


def test_operations_render_and_factory() -> None:
    c = create_backend("cpu", 40, 30, "watercolor", 1)
    assert isinstance(c, CpuCanvas) and c.renderer.startswith("cpu")
    assert fastest_cpu_backend() == "cpu"
    pick = resolve_auto()[0]  # measured here (and cached): auto makes what it names
    if pick != "gl":
        made = create_backend("auto", 40, 30)
        assert type(made).__name__ == {"cpu": "CpuCanvas", "numpy": "NumpyCanvas"}[pick]
    n = create_backend("numpy", 40, 30, "watercolor", 1)
    fp = np.ones((10, 10), np.float32)
    for x in (c, n):
        x.add_sources(dw=0.5 * fp, dp={PIGMENTS[1]: 0.1 * fp}, y0=5, x0=5)
        for _ in range(5):
            x.step()
        x.dry()
    assert np.array_equal(c.render(), n.render())
    assert c.live_state.w.sum() == 0 and c.live_state.q.sum() > 0
    c.clear()
    assert c.live_state.q.sum() == 0
    # honest traffic: the per-sweep count (float32 fields 4 bytes, the two flags 1 byte)
    slots = max(len(c.live_state.slots), 1)
    iters = int(c.live_state.params.jacobi_iters)
    memory = c.live_state.params.wet_hold > 0
    assert memory  # the watercolor profile keeps a wet-area memory (issue 21 item 8)
    finv, fdry = c.live_state.params.standing_front()
    front = (1 if fdry > 0 else 0) if finv > 0 else -1
    assert c.bytes_per_cell_step() == sum(
        traffic.bytes_per_sweep(slots, iters, memory, front).values())
    # 520 before issue 10, 556 in own sweep, 544 before issue 26 fused passes 2-5, 6 and
    # 7-10, 408 after them; 364 with uint8 flags, c from h, pass 1 on the state's velocity
    assert traffic.bytes_per_cell_step(2, 4) == 380
    # one Jacobi iteration (the profiles since issue 26): no temporally blocked sweep;
    # 340 (348 with the fibres' reads, which that count left out) before the flags, 315
    # after them; 275 with iteration 1 in limit_diffuse's row ring
    # 251 since session 15: no w0/p0 copies where pass 3 levels a height of its own
    assert traffic.bytes_per_cell_step(2, 1) == 251
    assert traffic.bytes_per_cell_step(2, 1, levelled=False) == 275
    # the wet-area memory: prep reads and writes the area (8), and its fade reads and
    # writes it again in evap_capillary's rows (8; 17 as a sweep of its own, 300 in all)
    assert traffic.bytes_per_cell_step(2, 1, wet_memory=True) == 267
    # the standing gate's front factor (session 13's default): 300 and 316 B as a sweep of
    # its own (41 B, 57 B with the dry-paper term); session 14 folds it into
    # advect_jacobi1's rows (the wet mask and velocity read once), prep writes the x half
    # of the dry-paper blur (its wc and h read once) and no beta_c (written once, with
    # the factor)
    # session 15: prep's copies of w and p are gone (-24 B: w read once, p not at all,
    # neither copy written; the sweeps after it read the state)
    assert traffic.bytes_per_cell_step(2, 1, wet_memory=True, front=0) == 259
    assert traffic.bytes_per_cell_step(2, 1, wet_memory=True, front=1) == 267
    # several Jacobi iterations keep the front's sweep (advect_jacobi1's pigment
    # iteration reads beta_c of the next rows); one iteration has none
    four = traffic.bytes_per_sweep(2, 4, wet_memory=True, front=1)
    assert [k.split()[0] for k in four][-1] == "standing_front" and len(four) == 7
    assert len(traffic.bytes_per_sweep(2, 1, wet_memory=True, front=1)) == 6
    assert sum(four.values()) == 409  # the iterations read the copies: still written


def test_front_factor_runs_in_advect_jacobi1_rows(monkeypatch: pytest.MonkeyPatch) -> None:
    """With one Jacobi iteration (the profiles') the standing gate's front factor has no
    sweep of its own: advect_jacobi1 computes it row by row (issue 26: a pass fewer, the
    wet mask, velocity, wc and h read once); with three it still runs (its pigment
    iteration reads beta_c of the next rows) and both agree with the reference."""
    import station.backends.cpu.kernels as K

    calls: list[int] = []
    real = K.standing_front

    def counted(*a: Any) -> None:
        calls.append(1)
        real(*a)

    monkeypatch.setattr(K, "standing_front", counted)
    prm = get_profile("watercolor").params
    assert prm.jacobi_iters == 1 and prm.standing_front()[0] > 0
    for iters, sweeps in ((1, 0), (3, 3)):
        p = dataclasses.replace(prm, jacobi_iters=iters)
        a = _random_canvas(NumpyCanvas, 4, params=p)
        b = _random_canvas(CpuCanvas, 4, params=p)
        calls.clear()
        for _ in range(3):
            a.step()
            b.step()
        assert len(calls) == sweeps
        for f in FIELDS:
            assert np.array_equal(getattr(a.live_state, f), getattr(b.live_state, f)), f


def test_bench_sim_measures_the_cpu_backend(capsys) -> None:
    from station.cli import main

    rc = main(["bench", "sim", "--json", "--backends", "cpu", "--sizes", "64x48",
               "--seconds", "0.05"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    got = {(r["backend"], r["scenario"]) for r in out["results"]}
    assert got == {("cpu", "wash"), ("cpu", "stroke")}
    for r in out["results"]:
        assert r["steps_per_s"] > 0 and r["bytes_per_cell_step"] > 0
        assert r["renderer"].startswith("cpu")


def test_fibre_wick_on_rough_paper_is_bitwise_equal() -> None:
    """The ink profile's front running along the paper's fibres (fibre_wick) agrees bit
    for bit, and the fibres change the result (the comparison is not vacuous)."""
    a = _random_canvas(NumpyCanvas, 4, profile="ink")
    b = _random_canvas(CpuCanvas, 4, profile="ink")
    assert a.live_state.params.fibre_wick > 0 and a.live_state.fibre.any()
    flat = _random_canvas(NumpyCanvas, 4, profile="ink",
                          params=dataclasses.replace(get_profile("ink").params, fibre_wick=0.0))
    for _ in range(30):
        for c in (a, b, flat):
            c.step()
    for f in FIELDS:
        assert np.array_equal(getattr(a.live_state, f), getattr(b.live_state, f)), f
    assert not np.array_equal(a.live_state.w, flat.live_state.w)


def test_fibre_dispersion_on_cold_press_is_bitwise_equal() -> None:
    """The watercolor profile's dispersion along the paper's fibre channels (pass 5's
    beta_c times 1 + gd max(fibre) |v|) agrees bit for bit, and it changes the painting."""
    a = _random_canvas(NumpyCanvas, 6)
    b = _random_canvas(CpuCanvas, 6)
    prm = a.live_state.params
    assert prm.fibre_dispersivity > 0 and a.live_state.fibre.any()
    plain = _random_canvas(NumpyCanvas, 6,
                           params=dataclasses.replace(prm, fibre_dispersivity=0.0))
    for _ in range(30):
        for c in (a, b, plain):
            c.step()
    for f in FIELDS:
        assert np.array_equal(getattr(a.live_state, f), getattr(b.live_state, f)), f
    assert not np.array_equal(a.live_state.p, plain.live_state.p)


def test_fibre_channelled_flow_on_cold_press_is_bitwise_equal() -> None:
    """The levelling flow along the paper's fibres (pass 3's height term times
    1 - a + 4 a fibre[axis], cold-press paper) agrees bit for bit, and it changes the flow."""
    plain_prm = get_profile("watercolor").params
    prm = dataclasses.replace(plain_prm, fibre_permeability=1.0, nu_p=0.02,
                              fibre_dispersivity=9.0)
    a = _random_canvas(NumpyCanvas, 7, params=prm)
    b = _random_canvas(CpuCanvas, 7, params=prm)
    assert a.live_state.fibre.any()
    plain = _random_canvas(NumpyCanvas, 7, params=dataclasses.replace(prm,
                                                                      fibre_permeability=0.0))
    for _ in range(30):
        for c in (a, b, plain):
            c.step()
    for f in FIELDS:
        assert np.array_equal(getattr(a.live_state, f), getattr(b.live_state, f)), f
    assert not np.array_equal(a.live_state.vx, plain.live_state.vx)


@pytest.mark.parametrize(("fibred", "tiling"), [(True, False), (False, False), (True, True)])
def test_standing_water_gate_and_diffusion_are_bitwise_equal(fibred: bool,
                                                             tiling: bool) -> None:
    """Pass 3's fibre channel faded in by the standing water (fibre_gate_depth), off where
    the flow outward pulls (fibre_gate_pull), and the
    pigment's own diffusion faded to standing_nu_p in it (standing_depth), itself off near
    the edge of the wet area over dry paper (standing_front_pull, standing_front_dry: the
    blurred wet-area mask and the blurred dry-paper mask, K.standing_front after prep):
    every field bit for bit, on cold-press paper and on paper without fibre (there the
    channel is off), untiled and tiled (the cpu step computes only the cells near live
    ones), and the terms change the flow and the pigment."""
    base = dataclasses.replace(get_profile("watercolor").params, fibre_permeability=1.0,
                               fibre_dispersivity=9.0, fibre_gate_depth=0.0,
                               fibre_gate_pull=0.0, standing_depth=0.0, standing_nu_p=0.0,
                               standing_front_pull=0.0, standing_front_dry=0.0)
    gated = dataclasses.replace(base, fibre_gate_depth=0.4, fibre_gate_pull=0.1,
                                standing_depth=0.3, standing_nu_p=0.005)
    prm = dataclasses.replace(gated, standing_front_pull=0.04, standing_front_dry=0.5)
    runs = []
    for cls, p in ((NumpyCanvas, prm), (CpuCanvas, prm), (NumpyCanvas, base),
                   (NumpyCanvas, gated)):
        c = _random_canvas(cls, 8, params=p, tiling=tiling)
        if not fibred:
            c.live_state.fibre[...] = 0
        runs.append(c)
    for _ in range(20):
        for c in runs:
            c.step()
    a, b, ungated, no_front = (c.live_state for c in runs)
    for f in FIELDS:
        assert np.array_equal(getattr(a, f), getattr(b, f)), f
    if tiling:
        assert np.array_equal(a.tile_ttl, b.tile_ttl)
    assert not np.array_equal(a.p, ungated.p)
    assert not np.array_equal(a.p, no_front.p)
    if fibred:
        assert not np.array_equal(a.vx, ungated.vx)


def test_live_stroke_on_tiles_is_bitwise_equal() -> None:
    """A disc stroke along a wave, painting every step, with the wet trail spreading over
    tiles and its bounding box much larger than the tiles near it (the cpu step computes
    only the cells near active tiles): every field and the tile TTLs bit for bit."""
    from station.bench.sim import _StrokePath
    from station.canvas import tiles

    a = NumpyCanvas(256, 256, seed=4, tiling=True)
    b = CpuCanvas(256, 256, seed=4, tiling=True)
    sa, sb = _StrokePath(a, 256, 256, radius=6.0), _StrokePath(b, 256, 256, radius=6.0)
    sparse = 0
    for _ in range(90):
        for c, s in ((a, sa), (b, sb)):
            s.advance()
            c.step()
        st = b.live_state
        box = sum((r[0].stop - r[0].start) * (r[1].stop - r[1].start)
                  for r in tiles.active_regions(st))
        sparse += int(box > 1.4 * int((st.tile_ttl > 0).sum()) * st.params.tile_size ** 2)
    assert sparse > 20  # the box held many tiles at rest: the skipping was exercised
    for f in (*FIELDS, "tile_ttl"):
        assert np.array_equal(getattr(a.live_state, f), getattr(b.live_state, f)), f
    assert a.live_state.w.sum() > 0 and a.live_state.q.sum() > 0


@pytest.mark.parametrize(("change", "copied"), [
    ({}, False),                                            # the profile: no copies
    ({"paper_relief": 0.0, "flow_outward": 0.0}, True),     # pass 3 levels w0 itself
    ({"jacobi_iters": 2}, True),                            # the iterations read them
])
def test_the_stencils_read_the_state_where_no_sweep_needs_the_copies(
        change: dict[str, Any], copied: bool) -> None:
    """Issue 26 item 1 (session 15): with one Jacobi iteration and a levelled height of
    pass 3's own (the profiles') prep writes no padded copies of w and p: the contact
    line and the Jacobi iteration read the state through rings of padded rows, the cells
    read it in place (-24 B a cell-step). Bit for bit the reference, tiled and not, with
    the copies and without; the scratch copies stay as they were made (zeros) when not
    needed."""
    prm = dataclasses.replace(get_profile("watercolor").params, **change)
    for tiling in (False, True):
        a = _random_canvas(NumpyCanvas, 5, params=prm, tiling=tiling)
        b = _random_canvas(CpuCanvas, 5, params=prm, tiling=tiling)
        _step_both_bitwise(a, b, 6)
        sc = b._scratch()  # type: ignore[attr-defined]
        assert bool(sc.a2["w0"].any()) is copied and bool(sc.a3["p0"].any()) is copied
        assert b.live_state.w.sum() > 0 and b.live_state.p.sum() > 0


def test_a_cell_rounded_below_zero_gives_nothing_and_breaks_nothing() -> None:
    """The donor limiter of passes 4/5 leaves a cell at most a rounding error below 0; such
    a cell holds nothing. It used to be divided by its zero outflow (-inf, then NaN fluxes
    that spread and wiped a whole wash: the demo's sky at 400x300 with the fibre
    dispersion). Now it gives nothing, in the reference and the cpu kernels alike."""
    u = np.zeros((1, 5, 5), np.float32)
    u[0, 2, 2] = np.float32(-1e-9)
    u[0, 0, 0] = np.float32(0.5)
    out = ref.implicit_diffusion(u, np.full((5, 4), 3.0, np.float32),
                                       np.full((4, 5), 3.0, np.float32), 0.4, 4)
    assert np.isfinite(out).all() and out[0, 2, 2] >= u[0, 2, 2]
    a = _random_canvas(NumpyCanvas, 8)
    b = _random_canvas(CpuCanvas, 8)
    for c in (a, b):
        st = c.live_state
        st.p[0, 18:22, 24:28] = np.float32(0.0)
        st.p[0, 20, 26] = np.float32(-1e-9)  # inside the wet stroke
        st.w[20, 26] = np.float32(-1e-9)
    for _ in range(5):
        for c in (a, b):
            c.step()
    for f in FIELDS:
        assert np.isfinite(getattr(a.live_state, f)).all(), f
        assert np.array_equal(getattr(a.live_state, f), getattr(b.live_state, f)), f


def test_drying_trail_on_tiles_is_bitwise_equal() -> None:
    """A stroke, then fast drying without painting: inside the still active tiles more and
    more cells come to rest (the cpu step computes only the cells near live cells, and
    looks for water only in the halo strips of tiles next to active ones); every field
    and the tile TTLs stay bit for bit the reference's while tiles leave the active set."""
    from station.bench.sim import _StrokePath

    prm = dataclasses.replace(get_profile("watercolor").params, airflow=5.0,
                              temperature=35.0, humidity=0.0)
    a = NumpyCanvas(192, 160, seed=5, tiling=True, params=prm)
    b = CpuCanvas(192, 160, seed=5, tiling=True, params=prm)
    sa, sb = _StrokePath(a, 192, 160, radius=5.0), _StrokePath(b, 192, 160, radius=5.0)
    for _ in range(40):
        for c, s in ((a, sa), (b, sb)):
            s.advance()
            c.step()
    peak = int((b.live_state.tile_ttl > 0).sum())
    resting = 0
    for _ in range(160):
        a.step()
        b.step()
        st = b.live_state
        live = (st.w != 0) | (st.wc != 0) | (st.vx != 0) | (st.p != 0).any(0)
        tile_cells = int((st.tile_ttl > 0).sum()) * st.params.tile_size ** 2
        resting += int(tile_cells > 2 * int(live.sum()))
    assert resting > 80, resting  # many active-tile cells at rest: live spans exercised
    assert int((b.live_state.tile_ttl > 0).sum()) < peak  # tiles dried out and left
    for f in (*FIELDS, "tile_ttl"):
        assert np.array_equal(getattr(a.live_state, f), getattr(b.live_state, f)), f
    assert a.live_state.q.sum() > 0


@pytest.mark.parametrize("tiling", [False, True])
def test_uniform_wash_blur_runs_are_bitwise_equal(tiling: bool) -> None:
    """A fully wet wash (``station bench sim``'s) blurs rows of one value: prep keeps each
    row's run of one x-blurred value and the y halves fill it with the taps' sum of that
    value instead of adding the taps (issue 26 item 3). The rows through a dry hole have
    no run, the damp top half and the dry bottom half of the paper give the not-dry mask's
    runs two values: every field bit for bit against the reference."""
    from station.bench._sim_driver import wash

    w, h = 72, 60
    runs = []
    for cls in (NumpyCanvas, CpuCanvas):
        c = cls(w, h, profile="watercolor", seed=3, tiling=tiling)
        wash(c, w, h)
        st = c.live_state
        st.w[24:30, 30:40] = 0  # a dry hole
        st.wc[:24] = (0.8 * st.capacity()[:24]).astype(np.float32)  # damp paper on top
        runs.append(c)
    _step_both_bitwise(*runs, 6)
    sc = runs[1]._scratch()
    full = sc.runs[:, 1:h + 1, 1] >= sc.runs[:, 1:h + 1, 0]
    assert full[0].sum() > h // 2 and full[1].sum() > h // 2  # most rows have a run
    assert not full[0].all()  # not those through the hole
    assert len(set(sc.rvals[1, 1:h + 1][full[1]].tolist())) == 2  # damp and dry paper


def test_any_nonzero_is_numpys_any() -> None:
    """The step's test for a paper with fibres (K.any_nonzero, early exit) answers as
    numpy's ``any``: -0 is zero, NaN and the smallest denormal are not, a non-zero in the
    last value counts."""
    import station.backends.cpu.kernels as K

    a = np.zeros((2, 7, 1000), np.float32)  # 14000 values: three blocks and a part
    cases = [(), ((0, 0, 0), np.float32(-0.0)), ((1, 6, 999), np.float32(2.0)),
             ((1, 3, 5), np.float32(np.nan)), ((0, 4, 2), np.float32(1e-45)),
             ((0, 0, 1), np.float32(-3.0))]
    for case in cases:
        b = a.copy()
        if case:
            b[case[0]] = case[1]
        assert K.any_nonzero(b.reshape(-1).view(np.uint32)) == bool(b.any()), case


@pytest.mark.parametrize("nu_p", [None, 0.4])
def test_binding_limiters_are_bitwise_equal(nu_p: float | None) -> None:
    """The donor and receiver limiters where they bind (issue 26: their divisions run
    only on spans where some cell needs one): water under w_min that the flow carries off,
    water at w_max and pigment near 1 that the flow fills, a pigment checkerboard that
    strong diffusion empties; every field bit for bit against the reference."""
    prm = get_profile("watercolor").params
    if nu_p is not None:
        prm = dataclasses.replace(prm, nu_p=nu_p)
    runs = []
    for cls in (NumpyCanvas, CpuCanvas):
        c = _random_canvas(cls, 5, params=prm)
        st = c.live_state
        st.w[6:12, 8:20] = np.float32(0.5 * prm.w_min)
        st.w[20:26, 8:20] = np.float32(prm.w_max)
        st.p[0, 20:26, 22:34] = np.float32(0.995)
        yy, xx = np.mgrid[0:8, 0:10]
        st.p[1, 14:22, 24:34] = ((yy + xx) % 2).astype(np.float32)
        runs.append(c)
    _step_both_bitwise(*runs, 8)


def _bloom_canvas(cls: type[NumpyCanvas], tiling: bool) -> NumpyCanvas:
    """Fresh water on a damp wash: the paper 90 % full everywhere, no wet-area memory, a
    ragged blob of water in the middle (the fronts damp_exposure acts on)."""
    rng = np.random.default_rng(4)
    h, w = 48, 56
    c = cls(w, h, profile="watercolor", seed=4, tiling=tiling)
    st = c.live_state
    st.wc[...] = (0.9 * st.capacity()).astype(np.float32)
    yy, xx = np.mgrid[0:h, 0:w]
    blob = ((yy - 24) ** 2 + (xx - 28) ** 2) < (9 + 3 * rng.uniform(0, 1, (h, w))) ** 2
    fp = blob.astype(np.float32)
    c.add_sources(dw=fp * rng.uniform(0.2, 0.6, (h, w)).astype(np.float32),
                  dp={PIGMENTS[0]: 0.1 * fp})
    return c


@pytest.mark.parametrize("tiling", [False, True])
def test_damp_exposure_is_bitwise_equal(tiling: bool) -> None:
    """stencils.sheltered in the cpu prep (_pin, _blur_y_at): 30 steps of water running
    out into damp paper, bit for bit; and the rule held some damp cells out."""
    a = _bloom_canvas(NumpyCanvas, tiling)
    b = _bloom_canvas(CpuCanvas, tiling)
    st = a.live_state
    prm = st.params
    assert prm.damp_exposure > 0
    area = ref.wet_memory(ref.own_wet(st.w, st.wc, st.mask, prm), st.wet_area, prm)
    held = ref.wet_mask(st.w, st.wc, st.mask, prm, st.h, st.fibre)
    held &= ~ref.wet_mask(st.w, st.wc, st.mask, prm, st.h, st.fibre, area)
    assert held.sum() >= 10, held.sum()
    _step_both_bitwise(a, b, 30)


@pytest.mark.parametrize("stop_after", ["advect_velocity", "water_height_and_boundary"])
def test_damp_exposure_pass_by_pass(stop_after: str) -> None:
    a = _bloom_canvas(NumpyCanvas, False)
    b = _bloom_canvas(CpuCanvas, False)
    sa, sb = a.live_state, b.live_state
    box = (slice(0, sa.height), slice(0, sa.width))
    ref.step_region(sa, box, sa.params.dt, stop_after=stop_after)
    assert isinstance(b, CpuCanvas)
    cpu_step.step_region(sb, box, sb.params.dt, b._scratch(), stop_after=stop_after)
    for f in FIELDS:
        assert np.array_equal(getattr(sa, f), getattr(sb, f)), (stop_after, f)
