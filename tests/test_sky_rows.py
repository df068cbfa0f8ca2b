"""Issue 21 item 8 at the kiosk: a visitor's wet sky laid in zig-zag rows with the kiosk's
defaults (``tools/kiosk_screenshots.py``'s drag: six rows 31 cells apart, 8 s, brush size
72, water 1, French Ultramarine and Cerulean at strength 0.8), painted through the brush
on the cpu backend (the reference's bits), dried, measured on the render.

Rows laid into a still-wet previous row merge, as a painter's wet sky does: no evenly
spaced dark line where a row's single-coverage strip (between two overlapping passes,
half the water of the overlaps) ran dry first and drew the wet bands' pigment into it.
Only a row laid over a dried row leaves an edge (``test_wet_area_rows``).
"""

from __future__ import annotations

import numpy as np

from station.backends.factory import create_backend
from station.pictures.effects_brush import sky_banding, sky_rows_script
from station.pictures.scenarios import run_until_dry
from station.sim.player import SessionPlayer

CONTRAST_MAX = 1.2
"""Darkest over palest row across the sky's rows (a 31-cell running mean divided out):
1.164 with the paper absorbing at 0.011 /s and eps_shallow 0.012 (soft double-coverage
shading); 1.338 before (the visible lines: absorption 0.02 /s), 1.383 with the stronger
flow outward of the rim (0.57) on that absorption."""
PERIOD_MAX = 0.06
"""The rows' spacing's share of the profile (Fourier amplitude over the mean): 0.047 now,
0.111 with absorption 0.02 /s, 0.126 with it and flow outward 0.57."""


def test_a_wet_sky_laid_in_zig_zag_rows_has_no_dark_lines_between_its_rows() -> None:
    s = sky_rows_script(0)
    h = s.header
    c = create_backend("cpu", h.width, h.height, "watercolor", 0)
    SessionPlayer(c, h.width, h.height, "watercolor").play(s.records)
    run_until_dry(c, 20000)
    c.dry()
    out = sky_banding(np.asarray(c.render(), np.float64), c)
    assert out["row_contrast"] <= CONTRAST_MAX, out
    assert out["row_period_share"] <= PERIOD_MAX, out
    assert out["sky_darkness"] >= 0.35, out  # a sky at the kiosk's strength, not a tint
    bal = c.stats()["balance"]
    assert bal["water_rel_error"] < 1e-3 and bal["pigment_rel_error"] < 1e-3
