"""GL passes against the NumPy reference, pass by pass, on random but plausible input.

Each test loads the same random canvas state into a ``GLCanvas`` (real shaders on
the machine's OpenGL, llvmpipe here), runs one program group and compares the
fields it writes with the reference functions of ``station/canvas/reference.py``.

Tolerance: max abs error <= 1e-5 x max(1, field scale) (float32 rounding; the
GPU may contract a*b+c into FMA).  On llvmpipe the results are in fact bitwise
equal, which the tests also report in their failure messages.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from station.canvas import reference as ref
from station.canvas.palette import default_palette
from station.canvas.paper import make_fibres
from station.canvas.params import SimParams
from station.canvas.state import CanvasState
from station.render.km import render_state, to_linear_rgb

gl = pytest.importorskip("station.backends.gl")

W, H = 48, 40
SLOTS6 = ["French Ultramarine", "Cerulean Blue", "Hansa Yellow", "Burnt Umber",
          "Quinacridone Rose", "Phthalo Green"]  # 6 slots: both RGBA layers in use
REL_TOL = 1e-5


@pytest.fixture(scope="module")
def ctx():
    try:
        c = gl.create_context()
    except gl.GLUnavailable as exc:
        pytest.skip(f"no OpenGL 4.3 context: {exc}")
    yield c
    c.release()


def random_state(seed: int = 5, params: SimParams | None = None, tiling: bool = False,
                 slots: list[str] | None = None) -> CanvasState:
    """A plausible mid-painting state: a wet blob with a dry island, moist margins,
    deposits everywhere, a masked square, a fading blocking pattern."""
    rng = np.random.default_rng(seed)
    prm = params or SimParams()
    h = rng.uniform(0, 1, (H, W)).astype(np.float32)
    st = CanvasState.blank(W, H, prm, h, tiling=tiling, palette=default_palette())
    yy, xx = np.mgrid[0:H, 0:W]
    blob = ((yy - 20) ** 2 / 15.0 ** 2 + (xx - 22) ** 2 / 18.0 ** 2) < 1.0
    blob &= ~((abs(yy - 20) < 3) & (abs(xx - 22) < 3))  # dry island
    w = np.where(blob, rng.uniform(0.0, 1.0, (H, W)), 0).astype(np.float32)
    w[blob & (rng.uniform(0, 1, (H, W)) < 0.05)] = 3e-6  # a few cells about to dry
    cap = st.capacity()
    margin = ((yy - 20) ** 2 / 18.0 ** 2 + (xx - 22) ** 2 / 21.0 ** 2) < 1.0
    wc = np.where(margin, rng.uniform(0, 1, (H, W)) * cap, 0).astype(np.float32)
    st.w[...] = w
    st.wc[...] = wc
    vm = prm.v_max
    st.vx[...] = np.where(blob, rng.uniform(-vm, vm, (H, W)), 0).astype(np.float32)
    st.vy[...] = np.where(blob, rng.uniform(-vm, vm, (H, W)), 0).astype(np.float32)
    names = slots if slots is not None else SLOTS6
    for name in names:
        st.slot_of(name)
    n = len(names)
    st.p[:n] = np.where(blob, rng.uniform(0, 0.4, (n, H, W)), 0).astype(np.float32)
    st.p[:n, 5, 5] = 0.97  # near the top of the range (inflow limiter)
    st.q[:n] = rng.uniform(0, 0.5, (n, H, W)).astype(np.float32)
    st.mask[30:34, 8:12] = 1
    st.block[...] = rng.uniform(0.2, 1, (H, W)).astype(np.float32)
    st.block_time[...] = rng.uniform(0, 1.5, (H, W)).astype(np.float32)
    st.sim_time = 1.0
    st.evaporated[...] = rng.uniform(0, 0.1, (H, W)).astype(np.float32)
    st.r_composed[...] = rng.uniform(0.3, 1, st.r_composed.shape).astype(np.float32)
    # the wet-area memory of damp paper (used only with wet_hold > 0)
    st.wet_area[...] = np.where(wc > 0, rng.uniform(0, 1, (H, W)), 0).astype(np.float32)
    return st


def close(name: str, got: np.ndarray, want: np.ndarray) -> None:
    scale = max(1.0, float(np.abs(want).max()))
    err = float(np.abs(got.astype(np.float64) - want).max())
    assert err <= REL_TOL * scale, f"{name}: max abs err {err:.3g} (scale {scale:.3g})"


def gl_canvas(ctx, st: CanvasState):
    c = gl.GLCanvas(st.width, st.height, ctx=ctx, tiling=st.tiling, n_slots=st.n_slots)
    c.load_state(st)
    c._set_step_uniforms(st.params.dt)
    c._begin_step()
    return c


def read_rgba(c, tex, comps: int = 4) -> np.ndarray:
    return np.frombuffer(tex.read(), np.float32).reshape(H, W, comps)


def test_state_round_trip_is_lossless(ctx) -> None:
    st = random_state(1)
    c = gl.GLCanvas(W, H, ctx=ctx)
    c.load_state(st)
    back = c.state()
    for name in ("vx", "vy", "w", "wc", "h", "mask", "block", "block_time", "p", "q",
                 "r_composed", "evaporated", "removed_w", "removed_p", "tile_ttl", "fibre",
                 "wet_area"):
        assert np.array_equal(getattr(back, name), getattr(st, name)), name
    assert back.slots == st.slots and back.sim_time == st.sim_time
    assert back.water_added == st.water_added


def test_prep_wet_controller_and_velocity_advection(ctx) -> None:
    st = random_state(2)
    prm = st.params
    c = gl_canvas(ctx, st)
    c._pass_prep()
    wet = ref.wet_mask(st.w, st.wc, st.mask, prm, st.h)
    vx1, vy1 = ref.advect_velocity(st.vx, st.vy, wet, prm.dt)
    aux = read_rgba(c, c.aux)
    close("advected vx", aux[..., 0], vx1)
    close("advected vy", aux[..., 1], vy1)
    assert np.array_equal(aux[..., 2], st.w)  # the water right-hand side
    jv = read_rgba(c, c.jv[0])
    beta_c = ref.blocking(st.h, st.block, st.block_time, st.sim_time, prm)
    assert np.array_equal(jv[..., 3] >= 0, wet)
    close("beta_c", jv[..., 3][wet], beta_c[wet])
    assert wet.sum() > 500 and (~wet).sum() > 300  # both kinds of cell present


def test_prep_front_runs_along_fibres(ctx) -> None:
    """fibre_wick: the advancing height is lowered along the paper's fibres, per axis."""
    st = random_state(2, params=SimParams(fibre_wick=1.0))
    st.fibre = make_fibres("rough", H, W, 3)
    c = gl_canvas(ctx, st)
    c._pass_prep()
    wet = ref.wet_mask(st.w, st.wc, st.mask, st.params, st.h, st.fibre)
    jv = read_rgba(c, c.jv[0])
    assert np.array_equal(jv[..., 3] >= 0, wet)
    plain = ref.wet_mask(st.w, st.wc, st.mask, st.params, st.h)
    assert (wet & ~plain).sum() >= 5  # the fibres carried the front on


