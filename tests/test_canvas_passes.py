"""Pass-by-pass checks of the NumPy reference (the maths in reference.py's docstring)."""

from __future__ import annotations

import numpy as np

from station.canvas import reference as ref
from station.canvas.palette import default_palette
from station.canvas.params import CanvasInputError, SimParams
from station.canvas.removal import pickup
from station.canvas.state import CanvasState

PRM = SimParams()
DT = PRM.dt
RNG = np.random.default_rng(1234)


def _random_stroke(h: int = 24, w: int = 28, slots: int = 3):
    wet = np.zeros((h, w), bool)
    wet[3:20, 4:24] = True
    wet[8:12, 10:14] = False  # a dry island inside
    water = np.where(wet, RNG.uniform(0.0, 1.0, (h, w)), 0).astype(np.float32)
    pig = np.where(wet, RNG.uniform(0, 0.6, (slots, h, w)), 0).astype(np.float32)
    vx = np.where(wet, RNG.uniform(-30, 30, (h, w)), 0).astype(np.float32)
    vy = np.where(wet, RNG.uniform(-30, 30, (h, w)), 0).astype(np.float32)
    return wet, water, pig, vx, vy


def test_advection_conserves_clamps_and_respects_boundary() -> None:
    wet, w, p, vx, vy = _random_stroke()
    w2, p2 = ref.advect_water_and_pigment(w, p, vx, vy, wet, PRM, DT)
    assert abs(float(w2.sum(dtype=np.float64)) - float(w.sum(dtype=np.float64))) < 1e-4
    for k in range(p.shape[0]):
        assert abs(float(p2[k].sum(dtype=np.float64)) - float(p[k].sum(dtype=np.float64))) < 1e-4
    lo = np.minimum(w, PRM.w_min) - 1e-6
    hi = np.maximum(w, PRM.w_max) + 1e-6
    assert (w2[wet] >= lo[wet]).all() and (w2[wet] <= hi[wet]).all()
    assert p2.min() >= 0 and p2.max() <= 1 + 1e-6
    # non-wet cells neither give nor receive
    assert (w2[~wet] == w[~wet]).all() and (p2[:, ~wet] == p[:, ~wet]).all()
    # something did move
    assert np.abs(w2 - w).max() > 1e-3


def test_advection_flux_matches_formula_on_two_cells() -> None:
    wet = np.ones((1, 2), bool)
    w = np.array([[0.5, 0.3]], np.float32)
    p = np.array([[[0.2, 0.0]]], np.float32)
    vx = np.array([[24.0, 12.0]], np.float32)
    vy = np.zeros((1, 2), np.float32)
    w2, p2 = ref.advect_water_and_pigment(w, p, vx, vy, wet, PRM, DT)
    flux = 0.5 * (24.0 + 12.0) / 2 * DT / 4  # w_upwind * |v_face| * dt / 4
    assert np.allclose(w2, [[0.5 - flux, 0.3 + flux]], atol=1e-6)
    moved = 0.2 * flux / 0.5  # p * flux / w_upwind
    assert np.allclose(p2[0], [[0.2 - moved, moved]], atol=1e-6)


def test_advection_upper_clamp_keeps_receiver_below_w_max() -> None:
    wet = np.ones((1, 3), bool)
    w = np.array([[1.0, 0.999, 1.0]], np.float32)
    p = np.zeros((1, 1, 3), np.float32)
    vx = np.array([[30.0, 0.0, -30.0]], np.float32)
    w2, _ = ref.advect_water_and_pigment(w, p, vx, np.zeros_like(vx), wet, PRM, DT)
    assert w2.max() <= PRM.w_max + 1e-7
    assert abs(float(w2.sum()) - float(w.sum())) < 1e-6


