"""Deformable brush mechanics (issue 11 §1–3): kinematics, energy gradients, SLSQP
equilibrium against brute force, the canvas constraint, anisotropic friction."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from station.brush.energy import energy, heights
from station.brush.solver import Friction, SpineSolver, SpineState
from station.brush.spine import THETA_MAX, SpineSpec, chain, handle_frame

RNG = np.random.default_rng(3)


def fd(f, x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    out = []
    for a in range(x.size):
        e = np.zeros_like(x)
        e[a] = h
        out.append((f(x + e) - f(x - e)) / (2 * h))
    return np.array(out).T


def test_spec_tapers_toward_the_tip() -> None:
    spec = SpineSpec.tapered(4)
    assert spec.n == 4 and math.isclose(sum(spec.lengths), 1.0)
    assert all(a > b for a, b in itertools.pairwise(spec.lengths))
    assert all(a > b for a, b in itertools.pairwise(spec.stiffness))
    _, hi = spec.bounds()
    assert hi[0] == THETA_MAX < math.pi / 2  # θ kept away from the gimbal lock


def test_straight_spine_hangs_from_the_handle() -> None:
    spec = SpineSpec.tapered(4)
    root = np.array([1.0, 2.0, 3.0])
    pos, _, _ = chain(np.zeros(8), np.asarray(spec.lengths), root, np.eye(3))
    assert np.allclose(pos[-1], [1.0, 2.0, 2.0])
    tilted = handle_frame(30.0, 0.0, 0.0)  # top leans right: the tuft points left
    pos, _, _ = chain(np.zeros(8), np.asarray(spec.lengths), root, tilted)
    assert pos[-1, 0] < 1.0 - 0.4 and math.isclose(np.linalg.norm(pos[-1] - root), 1.0)


def test_jacobian_matches_finite_differences() -> None:
    spec = SpineSpec.tapered(4)
    lengths = np.asarray(spec.lengths)
    root, handle = np.array([0.3, -0.2, 0.7]), handle_frame(20.0, -35.0, 40.0)
    for _ in range(3):
        x = RNG.uniform(-1.0, 1.0, 8)
        _, _, jac = chain(x, lengths, root, handle)
        num = fd(lambda v: chain(v, lengths, root, handle)[0].ravel(), x)
        assert np.allclose(jac.reshape(-1, 8), num, atol=1e-7)


def _contact_problem(x: np.ndarray) -> dict:
    n = 4
    return dict(
        lengths=np.asarray(SpineSpec.tapered(n).lengths),
        stiffness=np.asarray(SpineSpec.tapered(n).stiffness),
        rest=np.zeros(2 * n) + 0.05, root=np.array([0.1, 0.2, 0.6]),
        handle=handle_frame(15.0, 25.0, 10.0), contact=np.array([0.0, 1.0, 1.0, 1.0]),
        anchor=RNG.uniform(-0.3, 0.3, (n, 2)),
        pull=np.array([[0.0, 0.0], [1.0, 0.0], [0.6, 0.8], [0.0, -1.0]]),
        mu_n=np.array([0.0, 0.4, 0.4, 0.4]), c_eta=0.8, k_eta=2.0)


def test_energy_gradient_matches_finite_differences() -> None:
    for _ in range(4):
        x = RNG.uniform(-0.8, 0.8, 8)
        kw = _contact_problem(x)
        args = [kw[k] for k in ("lengths", "stiffness", "rest", "root", "handle", "contact",
                                "anchor", "pull", "mu_n")]

        def e(v: np.ndarray, args: list = args, kw: dict = kw) -> float:
            return energy(v, np.empty(0), *args, kw["c_eta"], kw["k_eta"])

        g = np.empty(8)
        energy(x, g, *args, kw["c_eta"], kw["k_eta"])
        assert np.allclose(g, fd(e, x), rtol=1e-5, atol=1e-7)


def test_constraint_gradient_matches_finite_differences() -> None:
    spec = SpineSpec.tapered(4)
    lengths, root, handle = np.asarray(spec.lengths), np.array([0.0, 0.0, 0.5]), np.eye(3)
    x = RNG.uniform(-1.0, 1.0, 8)
    g = np.empty((4, 8))
    heights(x, g, lengths, root, handle)
    num = fd(lambda v: heights(v, np.empty((0, 0)), lengths, root, handle), x)
    assert np.allclose(g, num, atol=1e-7)


def _brute_force(spec: SpineSpec, root: np.ndarray, steps: int = 61) -> tuple[float, np.ndarray]:
    """Exhaustive grid over a planar 2-segment chain (φ only) with z ≥ 0 (no friction)."""
    lengths, stiffness, _ = spec.arrays()
    grid = np.linspace(-2.9, 2.9, steps)
    best, arg = math.inf, None
    for a, b in itertools.product(grid, grid):
        x = np.array([0.0, a, 0.0, b])
        z = heights(x, np.empty((0, 0)), lengths, root, np.eye(3))
        if z.min() < 0.0:
            continue
        e = 0.5 * (stiffness[0] * a * a + stiffness[1] * b * b)
        if e < best:
            best, arg = e, x
    assert arg is not None
    # polish the grid optimum with a fine local grid
    for scale in (0.05, 0.005, 0.0005):
        fine = np.linspace(-1, 1, 41) * scale
        for da, db in itertools.product(fine, fine):
            x = arg + np.array([0.0, da, 0.0, db])
            z = heights(x, np.empty((0, 0)), lengths, root, np.eye(3))
            if z.min() < 0.0:
                continue
            e = 0.5 * (stiffness[0] * x[1] ** 2 + stiffness[1] * x[3] ** 2)
            if e < best:
                best, arg = e, x
    return best, arg


@pytest.mark.parametrize("height", [0.85, 0.6])
def test_equilibrium_matches_brute_force_minimisation(height: float) -> None:
    """A 2-segment chain pressed onto the canvas: SLSQP's energy equals an exhaustive search's."""
    spec = SpineSpec((0.55, 0.45), (1.0, 0.5), (0.0, 0.0, 0.0, 0.0))
    root = np.array([0.0, 0.0, height])
    st = SpineState.at_rest(spec)
    st.x = np.array([0.0, 0.3, 0.0, 0.3])  # start bent one way (the search's optimum too)
    above = root + np.array([0.0, 0.0, 1.0])
    st.pos, _, _ = chain(st.x, np.asarray(spec.lengths), above, np.eye(3))
    st.contact = np.zeros(2, bool)
    # no friction: the static equilibrium is the constrained spring minimum
    solver = SpineSolver(Friction(mu_n=0.0), max_evals=500)
    # only the inequality: start above so no joint is held on the plane
    st.root = None
    pos = solver.solve(st, root, np.eye(3))
    assert solver.counters.fallbacks == 0
    e_sqp = 0.5 * (1.0 * (st.x[0] ** 2 + st.x[1] ** 2) + 0.5 * (st.x[2] ** 2 + st.x[3] ** 2))
    e_bf, _ = _brute_force(spec, root)
    assert pos[:, 2].min() >= -1e-6
    assert e_sqp <= e_bf * 1.02 + 1e-6
    assert e_sqp >= e_bf * 0.9  # and it is not below the true constrained minimum


def _drag(direction: tuple[float, float], frames: int = 25) -> float:
    """Press a spine and drag the handle; returns the tip's bend (sum of |angles|)."""
    spec = SpineSpec.tapered(4)
    st = SpineState.at_rest(spec)
    solver = SpineSolver(Friction(mu_n=0.4, c_eta=0.9, k_eta=2.0))
    handle = handle_frame(0.0, 25.0, 0.0)  # the tuft trails toward -y
    root = np.array([0.0, 0.0, 0.6])
    for _ in range(6):
        solver.solve(st, root, handle)
    for _ in range(frames):
        root = root + 0.02 * np.array([direction[0], direction[1], 0.0])
        pos = solver.solve(st, root, handle)
        assert pos[:, 2].min() >= -1e-6  # no joint below the canvas in any frame
    assert solver.counters.fallbacks == 0
    lengths = np.asarray(spec.lengths)
    straight, _, _ = chain(np.zeros(8), lengths, root, handle)
    return float(np.linalg.norm(pos[-1, :2] - straight[-1, :2]))