def test_prep_damp_paper_eases_the_front(ctx) -> None:
    """damp_ease: the advancing height into a damp cell falls with its saturation."""
    prm = SimParams(damp_ease=3.0, damp_sat=0.3, moist_threshold=1.0)
    st = random_state(2, params=prm)
    c = gl_canvas(ctx, st)
    c._pass_prep()
    wet = ref.wet_mask(st.w, st.wc, st.mask, prm, st.h)
    jv = read_rgba(c, c.jv[0])
    assert np.array_equal(jv[..., 3] >= 0, wet)
    plain = ref.wet_mask(st.w, st.wc, st.mask, prm.replace(damp_ease=0.0), st.h)
    assert (wet & ~plain).sum() >= 5  # damp cells let the front in


def test_damp_exposure_keeps_the_front_out_of_its_bays(ctx) -> None:
    """damp_exposure: after blur_x (shelter.comp) a damp cell the front reached joins only
    where the blurred wet-area mask leaves it exposed (stencils.sheltered); its velocity
    right-hand side is a non-wet cell's."""
    prm = SimParams(damp_ease=3.0, damp_sat=0.3, moist_threshold=1.0, wet_hold=4.0,
                    flow_outward=0.5, damp_exposure=0.6)
    st = random_state(2, params=prm)
    c = gl_canvas(ctx, st)
    c._pass_prep()
    area_m = ref.wet_memory(ref.own_wet(st.w, st.wc, st.mask, prm), st.wet_area, prm)
    wet = ref.wet_mask(st.w, st.wc, st.mask, prm, st.h, None, area_m)
    jv = read_rgba(c, c.jv[0])
    assert np.array_equal(jv[..., 3] >= 0, wet)
    vx1, vy1 = ref.advect_velocity(st.vx, st.vy, wet, prm.dt)
    aux = read_rgba(c, c.aux)
    close("advected vx", aux[..., 0], vx1)
    close("advected vy", aux[..., 1], vy1)
    loose = ref.wet_mask(st.w, st.wc, st.mask, prm, st.h)
    assert (loose & ~wet).sum() >= 5  # damp cells in the front's bays held out


