"""The deformable brush's reaction force at the handle (drivers/haptic/deformable.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from station.drivers.haptic.contact import BrushState, RoundBrushContact, Surface
from station.drivers.haptic.deformable import DeformableBrushContact

from station.brush.geometry import get_shape

QUIET = Surface(grain=0.0)  # friction only: the grain would modulate the numbers


def _fz(model: DeformableBrushContact, heights: np.ndarray, x: float = 10.0) -> np.ndarray:
    # one call per sim frame, the handle walking through ``heights``
    return np.array([model.reaction(BrushState(i / 30, (x, 12.0, float(z))))[2]
                     for i, z in enumerate(heights)])


def test_no_force_above_the_paper() -> None:
    model = DeformableBrushContact()
    for z in (6.0, 6.5, 20.0):
        assert model.contact_force(BrushState(0.0, (1.0, 2.0, z), (30.0, 0.0, 0.0))) == \
            (0.0, 0.0, 0.0)
    assert model.reaction_model.solver.counters.solves == 0
    # just inside the tuft's reach the canvas pushes
    assert model.reaction(BrushState(0.0, (1.0, 2.0, 5.95)))[2] > 0.0


def test_smooth_and_jumpy_descents_feel_the_same() -> None:
    # the warm-started force of the last session differed ~60 % between these two
    smooth = np.round(np.arange(5.9, 0.69, -0.1), 2)
    jumpy = np.round(np.arange(5.9, 0.69, -1.0), 2)
    a = dict(zip(smooth, _fz(DeformableBrushContact(), smooth), strict=True))
    # the jumpy stroke also went deep and came back, and wandered sideways
    model = DeformableBrushContact()
    _fz(model, np.array([0.8, 5.0, 1.2]), x=40.0)
    b = dict(zip(jumpy, _fz(model, jumpy), strict=True))
    for z, f in b.items():
        assert f == pytest.approx(a[z], rel=0.02), (z, f, a[z])


def test_force_is_the_gradient_of_the_tuft_energy() -> None:
    # the KKT multipliers (analytic) against a central difference of the solved energy
    model = DeformableBrushContact()
    h = 0.02
    for z in (5.0, 3.0, 2.0, 1.0):
        f = model.reaction(BrushState(0.0, (0.0, 0.0, z)))[2]
        assert model.last is not None and model.last.residual < 1e-4
        model.reaction(BrushState(0.0, (0.0, 0.0, z + h)))
        e_hi = model.last.energy
        model.reaction(BrushState(0.0, (0.0, 0.0, z - h)))
        e_lo = model.last.energy
        fd = -(e_hi - e_lo) / (2 * h) * model.energy_scale
        assert f == pytest.approx(fd, rel=0.01), (z, f, fd)


@pytest.mark.parametrize("shape", ["round3d", "flat", "fan"])
def test_pressing_lower_pushes_harder(shape: str) -> None:
    heights = np.round(np.arange(5.75, 0.69, -0.25), 2)
    fz = _fz(DeformableBrushContact(shape=get_shape(shape)), heights)
    assert np.isfinite(fz).all() and (fz > 0).all()
    assert (np.diff(fz) >= 0).all(), fz  # monotone every quarter millimetre
    assert fz[-1] > 3 * fz[0]


def test_every_spine_of_the_tuft_counts() -> None:
    # the fan's three spines: its reaction is the mean of what each spine alone gives
    fan = DeformableBrushContact(shape=get_shape("fan"))
    fz = fan.reaction(BrushState(0.0, (0.0, 0.0, 2.0)))[2]
    eq = fan.last
    assert eq is not None and len(eq.states) == 3
    per_spine = [float(lam.sum()) for lam in eq.lam]
    assert all(p > 0 for p in per_spine)
    assert fz == pytest.approx(np.mean(per_spine) * fan.energy_scale / fan.tuft_mm, rel=1e-9)


def test_plastic_state_changes_the_force() -> None:
    model = DeformableBrushContact()
    state = BrushState(0.0, (0.0, 0.0, 3.0))
    straight = model.reaction(state)[2]
    bent = [np.asarray(s.rest) + np.tile([0.0, 0.3], s.n) for s in model.specs]
    set_in = model.reaction(state, bent)[2]
    assert set_in < 0.9 * straight  # a brush that took a set pushes back less
    assert model.reaction(state, bent)[2] == set_in  # and it is still a function of both


def test_lateral_force_opposes_the_drag() -> None:
    model = DeformableBrushContact(surface=QUIET)
    for v in ((30.0, 0.0, 0.0), (-20.0, 15.0, 0.0), (3.0, -4.0, 0.0)):
        fx, fy, fz = model.contact_force(BrushState(0.0, (5.0, 5.0, 3.0), v))
        speed = math.hypot(v[0], v[1])
        assert fz > 0 and fx * v[0] + fy * v[1] < 0
        assert math.isclose(math.hypot(fx, fy), QUIET.friction * fz * min(1, speed / 5.0))
        assert math.isclose(fx * v[1] - fy * v[0], 0.0, abs_tol=1e-12)  # straight against it


def test_in_the_range_of_the_round_brush() -> None:
    model, round_ = DeformableBrushContact(), RoundBrushContact(grain=0.0)
    for z in (5.0, 3.0, 1.0):
        fz = model.reaction(BrushState(0.0, (0.0, 0.0, z)))[2]
        rz = round_.normal_force(z)
        assert 0.3 * rz < fz < 3 * rz


def test_ferrule_wall_below_the_floor() -> None:
    model = DeformableBrushContact()
    above, below = _fz(model, np.array([model.floor_mm, model.floor_mm - 0.5]))
    assert math.isclose(below - above, model.wall_stiffness * 0.5, rel_tol=1e-9)


def test_contacts_only_push() -> None:
    # the force solve lets joints lift off (SpineSolver(hold=False)): every contact force is
    # a push, where the painting brush's held joints can be pulled onto the paper
    model = DeformableBrushContact()
    for z in np.arange(5.8, 0.7, -0.3):
        model.reaction(BrushState(0.0, (0.0, 0.0, float(z))))
        eq = model.last
        assert eq is not None and eq.residual < 1e-4
        assert min(float(lam.min()) for lam in eq.lam) > -1e-6, (z, eq.lam)