def test_implicit_diffusion_conserves_and_converges_to_implicit_solution() -> None:
    n = 6
    u = RNG.uniform(0, 1, (n, n)).astype(np.float32)
    bx = RNG.uniform(0.2, 1, (n, n - 1)).astype(np.float32)
    by = RNG.uniform(0.2, 1, (n - 1, n)).astype(np.float32)
    k = 0.4
    out = ref.implicit_diffusion(u, bx, by, k, 200)
    assert abs(float(out.sum()) - float(u.sum())) < 1e-5
    # exact implicit solve: (I + k L) x = u with the weighted graph Laplacian L
    m = np.eye(n * n)
    idx = np.arange(n * n).reshape(n, n)
    faces = [(((y, x), (y, x + 1)), bx[y, x]) for y in range(n) for x in range(n - 1)]
    faces += [(((y, x), (y + 1, x)), by[y, x]) for y in range(n - 1) for x in range(n)]
    for (a, b), cond in faces:
        i, j = idx[a], idx[b]
        m[i, i] += k * cond
        m[j, j] += k * cond
        m[i, j] -= k * cond
        m[j, i] -= k * cond
    exact = np.linalg.solve(m, u.ravel().astype(np.float64)).reshape(n, n)
    assert np.abs(out - exact).max() < 1e-5
    few = ref.implicit_diffusion(u, bx, by, k, 2)
    assert abs(float(few.sum()) - float(u.sum())) < 1e-5  # conservative at any count
    assert few.min() >= 0


def test_pigment_diffusion_blocked_faces_carry_nothing() -> None:
    wet = np.ones((8, 8), bool)
    p = np.zeros((1, 8, 8), np.float32)
    p[0, :, :4] = 0.5
    beta_c = np.ones((8, 8), np.float32)
    beta_c[:, 4] = 0.0  # a wall of blocked cells
    out = ref.diffuse_pigment(p, wet, beta_c, PRM.replace(nu_p=2.0), DT)
    assert out[0, :, 4:].sum() == 0
    free = ref.diffuse_pigment(p, wet, np.ones_like(beta_c), PRM.replace(nu_p=2.0), DT)
    assert free[0, :, 4:].sum() > 0.01


def test_blocking_fades_with_age() -> None:
    h = np.full((2, 2), 1.0, np.float32)
    block = np.zeros((2, 2), np.float32)
    written = np.zeros((2, 2), np.float32)
    prm = PRM.replace(block_fade=2.0)
    assert ref.blocking(h, block, written, 0.0, prm).max() == 0
    assert np.allclose(ref.blocking(h, block, written, 1.0, prm), 0.5)
    assert np.allclose(ref.blocking(h, block, written, 5.0, prm), 1.0)
    paper = ref.blocking(np.zeros((2, 2), np.float32), np.ones((2, 2), np.float32), written, 0,
                         PRM.replace(block_paper=0.7))
    assert np.allclose(paper, 0.3)


def test_fibre_dispersion_follows_moving_water_along_fibres() -> None:
    """beta_c times 1 + (alpha / nu_p) max(fibre) |v|: only where water moves through a
    cell crossed by fibres; still water and fibre-free cells keep the plain value."""
    h = np.full((2, 3), 0.5, np.float32)
    block = np.ones((2, 3), np.float32)
    t0 = np.zeros((2, 3), np.float32)
    fibre = np.zeros((2, 2, 3), np.float32)
    fibre[0, :, 1] = 0.5  # a fibre along x through column 1
    fibre[1, :, 2] = 1.0  # one along y through column 2
    speed = np.array([[3.0, 3.0, 3.0], [0.0, 0.0, 0.0]], np.float32)  # already capped
    prm = PRM.replace(fibre_dispersivity=4.5, nu_p=0.3)
    beta = ref.blocking(h, block, t0, 5.0, prm, fibre, speed)
    gd = np.float32(4.5 / 0.3)
    assert beta[0, 0] == 1.0 and (beta[1] == 1.0).all()  # no fibre / still water
    assert beta[0, 1] == np.float32(1) + gd * (np.float32(0.5) * np.float32(3))
    assert beta[0, 2] == np.float32(1) + gd * np.float32(3)
    off = ref.blocking(h, block, t0, 5.0, PRM, fibre, speed)
    assert (off == 1.0).all()  # fibre_dispersivity 0: the plain controller
    assert ref.water_speed(np.float32([[3.0]]), np.float32([[4.0]]), PRM.replace(
        fibre_flow_max=9.0))[0, 0] == 5.0
    # a film the brush drives fast moves over the paper, not faster through its channels
    assert ref.water_speed(np.float32([[30.0]]), np.float32([[0.0]]), PRM)[0, 0] == np.float32(
        PRM.fibre_flow_max)
    assert prm.fibre_dispersion_gain() == 4.5 / 0.3
    assert PRM.replace(fibre_dispersivity=4.5, nu_p=0.0).fibre_dispersion_gain() == 0.0


def test_fibre_dispersivity_is_validated() -> None:
    for bad in (-1.0, 101.0, float("nan")):
        try:
            PRM.replace(fibre_dispersivity=bad)
        except CanvasInputError:
            continue
        raise AssertionError(f"fibre_dispersivity={bad} accepted")