def test_full_steps_with_damp_exposure_match_reference(ctx) -> None:
    st = random_state(8, params=SimParams(wet_hold=0.3, flow_outward=0.5, damp_ease=4.0,
                                          damp_sat=0.5, suspend_sat=0.5, damp_exposure=0.6,
                                          moist_threshold=1.0))
    _steps_match_reference(ctx, st, 4, ("vx", "vy", "w", "wc", "p", "q", "evaporated",
                                        "wet_area"))


def test_prep_pins_the_front_on_dry_paper(ctx) -> None:
    """A crept cell on paper no damper than damp_sat needs two 4-neighbours wet or crept
    (stencils.pinned): GL's wet mask is the reference's, and the rule takes cells out."""
    prm = SimParams(damp_sat=0.9, moist_threshold=1.0)
    st = random_state(2, params=prm)
    c = gl_canvas(ctx, st)
    c._pass_prep()
    wet = ref.wet_mask(st.w, st.wc, st.mask, prm, st.h)
    jv = read_rgba(c, c.jv[0])
    assert np.array_equal(jv[..., 3] >= 0, wet)
    # the same front with every cell's paper counted damp (s = 1 > 0): nothing pinned
    loose = ref.wet_mask(st.w, np.full_like(st.wc, 1.0), st.mask, prm.replace(damp_sat=0.0),
                         st.h)
    assert (loose & ~wet).sum() >= 3  # lone fingers held back


def test_prep_front_curvature(ctx) -> None:
    """advance_curvature (stencils.front_curvature): on drier paper the neighbourhood's
    water, diagonals included, sets the reach; GL's wet mask is the reference's, with and
    without fibres, and the term changes which cells the front takes."""
    for wick in (0.0, 0.6):
        prm = SimParams(advance_curvature=1.0, damp_sat=0.9, moist_threshold=1.0,
                        fibre_wick=wick)
        st = random_state(2, params=prm)
        st.fibre = make_fibres("rough", H, W, 3)
        c = gl_canvas(ctx, st)
        c._pass_prep()
        wet = ref.wet_mask(st.w, st.wc, st.mask, prm, st.h, st.fibre)
        jv = read_rgba(c, c.jv[0])
        assert np.array_equal(jv[..., 3] >= 0, wet), wick
        plain = ref.wet_mask(st.w, st.wc, st.mask, prm.replace(advance_curvature=0.0), st.h,
                             st.fibre)
        assert (wet != plain).sum() >= 3, wick


def test_damp_paper_keeps_its_pigment_suspended(ctx) -> None:
    """suspend_sat: a cell without fluid water but with saturated paper keeps p."""
    prm = SimParams(suspend_sat=0.5)
    st = random_state(7, params=prm)
    st.p[:6] = np.where(st.wc > 0, 0.2, st.p[:6]).astype(np.float32)
    c = gl_canvas(ctx, st)
    c._pass_capillary_dry()
    out = c.state()
    no_absorb = prm.replace(alpha=0.0)
    w, wc, evap = ref.capillary(st.w, st.wc, st.h, st.mask, st.evaporated, no_absorb, prm.dt)
    w, p, q, vx, vy, evap = ref.dry_cells(w, st.p[:6], st.q[:6], st.vx, st.vy, evap, prm,
                                          wc, st.h)
    close("suspended pigment (10)", out.p[:6], p)
    close("velocity y (10)", out.vy, vy)
    close("deposited pigment (10)", out.q[:6], q)
    close("velocity (10)", out.vx, vx)
    held = (out.w == 0) & (out.p[0] > 0)
    assert held.sum() >= 20  # damp cells kept pigment in suspension


def _steps_match_reference(ctx: Any, st: CanvasState, steps: int,
                           names: tuple[str, ...]) -> CanvasState:
    """``steps`` whole GL steps from ``st`` (untiled) against the reference's, field by
    field; returns the reference's state."""
    c = gl.GLCanvas(W, H, ctx=ctx, tiling=False)
    c.load_state(st)
    for _ in range(steps):
        c.step()
    mine = st.copy()
    for _ in range(steps):
        ref.step(mine)
    out = c.state()
    for name in names:
        close(name, getattr(out, name), getattr(mine, name))
    return mine


