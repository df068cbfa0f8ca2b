"""The compiled SQP of the spine solve (issue 26 item 5) against NLopt's SLSQP."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from station.brush.deformable import DeformableBrush
from station.brush.geometry import get_shape
from station.brush.solver import Friction, SpineSolver, SpineState
from station.brush.spine import SpineSpec
from station.brush.sqp import INFEASIBLE, OK, qp
from station.brush.stamp import BrushModel, BrushSettings

JOINT_TOL = 1e-3
"""Largest distance (tuft units) between the two solvers' joints along a stroke
(measured here: 4e-6 flat, 5e-4 round3d, ≤ 1e-5 fan, calligraphy, rigger, mop).
Both stop at the first iterate that moves less than ``xtol``; where a held tip's
friction is near its stick/slide threshold the energy is almost flat and the two
stopping points differ by more, and friction carries the difference on through
the anchors: the middle (unsplayed) spine of an odd flat, ≤ 5e-3."""
FLAT_MIDDLE_TOL = 1e-2


def _qp(g: np.ndarray, a: np.ndarray, c: np.ndarray, b: np.ndarray, meq: int
        ) -> tuple[int, np.ndarray, np.ndarray]:
    d = np.empty(g.shape[0])
    lam = np.empty(c.shape[0])
    status = qp(g, a, c, b, meq, d, lam, np.empty((9, g.shape[0], g.shape[0])))
    return status, d, lam


def test_qp_solves_an_equality_and_an_active_inequality() -> None:
    # min ½|d|² - (1, 1)·d with d0 + d1 = 1 and d0 ≥ 0.8: the line's closest point to
    # (1, 1) is (0.5, 0.5), the inequality moves it to (0.8, 0.2)
    g = np.eye(2)
    a = np.array([-1.0, -1.0])
    c = np.array([[1.0, 1.0], [1.0, 0.0]])
    b = np.array([1.0, 0.8])
    status, d, lam = _qp(g, a, c, b, 1)
    assert status == OK
    np.testing.assert_allclose(d, [0.8, 0.2], atol=1e-12)
    assert lam[1] > 0.0  # the inequality pushes
    np.testing.assert_allclose(c.T @ lam, g @ d + a, atol=1e-12)  # stationarity
    # an inactive inequality has no multiplier
    status, d, lam = _qp(g, a, c, np.array([1.0, 0.2]), 1)
    np.testing.assert_allclose(d, [0.5, 0.5], atol=1e-12)
    assert lam[1] == 0.0


def test_qp_reports_incompatible_constraints() -> None:
    c = np.array([[1.0, 0.0], [-1.0, 0.0]])  # d0 ≥ 1 and d0 ≤ 0
    status, _, _ = _qp(np.eye(2), np.zeros(2), c, np.array([1.0, 0.0]), 0)
    assert status == INFEASIBLE


def _stroke(kind: str, method: str, frames: int, spines: int | None = None
            ) -> tuple[np.ndarray, DeformableBrush]:
    shape = get_shape(kind)
    if spines is not None:
        shape = dataclasses.replace(shape, spines=spines)
    b = DeformableBrush(200, 150, BrushSettings(kind=kind, size=24.0, water=1.0,
                                                 pigment={"French Ultramarine": 0.5}),
                        BrushModel(), np.ones((150, 200), np.float32), shape=shape)
    b.solver.method = method
    joints = []
    for k in range(10):  # press in
        b.frame(30.0, 75.0, 0.06 * k)
    for k in range(frames):
        p = 0.55 + 0.35 * math.sin(k / 7.0)
        b.frame(30.0 + 140.0 * k / frames, 75.0 + 30.0 * math.sin(k / 6.0), p, 0.0, -20.0, 0.0)
        joints.append(np.concatenate([s.pos.ravel() for s in b.spines if s.pos is not None]))
    return np.asarray(joints), b


@pytest.mark.parametrize(("kind", "spines", "tol"), [("round3d", None, JOINT_TOL),
                                                     ("flat", None, JOINT_TOL),
                                                     ("flat", 5, FLAT_MIDDLE_TOL)])
def test_compiled_solve_matches_nlopt_along_a_pressed_stroke(kind: str, spines: int | None,
                                                             tol: float) -> None:
    old, b_old = _stroke(kind, "nlopt", 40, spines)
    new, b_new = _stroke(kind, "sqp", 40, spines)
    c = b_new.solver.counters
    assert c.compiled_declined == 0 and c.fallbacks == b_old.solver.counters.fallbacks == 0
    assert float(np.abs(new - old).max()) <= tol
    # the same method: about as many evaluations, not a different search
    assert c.evaluations <= 1.2 * b_old.solver.counters.evaluations


def test_a_declined_frame_goes_to_nlopt() -> None:
    spec = SpineSpec.tapered(4)
    root = np.array([0.0, 0.0, 0.7])
    results = []
    for method in ("sqp", "nlopt"):
        # three evaluations cannot settle a pressed spine: the compiled SQP declines and
        # NLopt (then the continuation) decides, exactly as with NLopt alone
        solver = SpineSolver(Friction(), max_evals=3, method=method)
        st = SpineState.at_rest(spec)
        results.append(solver.solve(st, root, np.eye(3)).copy())
        if method == "sqp":
            assert solver.counters.compiled_declined >= 1
    np.testing.assert_array_equal(results[0], results[1])


def test_an_unknown_method_is_refused() -> None:
    with pytest.raises(ValueError, match="slsqp"):
        SpineSolver(method="slsqp")
