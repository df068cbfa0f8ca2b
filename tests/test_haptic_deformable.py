"""The deformable brush's reaction force at the handle (drivers.haptic.deformable)."""

from __future__ import annotations

import math

import numpy as np

from drivers.haptic.contact import BrushState, RoundBrushContact
from drivers.haptic.deformable import DeformableBrushContact


def _press(model: DeformableBrushContact, heights: np.ndarray,
           velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> list[tuple[float, ...]]:
    # one call per sim frame, the handle walking down as a 30 Hz stroke would
    return [model.contact_force(BrushState(i / 30, (10.0, 12.0, float(z)), velocity))
            for i, z in enumerate(heights)]


def test_no_force_above_the_paper() -> None:
    model = DeformableBrushContact(tuft_mm=6.0)
    for z in (6.0, 6.5, 20.0):
        assert model.contact_force(BrushState(0.0, (1.0, 2.0, z))) == (0.0, 0.0, 0.0)
    assert model.solver.counters.solves == 0


def test_pressing_lower_pushes_harder() -> None:
    # a 30 Hz stroke walking down 0.25 mm a frame, read every millimetre: past the touch
    # the tuft buckles and its force has a plateau (an elastica's), where the finite
    # difference wobbles by a few per cent frame to frame; a millimetre deeper it has risen
    heights = np.round(np.arange(5.75, 0.7, -0.25), 2)
    forces = _press(DeformableBrushContact(), heights)
    assert np.isfinite(np.array(forces)).all()
    fz = np.array([f[2] for f in forces])
    assert (fz > 0).all()
    every_mm = fz[::4]
    assert len(every_mm) == 6
    assert (np.diff(every_mm) > 0).all(), every_mm
    assert every_mm[-1] > 3 * every_mm[0]


def test_deterministic() -> None:
    heights = np.array([5.0, 4.2, 3.1, 3.1, 2.0])
    a = _press(DeformableBrushContact(), heights, (20.0, -5.0, 0.0))
    b = _press(DeformableBrushContact(), heights, (20.0, -5.0, 0.0))
    assert a == b


def test_sign_agrees_with_the_round_brush() -> None:
    model, round_ = DeformableBrushContact(), RoundBrushContact(grain=0.0)
    for (fx, fy, fz), z in zip(_press(model, np.array([5.0, 4.0, 3.0]), (30.0, 0.0, 0.0)),
                               (5.0, 4.0, 3.0), strict=True):
        rx, ry, rz = round_.contact_force(BrushState(0.0, (0.0, 0.0, z), (30.0, 0.0, 0.0)))
        assert fz > 0 and rz > 0  # both push the handle up
        assert fx < 0 and rx < 0 and fy == ry == 0  # both drag against the stroke
        assert math.isclose(-fx / fz, model.friction)


def test_ferrule_wall_below_the_floor() -> None:
    model = DeformableBrushContact()
    above, below = (f[2] for f in _press(model, np.array([model.floor_mm, model.floor_mm - 0.5])))
    assert math.isclose(below - above, model.wall_stiffness * 0.5, rel_tol=1e-6)