def test_full_step_on_damp_paper_matches_reference(ctx) -> None:
    st = random_state(8, params=SimParams(damp_ease=8.0, damp_sat=0.5, suspend_sat=0.6,
                                          moist_threshold=1.0))
    _steps_match_reference(ctx, st, 3, ("vx", "vy", "w", "wc", "p", "q", "evaporated"))


def test_wet_area_mask_grows_and_flow_outward_blurs_it(ctx) -> None:
    """wet_hold: prep keeps max(wet_area, own) and pass 3's pressure blurs that mask (the
    levelled height is formed in the first Jacobi iteration, so the diffusion runs too)."""
    prm = SimParams(wet_hold=4.0, flow_outward=0.5)
    st = random_state(3, params=prm)
    c = gl_canvas(ctx, st)
    c._pass_prep()
    c._pass_diffusion()
    own = ref.own_wet(st.w, st.wc, st.mask, prm)
    area_m = ref.wet_memory(own, st.wet_area, prm)
    got = np.frombuffer(c.f["area"].src.read(), np.float32).reshape(H, W)
    assert np.array_equal(got, area_m)
    wet = ref.wet_mask(st.w, st.wc, st.mask, prm, st.h)
    pr = ref.flow_pressure(st.w, area_m, wet, st.h, prm)
    close("pressure with the wet-area mask", read_rgba(c, c.pr, 1)[..., 0], pr)
    plain = ref.flow_pressure(st.w, own, wet, st.h, prm)
    assert np.abs(pr - plain).max() > 1e-3  # the memory changed the pressure
    assert ((area_m > 0) & ~own).sum() >= 20  # damp cells remembered as wet


def test_pressure_blur_follows_a_new_wet_blur_of_the_same_width(ctx) -> None:
    """The blur's taps are constants of its programs: wet_blur 3.2 then 3.5 (15 taps both)
    must recompile them, not keep 3.2's taps."""
    st = random_state(3, params=SimParams(wet_blur=3.2, flow_outward=0.5))
    c = gl_canvas(ctx, st)
    c._pass_prep()
    c._pass_diffusion()
    first = read_rgba(c, c.pr, 1)[..., 0].copy()
    st.params = st.params.replace(wet_blur=3.5)
    assert len(ref.gaussian_taps(3.2)) == len(ref.gaussian_taps(3.5))
    c.load_state(st)
    c._set_step_uniforms(st.params.dt)
    c._begin_step()
    c._pass_prep()
    c._pass_diffusion()
    wet = ref.wet_mask(st.w, st.wc, st.mask, st.params, st.h)
    own = ref.own_wet(st.w, st.wc, st.mask, st.params)
    got = read_rgba(c, c.pr, 1)[..., 0]
    close("pressure after the new wet_blur", got, ref.flow_pressure(st.w, own, wet, st.h,
                                                                    st.params))
    assert np.abs(got - first).max() > 1e-5  # the taps changed the pressure


@pytest.mark.parametrize("front", [0.0, 0.04])
def test_pressure_pull_cut_to_the_contact_line(ctx, front: float) -> None:
    """rim_sharpness: pass 3's pull is flow_outward ((1 - k) u + k s), s the dry share u =
    1 - M' ramped between rim_onset and rim_full (pull.glsl), formed in the first Jacobi
    iteration (pressure.glsl) or, with the standing gate's front factor, in front.comp."""
    prm = SimParams(wet_blur=3.0, flow_outward=0.5, rim_sharpness=0.7, rim_onset=0.15,
                    rim_full=0.4, standing_depth=0.3 if front else 0.0,
                    standing_nu_p=0.005 if front else 0.0, standing_front_pull=front)
    st = random_state(4, params=prm)
    c = gl_canvas(ctx, st)
    c._pass_prep()
    c._pass_diffusion()
    wet = ref.wet_mask(st.w, st.wc, st.mask, prm, st.h)
    own = ref.own_wet(st.w, st.wc, st.mask, prm)
    got = read_rgba(c, c.pr, 1)[..., 0]
    want = ref.flow_pressure(st.w, own, wet, st.h, prm)
    close("pressure with the sharp pull", got, want)
    plain = ref.flow_pressure(st.w, own, wet, st.h, prm.replace(rim_sharpness=0.0))
    assert np.abs(want - plain).max() > 1e-2  # the sharp share changed the pressure