def test_standing_front_is_validated_and_off_without_its_terms() -> None:
    for name, bad in (("standing_front_pull", -0.1), ("standing_front_pull", 11.0),
                      ("standing_front_dry", -0.1), ("standing_front_dry", 1.5),
                      ("standing_front_pull", float("nan"))):
        try:
            PRM.replace(**{name: bad})
        except CanvasInputError:
            continue
        raise AssertionError(f"{name}={bad} accepted")
    on = PRM.replace(standing_depth=0.3, standing_nu_p=0.005, standing_front_pull=0.04,
                     standing_front_dry=0.5, flow_outward=0.5, wet_blur=2.0)
    assert on.standing_front() == (25.0, 0.5)
    # no standing gate, no pull: off (the reference leaves the gate as it is)
    assert on.replace(standing_depth=0.0).standing_front() == (0.0, 0.0)
    assert on.replace(flow_outward=0.0).standing_front() == (0.0, 0.0)
    g = np.full((3, 3), 0.5, np.float32)
    off = on.replace(standing_front_pull=0.0)
    assert ref.standing_front(g, np.zeros((3, 3), np.float32), g, g, off) is g


def test_outward_pull_is_cut_to_the_contact_line() -> None:
    """rim_sharpness k: the pull per unit flow_outward is (1 - k) u + k s, s the dry share
    u = 1 - M' ramped from rim_onset to rim_full; off (k 0) it is u itself, and the
    parameters are validated."""
    for change in ({"rim_sharpness": -0.1}, {"rim_sharpness": 1.5},
                   {"rim_sharpness": 0.5, "rim_onset": 0.4, "rim_full": 0.3},
                   {"rim_full": 1.5}):
        try:
            PRM.replace(**change)
        except CanvasInputError:
            continue
        raise AssertionError(f"{change} accepted")
    u = np.array([0.0, 0.1, 0.22, 0.29, 0.36, 0.5, 1.0], np.float32)
    off = PRM.replace(rim_sharpness=0.0)
    assert off.rim_profile() == (0.0, 0.0, 0.0, 0.0)
    assert ref.outward_pull(u, off) is u
    sharp = PRM.replace(rim_sharpness=1.0, rim_onset=0.22, rim_full=0.36)
    got = ref.outward_pull(u, sharp)
    assert got.dtype == np.float32
    # nothing up to the onset, full from rim_full on, a ramp between
    np.testing.assert_allclose(got, [0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0], atol=1e-6)
    half = PRM.replace(rim_sharpness=0.5, rim_onset=0.22, rim_full=0.36)
    np.testing.assert_allclose(ref.outward_pull(u, half), 0.5 * u + 0.5 * got, atol=1e-6)
    # a narrow stroke's middle (u about 0.2 under a 4-cell blur) is not pulled
    strip = np.zeros((40, 40), bool)
    strip[15:25, :] = True
    w = np.where(strip, np.float32(0.3), np.float32(0.0)).astype(np.float32)
    prm = PRM.replace(flow_outward=0.3, wet_blur=4.0, paper_relief=0.0)
    h = np.zeros_like(w)
    soft = ref.flow_pressure(w, strip, strip, h, prm.replace(rim_sharpness=0.0))[:, 20]
    cut = ref.flow_pressure(w, strip, strip, h, prm.replace(rim_sharpness=1.0))[:, 20]
    assert soft[20] < np.float32(0.3) - np.float32(0.05)  # the blur pulls the middle down
    assert cut[18:22].min() == np.float32(0.3)  # the cut pull leaves the middle level
    assert cut[15] == cut[24] == np.float32(0.3) - np.float32(0.3)  # full at the edge


def test_evaporation_is_faster_at_stroke_edges_and_booked() -> None:
    w = np.zeros((5, 5), np.float32)
    w[1:4, 1:4] = 0.5
    evap = np.zeros_like(w)
    w2, e2 = ref.evaporate(w, evap, PRM, DT)
    e = PRM.eps_shallow * DT
    assert np.isclose(w[2, 2] - w2[2, 2], e, atol=1e-7)  # interior: top only
    assert np.isclose(w[1, 2] - w2[1, 2], e + PRM.edge_evap * 1 * 0.5 * e, atol=1e-7)
    assert np.isclose(w[1, 1] - w2[1, 1], e + PRM.edge_evap * 2 * 0.5 * e, atol=1e-7)
    assert np.allclose(w - w2, e2)


