"""Issue 21 (look-a's part): the effects measured on strokes painted through the brush, as
a person paints (pen samples played by the session player; no rectangles)."""

from __future__ import annotations

import numpy as np
import pytest

from station.canvas.palette import default_palette
from station.canvas.paper import PAPER_PRESETS, make_paper
from station.errors import BadInput
from station.kiosk.ui import PASS_THICKNESS, swatch
from station.pictures import effects as fx
from station.pictures import effects_brush as eb
from station.sessionlog import SessionHeader
from station.sim.paint import session_paper


@pytest.mark.parametrize("pigment", ["French Ultramarine", "Burnt Umber"])
def test_a_painters_value_range_through_the_brush(pigment: str) -> None:
    """Item 2: tint <= 0.08 darkness, one full-strength pass >= 0.35 (a dark pigment), two
    passes darker than one; item 6: the pass's hue within 10 deg of the real pigment."""
    c = fx._value_canvas(pigment)
    tint, full, two, hue = fx.value_stats(c)
    assert tint <= 0.08, tint
    assert full >= 0.35, full
    assert two >= full + 0.03, (full, two)
    assert fx._hue_off(hue, fx.REAL_MASSTONE_HUE[pigment]) <= 10.0, hue
    # the kiosk's palette swatch shows what that pass paints (it drew 1.8x thicker: dE ~ 30)
    m = fx._row_mask(c, fx.VALUE_H // 2, 4, 18, 54)
    stroke = c.render()[m].mean(axis=0)
    sw = np.array(swatch(default_palette(), {pigment: 1.0}, PASS_THICKNESS))
    sw_linear = np.where(sw <= 0.04045, sw / 12.92, ((sw + 0.055) / 1.055) ** 2.4)
    assert fx.delta_e76(sw_linear, stroke) <= 8.0


SHORT_RIMS = {
    ("French Ultramarine", 12, 0.8, 0.6): "1 cell: 1.40, 1.35 (main 1.34, 1.17)",
    ("Burnt Umber", 20, 1.0, 0.8): "0 cells: 1.31, 1.28 (main 1.31, 1.20)",
    ("French Ultramarine", 26, 1.0, 0.8): "1 cell: 1.40, 1.36 (main 1.47, 1.32)",
}
"""The painter's strokes whose darkness rim is still short of the issue's band. The
full-bodied ones (amount 0.8, water 1): their rim's deposit is 1.6x the interior's (q rings
1.60, 1.53; 1.64, 1.57) but the Kubelka-Munk render saturates on the dark interior. The
narrow one (size 12) gets its 2-cell band from the pull cut to the contact line alone
(rim_sharpness 1 at flow_outward 0.3: 1.41, 1.43), which the damp-wash bloom (2 lobes) and
the rectangle glaze price; with half of it (0.5 at 0.43) 1.40, 1.35. Strict: a stroke that
starts passing must move out of this list."""


def _stroke_id(s: tuple[str, int, float, float]) -> str:
    return f"{s[0].split()[-1]}-{s[1]}-w{s[2]}-a{s[3]}"


@pytest.mark.parametrize("stroke", [
    pytest.param(s, id=_stroke_id(s), marks=pytest.mark.xfail(
        strict=True, reason=f"rim short of the band: {SHORT_RIMS[s]}"))
    if s in SHORT_RIMS else pytest.param(s, id=_stroke_id(s))
    for s in (eb.RIM_STROKE, *eb.PAINTER_STROKES)])
def test_a_painters_strokes_dry_with_a_dark_band(stroke: tuple[str, int, float, float]
                                                 ) -> None:
    """Item 3 on the darkness (what the eye sees), over a painter's strokes (sizes 12-32,
    amounts 0.3-0.8, water 0.5-1, three pigments; the kiosk's default stroke among them),
    not only the sheet's: the dried stroke's outer band is 2-5 cells wide at >= 1.4x its
    interior darkness. Main's model: the sheet's stroke 1 cell (1.46, 1.33; on the deposited
    pigment 2 cells, 1.64, 1.43: the Kubelka-Munk render saturates), Rose 16 at 0.3 1 cell
    (1.52, 1.34), Rose 26 at 0.6 1 cell (1.43, 1.32)."""
    band, qband, _ = eb.stroke_rim(*stroke)
    rings = ([round(r, 3) for r in band.ring_ratio[:3]],
             [round(r, 3) for r in qband.ring_ratio[:3]])
    assert 2 <= band.width <= 5, rings
    assert band.ratio >= 1.4, rings


@pytest.mark.parametrize("stroke", eb.PAINTER_STROKES, ids=_stroke_id)
def test_every_painters_stroke_dries_with_an_edge_line(stroke: tuple[str, int, float, float]
                                                       ) -> None:
    """The weakest of the painter's strokes still dries with a dark edge line: its outermost
    ring at >= 1.3x the interior's darkness (main: the size-12 stroke 1.24, Burnt Umber 20 at
    0.8 1.25), the line a real dried stroke shows at every size (Curtis 1997, fig. 1a)."""
    band, _, _ = eb.stroke_rim(*stroke)
    assert band.ring_ratio[0] >= 1.3, band.ring_ratio[:3]


PALE_HEADS = {
    ("Quinacridone Rose", 16, 0.5, 0.3): "0.70 of the body (main 0.69)",
}
"""Strokes whose head still dries paler than the issue's painter would accept: a thin film
(water 0.5) about as deep as the edge's pull, so its rim drains the interior early, most
where the round cap surrounds it. Strict."""


@pytest.mark.parametrize("stroke", [
    pytest.param(s, id=_stroke_id(s), marks=pytest.mark.xfail(
        strict=True, reason=f"pale head: {PALE_HEADS[s]}"))
    if s in PALE_HEADS else pytest.param(s, id=_stroke_id(s))
    for s in (eb.RIM_STROKE, *eb.PAINTER_STROKES)])
def test_a_stroke_dries_without_a_pale_head(stroke: tuple[str, int, float, float]) -> None:
    """Where the pen set down (the stroke's first eighth, its pressure still rising from
    0.4) the dried stroke's middle is nearly as dark as its body's (>= 0.83; a darker cap
    of rim around it, as a real stroke's start has). Main: 0.69-0.82 on these strokes, a
    pale blotch: the light touch-down laid a fifth less paint (``load_min`` 0.5) and the
    flow outward's blur, wider than the narrow head, drained it to its cap. Now 0.84-0.92
    (with the pull cut to the contact line alone, rim_sharpness 1: 0.85-0.93)."""
    _, _, c = eb.stroke_rim(*stroke)
    dark = eb.darkness_map(c)
    head = float(dark[27:30, 16:29].mean())  # the path runs along row 28 from column 14
    body = float(dark[27:30, 40:81].mean())
    assert head >= 0.83 * body, (head, body, head / body)


def test_glaze_through_the_brush_reads_green_and_unlike_the_wet_mix() -> None:
    e = fx.brush_glazing()
    assert e.numbers["delta_e76_glaze_vs_mix"] >= 5.0, e.numbers
    assert 90.0 <= e.numbers["glaze_hue_srgb_deg"] <= 160.0, e.numbers


def test_a_brushed_granulating_wash_is_visible_and_broadband() -> None:
    """Item 7: a flat Ultramarine wash laid by the brush, darkness >= 0.3, shows its
    granulation at 1:1 (luma std >= 8 of 255) without a dominant texture scale."""
    c = fx.flat_wash("French Ultramarine", 0.7)
    inner = (slice(16, fx.WASH - 16), slice(12, fx.WASH - 12))
    lum = fx.luma(c.render())[inner]
    assert float(fx.darkness_map(c)[inner].mean()) >= 0.3
    assert float(lum.std()) * 255 >= 8.0
    peak, _ = fx.spectral_peak(lum)
    assert peak <= 1.5, peak


def test_spectral_peak_finds_a_single_scale_and_passes_broadband_noise() -> None:
    rng = np.random.default_rng(0)
    _, x = np.mgrid[0:96, 0:96]
    ripple = np.sin(2 * np.pi * x / 8.0) + 0.3 * rng.standard_normal((96, 96))
    peak, wavelength = fx.spectral_peak(ripple)
    assert peak > 3.0 and 7.0 <= wavelength <= 9.5
    assert fx.spectral_peak(rng.standard_normal((96, 96)))[0] <= 1.5


def test_papers_are_data_and_chosen_per_session() -> None:
    assert {"hot-press", "cold-press", "rough"} <= set(PAPER_PRESETS)
    for name in PAPER_PRESETS:
        assert fx.spectral_peak(make_paper(name, 96, 96, 3))[0] <= 1.5, name
    hdr = SessionHeader(64, 64, extra={"paper": "rough"})
    assert session_paper(hdr, "x:1") == {"paper": "rough"}
    assert session_paper(SessionHeader(64, 64), "x:1") == {}
    with pytest.raises(BadInput):
        session_paper(SessionHeader(64, 64, extra={"paper": "../etc"}), "x:1")


def test_the_step_artefact_tile_resolves_one_percent() -> None:
    """Item 8: the tile averages the step bin's complex coefficient over papers on a 320-cell
    stroke and reports a floor (a slow, effectively continuous stroke read the same way).
    On one paper and 160 cells it read 1.71 % wet, and the continuous stroke itself read
    1.5 % there; on two papers the wet fast stroke reads 0.4 % against a floor below 1 %."""
    e = fx.step_artefacts({"wet": (1, 2), "dry": (1, 2)})
    assert e.numbers["papers_wet"] == 2.0
    assert e.numbers["step_component_wet"] <= 0.01, e.numbers
    assert e.numbers["noise_floor_wet"] < 0.01, e.numbers
    assert e.numbers["other_bins_median_wet"] < 0.005, e.numbers
    assert e.picture(1).shape[0] == 2 * fx.STEP_H