def test_wet_area_fades_at_the_end_of_pass_10(ctx) -> None:
    prm = SimParams(wet_hold=0.5)
    st = random_state(7, params=prm)
    c = gl_canvas(ctx, st)
    c._pass_capillary_dry()
    out = c.state()
    n = len(st.slots)
    no_absorb = prm.replace(alpha=0.0)
    w, wc, evap = ref.capillary(st.w, st.wc, st.h, st.mask, st.evaporated, no_absorb, prm.dt)
    w = ref.dry_cells(w, st.p[:n], st.q[:n], st.vx, st.vy, evap, prm)[0]
    want = ref.wet_area_update(st.wet_area, w, wc, st.mask, prm, prm.dt)
    close("wet_area (10)", out.wet_area, want)
    faded = (want > 0) & (want < 1)
    assert faded.sum() >= 20 and (st.wet_area[faded] > want[faded]).all()


def test_full_steps_with_the_wet_area_memory_match_reference(ctx) -> None:
    st = random_state(8, params=SimParams(wet_hold=0.3, flow_outward=0.5, damp_ease=4.0,
                                          damp_sat=0.5, suspend_sat=0.5,
                                          moist_threshold=1.0))
    mine = _steps_match_reference(ctx, st, 4, ("vx", "vy", "w", "wc", "p", "q", "evaporated",
                                                "wet_area"))
    assert ((mine.wet_area > 0) & (mine.wet_area < 1)).sum() >= 20


def test_prep_fibre_dispersion(ctx) -> None:
    """fibre_dispersivity: beta_c times 1 + gd max(fibre) |v| (v at the step's start)."""
    st = random_state(3, params=SimParams(fibre_dispersivity=4.5))
    st.fibre = make_fibres("cold-press", H, W, 3)
    c = gl_canvas(ctx, st)
    c._pass_prep()
    wet = ref.wet_mask(st.w, st.wc, st.mask, st.params, st.h, st.fibre)
    beta_c = ref.blocking(st.h, st.block, st.block_time, st.sim_time, st.params, st.fibre,
                          ref.water_speed(st.vx, st.vy, st.params))
    jv = read_rgba(c, c.jv[0])
    close("beta_c", jv[..., 3][wet], beta_c[wet])
    assert (beta_c[wet] > 2).sum() > 50  # the fibres' dispersion is in play


def test_full_step_with_fibre_dispersion_matches_reference(ctx) -> None:
    st = random_state(4, params=SimParams(fibre_dispersivity=4.5))
    st.fibre = make_fibres("cold-press", H, W, 4)
    c = gl.GLCanvas(W, H, ctx=ctx, tiling=False)
    c.load_state(st)
    c.step()
    got = c.state()
    want = st.copy()
    ref.step(want)
    for name in ("vx", "vy", "w", "wc", "p", "q", "evaporated"):
        close(name, getattr(got, name), getattr(want, name))
    plain = st.copy()
    plain.params = SimParams()
    ref.step(plain)
    assert not np.array_equal(plain.p, want.p)  # the dispersion changed the step


def test_levelling_flow_runs_along_the_fibres(ctx) -> None:
    """fibre_permeability: pass 3's height term along each axis times 1 - a + 4 a fibre
    (the fibre texture read through a sampler in limit.comp), then a full step."""
    prm = SimParams(fibre_permeability=1.0, fibre_dispersivity=9.0, nu_p=0.02)
    st = random_state(5, prm)
    st.fibre = make_fibres("cold-press", H, W, 5)
    c = gl_canvas(ctx, st)
    c._pass_prep()
    c._pass_diffusion()
    out = c.state()
    wet = ref.wet_mask(st.w, st.wc, st.mask, prm, st.h, st.fibre)
    vx, vy = ref.advect_velocity(st.vx, st.vy, wet, prm.dt)
    vx, vy = ref.diffuse_velocity(vx, vy, wet, prm, prm.dt)
    pr = ref.flow_pressure(st.w, ref.own_wet(st.w, st.wc, st.mask, prm), wet, st.h, prm)
    vx, vy = ref.water_height_and_boundary(vx, vy, pr, wet, prm, prm.dt, st.fibre)
    close("velocity x (passes 1-3)", out.vx, vx)
    close("velocity y (passes 1-3)", out.vy, vy)
    vx0, _ = ref.water_height_and_boundary(*ref.diffuse_velocity(
        *ref.advect_velocity(st.vx, st.vy, wet, prm.dt), wet, prm, prm.dt), pr, wet, prm)
    assert np.abs(vx0 - vx).max() > 1e-2  # the fibres channel the flow
    c = gl.GLCanvas(W, H, ctx=ctx, tiling=False)
    c.load_state(st)
    c.step()
    got = c.state()
    want = st.copy()
    ref.step(want)
    for name in ("vx", "vy", "w", "wc", "p", "q", "evaporated"):
        close(name, getattr(got, name), getattr(want, name))