def test_sideways_drag_bends_more_than_a_pull() -> None:
    pull = _drag((0.0, 1.0))  # the tuft trails behind the handle: pulled along it
    side = _drag((1.0, 0.0))
    assert side > 1.3 * pull, (side, pull)


def test_lifted_spine_springs_back() -> None:
    spec = SpineSpec.tapered(4)
    st = SpineState.at_rest(spec)
    solver = SpineSolver()
    for z in (0.9, 0.6, 0.4, 0.6, 1.2):
        pos = solver.solve(st, np.array([0.0, 0.0, z]), np.eye(3))
    assert pos[:, 2].min() > 0.15 and np.abs(st.x).max() < 1e-3


def test_dragged_equilibrium_with_friction_matches_brute_force() -> None:
    """A 2-segment chain whose tip lies on the canvas is dragged: SLSQP's energy equals
    a 1-D exhaustive search along the contact manifold (tip height 0), same energy."""
    spec = SpineSpec((0.55, 0.45), (1.0, 0.5), (0.0, 0.0, 0.0, 0.0))
    lengths, stiffness, rest = spec.arrays()
    fr = Friction(mu_n=0.5, c_eta=0.8, k_eta=2.0)
    handle = np.eye(3)
    solver = SpineSolver(fr, max_evals=500)
    st = SpineState.at_rest(spec)
    root = np.array([0.0, 0.0, 0.8])
    for _ in range(5):
        solver.solve(st, root, handle)
    assert st.contact is not None and st.contact[-1]
    last, was = st.pos.copy(), st.contact.copy()
    root2 = root + np.array([0.12, 0.0, 0.0])
    solver.solve(st, root2, handle)
    e_sqp_x = st.x.copy()
    # the frame's friction set-up, from the documented rules
    anchor = np.zeros((2, 2))
    pull = np.zeros((2, 2))
    contact = np.array([0.0, 1.0])
    anchor[1] = last[1, :2]
    v = last[0, :2] - last[1, :2]
    pull[1] = v / np.linalg.norm(v)
    mu = np.array([0.0, fr.mu_n])
    assert was[1]

    def e(x: np.ndarray) -> float:
        return energy(x, np.empty(0), lengths, stiffness, rest, root2, handle, contact,
                      anchor, pull, mu, fr.c_eta, fr.k_eta)

    def tip_z(a: float, b: float) -> float:
        return float(heights(np.array([0.0, a, 0.0, b]), np.empty((0, 0)), lengths, root2,
                             handle)[1])

    best = math.inf
    for a in np.linspace(-1.4, 1.4, 2801):
        # φ1 putting the tip on the plane, on the branch bending the same way as SQP's
        lo, hi = (0.0, 2.9) if e_sqp_x[3] >= 0 else (-2.9, 0.0)
        zl, zh = tip_z(a, lo), tip_z(a, hi)
        if zl * zh > 0:
            continue
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if (tip_z(a, mid) > 0) == (zl > 0):
                lo = mid
            else:
                hi = mid
        x = np.array([0.0, a, 0.0, 0.5 * (lo + hi)])
        if heights(x, np.empty((0, 0)), lengths, root2, handle)[0] < 0:
            continue
        best = min(best, e(x))
    e_sqp = e(e_sqp_x)
    assert math.isfinite(best)
    assert abs(e_sqp_x[0]) < 1e-4 and abs(e_sqp_x[2]) < 1e-4  # planar, as the search
    assert e_sqp <= best + 1e-5 and e_sqp >= best - 1e-3, (e_sqp, best)