def test_surface_exchange_formula() -> None:
    p = np.array([[[0.3]]], np.float32)
    q = np.array([[[0.2]]], np.float32)
    w = np.array([[0.4]], np.float32)
    h = np.array([[0.7]], np.float32)
    wet = np.ones((1, 1), bool)
    beta, gamma, delta = (np.array([x], np.float32) for x in (2.0, 0.5, 0.8))
    p2, q2 = ref.surface_exchange(p, q, w, h, wet, beta, gamma, delta, PRM, DT)
    rate = PRM.surface_rate * DT
    f = 0.4 / PRM.w_max
    down = rate * 0.3 * (1 - f) * (1 - 0.7 * 0.5) * 0.8
    up = rate * 0.2 * f * (1 - 0.3 * 0.5) * 0.8 / 2.0
    assert np.isclose(p2[0, 0, 0], 0.3 - down + up, atol=1e-7)
    assert np.isclose(q2[0, 0, 0], 0.2 + down - up, atol=1e-7)
    p3, q3 = ref.surface_exchange(p, q, w, h, ~wet, beta, gamma, delta, PRM, DT)
    assert p3[0, 0, 0] == p[0, 0, 0] and q3[0, 0, 0] == q[0, 0, 0]


def test_capillary_absorbs_diffuses_within_capacity_and_conserves() -> None:
    h = RNG.uniform(0, 1, (16, 16)).astype(np.float32)
    c = PRM.c_min + h * (PRM.c_max - PRM.c_min)
    w = np.zeros_like(h)
    w[4:12, 4:12] = 0.3
    wc = np.zeros_like(h)
    mask = np.zeros_like(h)
    evap = np.zeros_like(h)
    prm = PRM.replace(eps_cap=0.0)
    total0 = float(w.sum() + wc.sum())
    for _ in range(200):
        w, wc, evap = ref.capillary(w, wc, h, mask, evap, prm, DT)
        assert wc.min() >= 0 and (wc <= c + 1e-6).all()
    assert abs(float(w.sum() + wc.sum()) - total0) < 1e-4
    assert wc[0:2, :].sum() > 0  # reached beyond the wet square
    assert evap.sum() == 0
    # evaporation only where no fluid water is above
    w2, _wc2, e2 = ref.capillary(w, wc, h, mask, evap, PRM.replace(cap_diffusion=0, alpha=0), DT)
    assert (e2[w2 > 0] == 0).all() and e2.sum() > 0


def test_masked_cells_take_nothing() -> None:
    h = np.full((8, 8), 0.5, np.float32)
    w = np.full((8, 8), 0.5, np.float32)
    mask = np.zeros_like(h)
    mask[:, 4:] = 1
    w[:, 4:] = 0
    wc = np.zeros_like(h)
    for _ in range(50):
        w, wc, _ = ref.capillary(w, wc, h, mask, np.zeros_like(h), PRM, DT)
    assert wc[:, 4:].sum() == 0 and w[:, 4:].sum() == 0
    wet = ref.wet_mask(np.ones_like(h), wc, mask, PRM, h)
    assert not wet[:, 4:].any()


def test_velocity_passes() -> None:
    wet = np.zeros((12, 12), bool)
    wet[2:10, 2:10] = True
    vx = np.where(wet, 15.0, 0).astype(np.float32)
    vy = np.zeros_like(vx)
    ax, _ay = ref.advect_velocity(vx, vy, wet, DT)
    assert np.allclose(ax[3:9, 4:9], 15.0)  # uniform flow stays uniform inside
    assert (ax[~wet] == 0).all()
    dx, _dy = ref.diffuse_velocity(vx, vy, wet, PRM, DT)
    assert np.allclose(dx[wet], 15.0, atol=1e-5)  # uniform field is a fixed point
    # water-height term: flow from high to low water, none into dry cells
    w = np.where(wet, 0.2, 0).astype(np.float32)
    w[2:10, 2:6] = 0.8
    zx, _zy = ref.water_height_and_boundary(np.zeros_like(vx), vy, w, wet, PRM)
    assert zx[5, 5] > 0 and zx[5, 6] > 0
    bx, _by = ref.water_height_and_boundary(vx, vy, w, wet, PRM)
    assert (bx[:, 9] <= 0).all()  # east edge: no flow into dry paper
    assert np.abs(bx).max() <= PRM.v_max
    assert (bx[~wet] == 0).all()