@pytest.mark.parametrize("fibred", [True, False])
def test_standing_water_gates_the_channel_and_the_diffusion(ctx, fibred: bool) -> None:
    """fibre_gate_depth: pass 3's channel faded in by the standing water, off where the flow
    outward pulls (fibre_gate_pull, with the relief term) and on paper without fibre
    (u_fibred); standing_depth: beta_c's own share 1 - drop smoothstep(w /
    depth) (prep.comp); passes 1-3 and beta_c against the reference, then a full step."""
    prm = SimParams(fibre_permeability=1.0, fibre_dispersivity=9.0, fibre_gate_depth=0.4,
                    fibre_gate_pull=0.1, paper_relief=0.2, standing_depth=0.3,
                    standing_nu_p=0.005)
    st = random_state(6, prm)
    st.fibre = make_fibres("cold-press", H, W, 6) if fibred else np.zeros((2, H, W), np.float32)
    c = gl_canvas(ctx, st)
    c._pass_prep()
    wet = ref.wet_mask(st.w, st.wc, st.mask, prm, st.h, st.fibre)
    standing = ref.standing_gate(st.w, prm.standing_diffusion()[0])
    beta_c = ref.blocking(st.h, st.block, st.block_time, st.sim_time, prm, st.fibre,
                          ref.water_speed(st.vx, st.vy, prm), standing)
    close("beta_c", read_rgba(c, c.jv[0])[..., 3][wet], beta_c[wet])
    c._pass_diffusion()
    out = c.state()
    vx, vy = ref.advect_velocity(st.vx, st.vy, wet, prm.dt)
    vx, vy = ref.diffuse_velocity(vx, vy, wet, prm, prm.dt)
    pr = ref.flow_pressure(st.w, ref.own_wet(st.w, st.wc, st.mask, prm), wet, st.h, prm)
    gate = ref.fibre_gate(st, st.w, st.h, pr)
    assert gate is not None and (bool(((gate > 0) & (gate < 1)).any()) == fibred)
    vx, vy = ref.water_height_and_boundary(vx, vy, pr, wet, prm, prm.dt, st.fibre, gate)
    close("velocity x (passes 1-3)", out.vx, vx)
    close("velocity y (passes 1-3)", out.vy, vy)
    c = gl.GLCanvas(W, H, ctx=ctx, tiling=False)
    c.load_state(st)
    c.step()
    got = c.state()
    want = st.copy()
    ref.step(want)
    for name in ("vx", "vy", "w", "wc", "p", "q", "evaporated"):
        close(name, getattr(got, name), getattr(want, name))


@pytest.mark.parametrize("dry", [0.0, 0.5])
def test_standing_gate_front_keeps_the_diffusion_at_the_edge(ctx, dry: float) -> None:
    """standing_front_pull: the standing gate times 1 - smoothstep(eta (1 - M') / pull)
    (front.comp after blur_x, which M' needs), with standing_front_dry times min(2 (1 -
    D'), 1), D' the blurred not-dry paper (blur_x's dx): beta_c against the reference's
    standing_front (and not the plain gate's); front.comp also forms pass 3's levelled
    height (with the paper's relief for dry 0.5), which the first Jacobi iteration then
    leaves alone; then a full step."""
    prm = SimParams(fibre_permeability=1.0, fibre_dispersivity=9.0, standing_depth=0.3,
                    standing_nu_p=0.005, standing_front_pull=0.04, standing_front_dry=dry,
                    wet_blur=2.0, flow_outward=0.3, paper_relief=0.4 * dry)
    st = random_state(6, prm)
    st.fibre = make_fibres("cold-press", H, W, 6)
    c = gl_canvas(ctx, st)
    c._pass_prep()
    wet = ref.wet_mask(st.w, st.wc, st.mask, prm, st.h, st.fibre)
    plain = ref.standing_gate(st.w, prm.standing_diffusion()[0])
    area = ref.wet_memory(ref.own_wet(st.w, st.wc, st.mask, prm), st.wet_area, prm)
    standing = ref.standing_front(plain, area, st.wc, st.h, prm)
    speed = ref.water_speed(st.vx, st.vy, prm)
    beta_c = ref.blocking(st.h, st.block, st.block_time, st.sim_time, prm, st.fibre, speed,
                          standing)
    beta_plain = ref.blocking(st.h, st.block, st.block_time, st.sim_time, prm, st.fibre,
                              speed, plain)
    assert float(np.abs(beta_c - beta_plain)[wet].max()) > 0.1
    close("beta_c", read_rgba(c, c.jv[0])[..., 3][wet], beta_c[wet])
    close("levelled height", read_rgba(c, c.pr, 1)[..., 0],
          ref.flow_pressure(st.w, area, wet, st.h, prm))
    c = gl.GLCanvas(W, H, ctx=ctx, tiling=False)
    c.load_state(st)
    c.step()
    got = c.state()
    want = st.copy()
    ref.step(want)
    for name in ("vx", "vy", "w", "wc", "p", "q", "evaporated"):
        close(name, getattr(got, name), getattr(want, name))


