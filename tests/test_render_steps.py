"""The sub-cell renderer draws hard edges INSIDE the paint (one paint over another, a dried
glaze's edge) as smooth contours, not as the cells' staircase (issue 21, the look)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from station.backends.numpy_canvas import NumpyCanvas
from station.canvas.state import CanvasState
from station.render import upscale
from station.render.km import render_bands
from station.render.upscale import render_scaled, scaled_layers

H, W = 32, 48
SLOPE = 0.3  # a crest's slope: treads of 3-4 cells, one-cell risers


def _band_over_wash(slope: float = SLOPE) -> tuple[CanvasState, int, int]:
    """Burnt Umber laid (cells only) below a line of ``slope`` over a French Ultramarine
    wash covering the canvas: a staircase edge between two paints."""
    st = NumpyCanvas(W, H, seed=1).state()
    a = st.slot_of("French Ultramarine")
    b = st.slot_of("Burnt Umber")
    yy, xx = np.mgrid[0:H, 0:W]
    st.q[a] = 0.2
    st.q[b] = np.where(yy + 0.5 > 10 + slope * (xx + 0.5), 0.3, 0.0).astype(np.float32)
    return st, a, b


def _edge_wiggle(lum: np.ndarray, k: int) -> float:
    """Largest deviation (pixels) from its fitted straight line of the edge's crossing
    (the mid-level between the two sides, linear between pixels) in each pixel column."""
    top, bottom = np.median(lum[:6 * k]), np.median(lum[-6 * k:])
    level = 0.5 * (top + bottom)
    xs = np.arange(4 * k, (W - 4) * k)
    ys = []
    for x in xs:
        col = lum[:, x]
        i = int(np.argmax(col < level if bottom < top else col > level))
        ys.append(i - 1 + (level - col[i - 1]) / (col[i] - col[i - 1]))
    centre = xs + 0.5
    fit = np.polyfit(centre, ys, 1)
    assert abs(fit[0] - SLOPE) < 0.02  # the measured edge is the laid one
    return float(np.abs(np.asarray(ys) - np.polyval(fit, centre)).max())


def _plain(monkeypatch: pytest.MonkeyPatch) -> None:
    """The renderer without step contours (main's before them): no step qualifies."""
    monkeypatch.setattr(upscale, "HARD_RATIO", 0.0)
    monkeypatch.setattr(upscale, "HARD_MIN_DENSITY", np.inf)
    monkeypatch.setattr(upscale, "HARD_MIN_AMOUNT", np.inf)


@pytest.mark.parametrize("k", [2, 3])
def test_an_edge_between_two_paints_is_a_smooth_contour(k: int,
                                                        monkeypatch: pytest.MonkeyPatch
                                                        ) -> None:
    st, _, _ = _band_over_wash()
    wiggle = _edge_wiggle(render_scaled(st, "km", k).mean(axis=2), k)
    # the cells' staircase (main: 0.96 px at k=2, 1.50 at k=3) is gone: within a quarter
    # cell of a straight line (0.39 / 0.48 px measured)
    assert wiggle < 0.25 * k, wiggle
    with monkeypatch.context() as m:
        _plain(m)
        stair = _edge_wiggle(render_scaled(st, "km", k).mean(axis=2), k)
    assert stair > 0.4 * k, stair  # the measure sees the staircase where it is drawn


def test_a_glaze_of_the_same_colour_has_a_smooth_edge_too(monkeypatch: pytest.MonkeyPatch
                                                           ) -> None:
    """A second layer of the wash's own pigment (0.2 -> 0.35: under twice, the step in
    one cell): the demo's front mountain over the back one."""
    st, a, b = _band_over_wash()
    st.q[a] += np.float32(0.75) * st.q[b]
    st.q[b] = 0.0
    k = 3
    wiggle = _edge_wiggle(render_scaled(st, "km", k).mean(axis=2), k)
    assert wiggle < 0.25 * k, wiggle
    with monkeypatch.context() as m:
        _plain(m)
        assert _edge_wiggle(render_scaled(st, "km", k).mean(axis=2), k) > 0.4 * k


def test_a_dried_glaze_edge_is_a_smooth_contour() -> None:
    st = _band_over_wash()[0]
    st.r_composed[...] = render_bands(st, "km")  # the band and the wash dried
    st.p[...] = 0.0
    st.q[...] = 0.0
    k = 3
    wiggle = _edge_wiggle(render_scaled(st, "km", k).mean(axis=2), k)
    assert wiggle < 0.25 * k, wiggle  # main: 1.50 px


def test_step_contours_keep_the_paint_where_the_simulation_put_it() -> None:
    st, a, b = _band_over_wash()
    k = 3
    amount, _ = scaled_layers(st, k)
    cells = amount.reshape(-1, H, k, W, k).mean(axis=(2, 4))
    inner = (slice(2, -2), slice(2, -2))
    # the wash under the band: untouched
    assert np.abs(cells[a] - st.q[a])[inner].max() < 1e-6
    # the band: its total kept within 1 %, its amount moved along the edge within a
    # cell (3x3 means within 7 % of the step), nothing farther than a cell away
    want = st.q[b]
    assert abs(cells[b][inner].sum() / want[inner].sum() - 1) < 0.01
    box = ndimage.uniform_filter(cells[b] - want, 3, mode="nearest")
    assert np.abs(box[inner]).max() < 0.07 * 0.3, np.abs(box[inner]).max()
    far = ~ndimage.binary_dilation(want > 0, np.ones((3, 3), bool))
    assert amount[b][np.repeat(np.repeat(far, k, 0), k, 1)].max() == 0.0


def test_smooth_gradients_and_rims_stay_bicubic(monkeypatch: pytest.MonkeyPatch) -> None:
    """A wet-in-wet blend (30 % less a cell) over a wash, a dried rim (its darkness
    rising over 3 cells to 1.4x its interior at the edge) and a dried blob's soft edge
    have no hard step: drawn exactly as without step contours."""
    st = NumpyCanvas(40, 24, seed=2).state()
    a = st.slot_of("French Ultramarine")
    b = st.slot_of("Burnt Umber")
    yy, xx = np.mgrid[0:24, 0:40]
    st.q[a] = 0.2
    st.p[b] = (0.3 * 0.7 ** np.abs(xx - 12.3)).astype(np.float32)
    dried = NumpyCanvas(40, 24, seed=2).state()
    c = dried.slot_of("Sepia")
    # a rim inside a wash on paper (its outer edge on paper: the paint's own contour)
    inward = np.minimum(np.minimum(yy - 4, 19 - yy), np.minimum(xx - 24, 37 - xx))
    dried.q[c] = np.where(inward >= 0, 0.1 + 0.04 * np.clip(1 - inward / 3, 0, 1), 0.0
                          ).astype(np.float32)
    st.r_composed[...] = render_bands(dried, "km")
    # and a dried wet-in-wet blob's soft lower edge (the demo's hills: its steepest row
    # drops 46 % after 16 %, then 24 %), in optical density over the paper
    soft = np.array([0.75, 0.7, 0.65, 0.6, 0.52, 0.47, 0.424, 0.355, 0.192, 0.146, 0.117,
                     0.1, 0.09, 0.085] + [0.08] * 10, np.float32)
    paper = st.paper_reflectance()
    st.r_composed[:, :20] = (paper[:, :20] * np.exp(-soft)[:, None])[..., None]
    got = render_scaled(st, "km", 3)
    with monkeypatch.context() as m:
        _plain(m)
        want = render_scaled(st, "km", 3)
    assert np.array_equal(got, want)