def test_unheld_joints_lift_off() -> None:
    # hold=False (the haptic reaction's frictionless solve): pressed straight down from
    # rest the joints only stay above the paper, SQP still starts (the buckle), and the
    # joints that stay down are those the paper pushes; the default holds them
    spec = SpineSpec.tapered(4, 0.75, 1.0, 0.6)
    handle = np.eye(3)
    for hold in (False, True):
        solver = SpineSolver(friction=Friction(mu_n=0.0), hold=hold, xtol=1e-9, max_evals=500)
        st = SpineState.at_rest(spec)
        for z in np.linspace(0.98, 0.5, 13):
            solver.solve(st, np.array([0.0, 0.0, z]), handle)
        assert solver.counters.fallbacks == 0
        lengths, stiffness, _ = spec.arrays()
        zg = np.empty((4, 8))
        zs = heights(st.x, zg, lengths, np.array([0.0, 0.0, 0.5]), handle)
        on = np.flatnonzero(zs <= 1e-5)
        grad = np.repeat(stiffness, 2) * (st.x - st.rest)
        lam = np.linalg.lstsq(zg[on].T, grad, rcond=None)[0]
        assert np.allclose(zg[on].T @ lam, grad, atol=1e-6)
        if not hold:
            assert (lam > -1e-6).all(), lam
        else:
            assert lam.min() < -0.1, lam  # a held joint the paper pulls down