@pytest.mark.parametrize("iters", [1, 4])
def test_velocity_water_pigment_diffusion(ctx, iters: int) -> None:
    # paper relief on for odd counts: pass 3 then levels (w + relief h) - eta (1 - M')
    prm = SimParams(jacobi_iters=iters, block_paper=0.5, nu_p=2.0, nu_w=1.0,
                    paper_relief=0.5 * (iters % 2))
    st = random_state(3, prm)
    c = gl_canvas(ctx, st)
    c._pass_prep()
    c._pass_diffusion()
    out = c.state()
    wet = ref.wet_mask(st.w, st.wc, st.mask, prm, st.h)
    vx, vy = ref.advect_velocity(st.vx, st.vy, wet, prm.dt)
    vx, vy = ref.diffuse_velocity(vx, vy, wet, prm, prm.dt)
    pr = ref.flow_pressure(st.w, ref.own_wet(st.w, st.wc, st.mask, prm), wet, st.h, prm)
    vx, vy = ref.water_height_and_boundary(vx, vy, pr, wet, prm)
    close("velocity x (passes 1-3)", out.vx, vx)
    close("velocity y (passes 1-3)", out.vy, vy)
    w = ref.diffuse_water(st.w, wet, prm, prm.dt)
    close("water (pass 4)", out.w, w)
    beta_c = ref.blocking(st.h, st.block, st.block_time, st.sim_time, prm)
    n = len(st.slots)
    p = ref.diffuse_pigment(st.p[:n], wet, beta_c, prm, prm.dt)
    close("pigment (pass 5)", out.p[:n], p)
    assert np.abs(out.w - st.w).max() > 1e-4  # the pass did something
    # untouched fields stay bitwise
    assert np.array_equal(out.wc, st.wc) and np.array_equal(out.q, st.q)


def test_water_and_pigment_advection(ctx) -> None:
    st = random_state(4)
    prm = st.params
    c = gl_canvas(ctx, st)
    c._pass_prep()
    c._pass_advect()
    out = c.state()
    wet = ref.wet_mask(st.w, st.wc, st.mask, prm, st.h)
    n = len(st.slots)
    w, p = ref.advect_water_and_pigment(st.w, st.p[:n], st.vx, st.vy, wet, prm, prm.dt)
    close("water (pass 6)", out.w, w)
    close("pigment (pass 6)", out.p[:n], p)
    assert np.abs(out.w - st.w).max() > 1e-3
    # conservation on the GPU too
    assert abs(float(out.w.sum(dtype=np.float64) - st.w.sum(dtype=np.float64))) < 1e-3


@pytest.mark.parametrize("lift_gain", [1.0, 5.0])
def test_evaporation_surface_exchange_absorption(ctx, lift_gain: float) -> None:
    """lift_gain: u_dob divides by the same float32 staining as slot_properties."""
    st = random_state(6, params=SimParams(lift_gain=lift_gain))
    prm = st.params
    c = gl_canvas(ctx, st)
    c._pass_prep()
    c._pass_evap_surface()
    out = c.state()
    wet = ref.wet_mask(st.w, st.wc, st.mask, prm, st.h)
    n = len(st.slots)
    w, evap = ref.evaporate(st.w, st.evaporated, prm, prm.dt)
    beta, gamma, delta = ref.slot_properties(st)
    p, q = ref.surface_exchange(st.p[:n], st.q[:n], w, st.h, wet, beta[:n], gamma[:n],
                                delta[:n], prm, prm.dt)
    # pass 9a alone: the reference capillary pass without diffusion and evaporation
    absorb_only = prm.replace(cap_diffusion=0.0, eps_cap=0.0)
    w, wc, evap = ref.capillary(w, st.wc, st.h, st.mask, evap, absorb_only, prm.dt)
    close("water (7, 9a)", out.w, w)
    close("capillary water (9a)", out.wc, wc)
    close("evaporated (7)", out.evaporated, evap)
    close("suspended pigment (8)", out.p[:n], p)
    close("deposited pigment (8)", out.q[:n], q)
    assert np.abs(out.q - st.q).max() > 1e-4