def test_dry_cells_deposit_and_book_tiny_water() -> None:
    w = np.array([[0.0, 5e-6, 0.3]], np.float32)
    p = np.array([[[0.2, 0.1, 0.1]]], np.float32)
    q = np.zeros_like(p)
    v = np.ones_like(w)
    evap = np.zeros_like(w)
    w2, p2, q2, vx, _, e2 = ref.dry_cells(w, p, q, v, v, evap, PRM)
    assert list(w2[0]) == [0.0, 0.0, np.float32(0.3)]
    assert np.allclose(q2[0, 0], [0.2, 0.1, 0.0]) and np.allclose(p2[0, 0], [0, 0, 0.1])
    assert np.isclose(e2[0, 1], 5e-6) and list(vx[0]) == [0, 0, 1]


def test_step_region_can_stop_after_any_pass() -> None:
    import pytest

    from station.backends.numpy_canvas import NumpyCanvas
    from station.errors import BadInput
    from station.pictures.scenarios import disc, paint

    base = NumpyCanvas(40, 32, seed=2)
    paint(base, disc(32, 40, 16, 20, 7), 0.6, {"Burnt Umber": 0.2}, vx=20.0)
    for _ in range(5):
        base.step()
    full = base.state()
    ref.step_region(full, (slice(0, 32), slice(0, 40)), DT)
    before = base.state()
    moved = []
    for name in ref.PASS_ORDER:
        st = before.copy()
        ref.step_region(st, (slice(0, 32), slice(0, 40)), DT, stop_after=name)
        moved.append(name)
        if name == "advect_velocity":
            assert np.array_equal(st.w, before.w) and not np.array_equal(st.vx, before.vx)
        if name == "diffuse_water":
            assert np.array_equal(st.p, before.p) and not np.array_equal(st.w, before.w)
    assert moved == list(ref.PASS_ORDER)
    for f in ("w", "wc", "p", "q", "vx", "vy", "evaporated"):
        assert np.array_equal(getattr(st, f), getattr(full, f)), f
    with pytest.raises(BadInput):
        ref.step_region(before.copy(), (slice(0, 32), slice(0, 40)), DT, stop_after="nope")


def test_lift_gain_lifts_settled_pigment_faster_in_the_surface_exchange_only() -> None:
    """Pass 8 lifts with the staining over lift_gain (one float32 division in
    slot_properties, the number every backend uses); the removal tools keep the pigment's
    own staining; lift_gain is validated."""
    h = np.full((6, 6), 0.5, np.float32)
    sts = {}
    for gain in (1.0, 5.0):
        st = CanvasState.blank(6, 6, PRM.replace(lift_gain=gain), h, palette=default_palette())
        st.slot_of("French Ultramarine")
        st.w[...] = 0.4
        st.q[0] = 0.3
        sts[gain] = st
    b1, g1, d1 = ref.slot_properties(sts[1.0])
    b5, g5, d5 = ref.slot_properties(sts[5.0])
    own = sts[5.0].slot_pigments()[0].beta
    assert b1[0] == np.float32(own) and b5[0] == np.float32(own / 5.0)
    assert (g1 == g5).all() and (d1 == d5).all()
    assert (ref.slot_properties(sts[5.0], lift=False)[0] == b1).all()
    wet = np.ones((6, 6), bool)
    lifted = {}
    for gain, b in ((1.0, b1), (5.0, b5)):
        st = sts[gain]
        p, q = ref.surface_exchange(st.p[:1], st.q[:1], st.w, st.h, wet, b[:1], g1[:1],
                                    d1[:1], st.params, DT)
        assert np.allclose(p + q, st.p[:1] + st.q[:1])  # moved, not made
        lifted[gain] = float(p.sum())
    assert lifted[1.0] > 0 and abs(lifted[5.0] / lifted[1.0] - 5.0) < 0.05, lifted
    # a brush scrubbing a wet wash lifts by the pigment's own staining, whatever the gain
    weight = np.ones((3, 3), np.float32)
    took = [pickup(sts[g], weight, y0=1, x0=1, thirst=0.5, scrub=2.0).pigment for g in (1.0, 5.0)]
    assert took[0] == took[1] and sum(took[0].values()) > 0
    for bad in (0.0, -1.0, 101.0, float("nan")):
        try:
            PRM.replace(lift_gain=bad)
        except CanvasInputError:
            continue
        raise AssertionError(f"lift_gain={bad} accepted")
