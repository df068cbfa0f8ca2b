"""A flat (or a fan) on a pen without a barrel sensor pulls broadside (deformable.py
``pull_broadside``): its width lies across its first move whatever the stylus's lean,
both edges on the paper, as a painter sets a flat down. Before, the width lay along the
canvas's x (turned only by the lean), so a horizontal wash stroke drew a line a few
cells wide and a vertical one a band."""

from __future__ import annotations

import math

import numpy as np
import pytest

from station.brush.deformable import DeformableBrush, pull_broadside, turned_tilt
from station.brush.spine import handle_frame
from station.brush.stamp import BrushModel, BrushSettings
from station.canvas.paper import make_paper
from station.canvas.profiles import get_profile
from station.events import PenSample

W, H = 160, 160


def pulled(kind: str, angle_deg: float, tilt: tuple[float, float],
           rotation: float | None = None) -> float:
    """Width [cells] across a 70-cell straight pull at ``angle_deg``: the painted cells'
    extent across the path, the median over the stroke's middle half."""
    paper = make_paper(get_profile("watercolor").paper, H, W, 5)
    settings = BrushSettings(kind=kind, size=24, water=0.8, pigment={"French Ultramarine": 0.6})
    b = DeformableBrush(W, H, settings, BrushModel(), paper)
    ux, uy = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    x0, y0 = 80 - 35 * ux, 80 - 35 * uy
    n = 60
    for i in range(n + 1):
        b.feed(PenSample(t=i / 120, device="d", tool="pen",  # type: ignore[arg-type]
                         x=(x0 + 70 * ux * i / n) / W, y=(y0 + 70 * uy * i / n) / H,
                         pressure=0.7, tilt_x=tilt[0], tilt_y=tilt[1], touching=True,
                         rotation=rotation))
    src = b.take()
    assert src is not None
    painted = src.full(W, H).dw > 0
    yy, xx = np.nonzero(painted)
    along = (xx + 0.5 - 80) * ux + (yy + 0.5 - 80) * uy
    across = -(xx + 0.5 - 80) * uy + (yy + 0.5 - 80) * ux
    widths = []
    for a in range(-17, 18):
        sel = np.floor(along) == a
        if sel.any():
            widths.append(float(across[sel].max() - across[sel].min() + 1))
    return float(np.median(widths))


@pytest.mark.parametrize("tilt", [(0.0, 0.0), (25.0, 35.0), (0.0, 45.0), (-30.0, 30.0)])
def test_flat_pulls_broadside_in_any_direction(tilt: tuple[float, float]) -> None:
    # before: a horizontal pull 4-8 cells wide, a vertical one 14-16, a 200° one 5-11
    widths = [pulled("flat", a, tilt) for a in (0.0, 90.0, 200.0)]
    assert min(widths) >= 0.8 * max(widths), widths
    assert min(widths) >= 12.0, widths


def test_a_barrel_sensor_keeps_its_say() -> None:
    # an Art Pen at rotation 0 holds the width along x: edge-on to a horizontal pull
    assert pulled("flat", 0.0, (0.0, 0.0), rotation=0.0) < 0.5 * pulled("flat", 0.0, (0.0, 0.0))


def test_pull_broadside_leans_along_the_move_with_the_width_across() -> None:
    for tilt, (dx, dy) in [((25.0, 35.0), (1.0, 0.0)), ((0.0, 45.0), (-0.3, 1.0)),
                           ((0.0, 0.0), (0.0, -1.0))]:
        turn, twist = pull_broadside(*tilt, dx, dy)
        f = handle_frame(*turned_tilt(*tilt, turn), twist)
        width = f[:, 0]
        d = np.array([dx, dy, 0.0]) / math.hypot(dx, dy)
        assert abs(width[2]) < 1e-9  # both edges on the paper
        assert abs(float(width @ d)) < 1e-9  # across the move
        if tilt != (0.0, 0.0):  # the handle's top leans the way it moves
            top = -f[:, 2]
            assert float(top[:2] @ d[:2]) < 0.0 or float(f[:2, 2] @ d[:2]) > 0.0