def test_capillary_diffusion_evaporation_and_drying(ctx) -> None:
    st = random_state(7)
    prm = st.params
    c = gl_canvas(ctx, st)
    c._pass_capillary_dry()
    out = c.state()
    n = len(st.slots)
    no_absorb = prm.replace(alpha=0.0)
    w, wc, evap = ref.capillary(st.w, st.wc, st.h, st.mask, st.evaporated, no_absorb, prm.dt)
    w, p, q, vx, vy, evap = ref.dry_cells(w, st.p[:n], st.q[:n], st.vx, st.vy, evap, prm)
    close("velocity y (10)", out.vy, vy)
    close("capillary water (9b, 9c)", out.wc, wc)
    close("water (10)", out.w, w)
    close("evaporated (9c, 10)", out.evaporated, evap)
    close("suspended pigment (10)", out.p[:n], p)
    close("deposited pigment (10)", out.q[:n], q)
    close("velocity (10)", out.vx, vx)
    assert np.abs(out.wc - st.wc).max() > 1e-4
    assert (st.w == 3e-6).any() and not (out.w == 3e-6).any()  # the drying cells dried


def test_one_full_step_matches_reference_step(ctx) -> None:
    st = random_state(8)
    c = gl.GLCanvas(W, H, ctx=ctx, tiling=False)
    c.load_state(st)
    c.step()
    mine = st.copy()
    ref.step(mine)
    out = c.state()
    for name in ("vx", "vy", "w", "wc", "p", "q", "evaporated"):
        close(name, getattr(out, name), getattr(mine, name))
    assert out.step_count == mine.step_count and out.sim_time == mine.sim_time


@pytest.mark.parametrize("bands", [3, 12])
@pytest.mark.parametrize("renderer", ["km", "gouache"])
def test_render_matches_render_py(ctx, renderer: str, bands: int) -> None:
    """render.comp against render.py, with Curtis's RGB bands and the 12 spectral ones."""
    st = random_state(9, params=SimParams(render_bands=bands))
    assert st.r_composed.shape == (H, W, bands)
    st.profile = "gouache" if renderer == "gouache" else "watercolor"
    c = gl.GLCanvas(W, H, ctx=ctx)
    c.load_state(st)
    got = c.render()
    want = render_state(st, renderer)
    assert got.shape == (H, W, 3) and got.dtype == np.float32
    err = float(np.abs(got - want).max())
    assert err < 2e-5, f"{renderer}: max abs err {err:.3g}"
    assert float(np.abs(want - to_linear_rgb(st.r_composed)).max()) > 0.05  # paint shows


def test_render_thin_paint_keeps_precision(ctx) -> None:
    """sinh of a small t: the shader's series keeps R accurate for very thin glazes."""
    st = random_state(10, slots=["Phthalo Green"])
    st.p[...] = 0
    st.q[0] = np.float32(1e-4)
    c = gl.GLCanvas(W, H, ctx=ctx)
    c.load_state(st)
    got = c.render()
    want = render_state(st, "km")
    assert float(np.abs(got - want).max()) < 2e-6


def test_step_constants_follow_dt_and_parameters(ctx) -> None:
    # the step's parameters are compile-time constants of the programs (passes.
    # param_constants); a step given another dt runs the uniform variant, new parameters
    # recompile, and every step still matches the reference's
    st = random_state(6)
    c = gl.GLCanvas(W, H, ctx=ctx, tiling=False)
    c.load_state(st)
    mine = st.copy()
    dt = st.params.dt
    for d in (dt, 0.5 * dt, dt):
        c.step(d)
        ref.step(mine, d)
        assert c._param_consts["DT_CONST"] == ("1" if d == dt else "0")
    out = c.state()
    for name in ("vx", "vy", "w", "wc", "p", "q", "evaporated"):
        close(name, getattr(out, name), getattr(mine, name))
    mine.params = mine.params.replace(nu_w=2.5 * mine.params.nu_w, w_max=0.8, tilt=8.0,
                                      tilt_direction=90.0)
    c.load_state(mine)
    assert "uintBitsToFloat" in c._param_consts["K_WMAX"]
    c.step()
    ref.step(mine)
    out = c.state()
    for name in ("vx", "vy", "w", "wc", "p", "q", "evaporated"):
        close(name, getattr(out, name), getattr(mine, name))
