"""The spectral Kubelka-Munk render (issue 10 item 4): 12 bands, pigment spectra fitted
to Curtis's RGB appearance, glazing that reads green, backends in agreement."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from station.backends.numpy_canvas import NumpyCanvas
from station.canvas.errors import CanvasInputError
from station.canvas.palette import N_BANDS, Palette, Pigment, default_palette, spectral_table
from station.canvas.params import SimParams
from station.canvas.state import CanvasState
from station.pictures import effects as fx
from station.pictures.scenarios import distance_inside, paint, rect, run_until_dry
from station.render.km import (
    band_matrix,
    gouache_layer,
    km_layer,
    render_region,
    render_state,
    to_linear_rgb,
)
from station.render.km_fast import km_layer_fast

ROOT = Path(__file__).resolve().parents[1]
F32 = np.float32


def masstone(p: Pigment, d: float, bands: int) -> np.ndarray:
    """Linear sRGB of pigment ``p`` at thickness ``d`` over the paper's white."""
    a = np.full((1, 1, 1), d, F32)
    return to_linear_rgb(km_layer(a, [p], np.full((1, 1, bands), 0.976, F32)))[0, 0]


def test_band_matrix_keeps_grey_grey_and_white_white() -> None:
    m = band_matrix(N_BANDS)
    assert m.shape == (3, N_BANDS)
    assert np.allclose(m.sum(axis=1), 1.0, atol=1e-5)
    for r in (0.0, 0.3, 0.976, 1.0):
        assert np.allclose(to_linear_rgb(np.full((2, N_BANDS), r, F32)), r, atol=1e-5)
    # the bands carry the CIE observer: mid-spectrum is green, the short end blue
    assert int(np.argmax(m[1])) in (4, 5, 6) and int(np.argmax(m[2])) in (1, 2)
    edges = spectral_table().edges_nm
    assert edges[0] == 400.0 and edges[-1] == 700.0 and len(edges) == N_BANDS + 1


def test_every_palette_pigment_has_physical_spectra() -> None:
    for p in default_palette():
        k, s = p.spectra()
        assert len(p.K_spec) == N_BANDS and (k >= 0).all() and (s > 0).all(), p.name
    pal = default_palette()
    k_fu, _ = pal.get("French Ultramarine").spectra()
    k_hy, _ = pal.get("Hansa Yellow").spectra()
    # PB29 absorbs ~550-650 nm, transmits 400-500 nm; PY3 absorbs below ~490 nm
    assert k_fu[6:9].min() > 2.5 * k_fu[:3].max()  # one broad S3- band near 600 nm
    assert k_hy[:3].min() > 5 * k_hy[5:].max()


@pytest.mark.parametrize("name", [p.name for p in default_palette()])
def test_single_pigments_keep_their_palette_colour(name: str) -> None:
    """A watercolorist sees the same hues as with Curtis's RGB K, S: masstone ΔE76 per
    thickness, old (3 bands) vs new (12 bands). French Ultramarine pays for the green
    glaze (docs/canvas-model.md) and is held to its own, looser bound."""
    p = default_palette().get(name)
    if name in ("French Ultramarine", "Quinacridone Rose", "Cerulean Blue"):
        pytest.skip("fitted to the real pigment's hue, not Curtis's RGB (issue 21 item 6)")
    limit = {"Hansa Yellow": 6.0}.get(name, 5.0)
    for d in (0.1, 0.25, 0.5):
        de = fx.delta_e76(masstone(p, d, 3), masstone(p, d, N_BANDS))
        assert de <= limit, (name, d, de)


def test_french_ultramarine_is_a_violet_leaning_blue() -> None:
    """Issue 21 item 6: PB29's masstone is HSV 240-250 with CIELAB a* > 0 (Curtis's RGB K, S
    painted it azure, 214), its absorption band still near 600 nm."""
    p = default_palette().get("French Ultramarine")
    rgb = masstone(p, 1.0, N_BANDS)
    assert 235.0 <= fx.hue_deg(fx.linear_to_srgb(rgb)) <= 255.0
    assert fx.lab(rgb)[1] > 10.0
    k, _ = p.spectra()
    assert 5 <= int(np.argmax(k)) <= 8  # 525-625 nm


def test_glaze_is_green_and_unlike_the_mix() -> None:
    e = fx.glazing()
    assert e.ok, e.numbers
    assert e.numbers["delta_e76_glaze_vs_mix"] >= 5.0
    assert 90.0 <= e.numbers["glaze_hue_deg"] <= 160.0
    assert 90.0 <= e.numbers["glaze_hue_srgb_deg"] <= 160.0  # as the screen shows it


def test_blue_and_yellow_overlap_to_green_on_one_canvas() -> None:
    c = NumpyCanvas(48, 24, seed=2, paper="hot-press")
    # Cerulean: Hansa Yellow over French Ultramarine (PB29, fitted to its real violet-leaning
    # hue) reads olive, as it does on paper
    paint(c, rect(24, 48, 4, 20, 4, 30), 0.5, {"Cerulean Blue": 0.7})
    run_until_dry(c, 6000)
    c.new_layer()
    paint(c, rect(24, 48, 4, 20, 18, 44), 0.5, {"Hansa Yellow": 0.3})
    run_until_dry(c, 6000)
    img = c.render()
    blue, both, yellow = img[8:16, 8:14].mean((0, 1)), img[8:16, 22:27].mean((0, 1)), \
        img[8:16, 34:40].mean((0, 1))
    assert 180 < fx.hue_deg(blue) < 250 and 40 < fx.hue_deg(yellow) < 70
    assert 90 <= fx.hue_deg(both) <= 160, both


def test_granulation_is_visible_at_one_to_one() -> None:
    c = NumpyCanvas(48, 48, seed=5)
    fp = rect(48, 48, 6, 42, 6, 42)
    paint(c, fp, 0.6, {"French Ultramarine": 0.3})
    run_until_dry(c, 6000)
    c.dry()
    st, img = c.live_state, c.render()
    inner = distance_inside(fp) >= 4
    h = st.h[inner]
    valley, hill = h < np.quantile(h, 0.25), h > np.quantile(h, 0.75)
    de = fx.delta_e76(img[inner][valley].mean(axis=0), img[inner][hill].mean(axis=0))
    # one pixel per cell, valleys visibly darker than hills: dE76 3+ on the two-octave paper
    # without the rim, 2.2 on the broadband paper with issue 21's rim flow (which keeps
    # pigment moving to the edge); the brushed wash's 1:1 visibility (luma std >= 8/255) is
    # asserted in test_effects_brush. 2.18 with the wet-wash drop's levers on (session 13:
    # the pigment's low diffusion in standing water only deeper than 0.05, so the wash's last
    # thin film lets it settle by the paper's height; 1.58 with standing_depth 0.005)
    assert de >= 2.0, de
    assert img[inner][valley].mean() < img[inner][hill].mean()


def _random_layer(bands: int, seed: int = 0) -> tuple[np.ndarray, list[Pigment], np.ndarray]:
    pal = default_palette()
    pigs = [pal.get(n) for n in ("French Ultramarine", "Hansa Yellow", "Burnt Umber",
                                 "Interference Lilac", "Black")]
    rng = np.random.default_rng(seed)
    a = (rng.random((len(pigs), 40, 50)) * 0.6).astype(F32)
    a[:, :8] = 0.0  # bare paper
    a[:, 8:16] = 1e-7  # the b -> 0 branch and tiny d
    a[:, 16:24] = 50.0  # t capped at 30
    r = (0.5 + 0.5 * rng.random((40, 50, bands))).astype(F32)
    return a, pigs, r


@pytest.mark.parametrize("bands", [3, N_BANDS])
def test_compiled_km_matches_the_reference(bands: int) -> None:
    a, pigs, r = _random_layer(bands)
    ref = to_linear_rgb(km_layer(a, pigs, r))
    got = km_layer_fast(a, pigs, r)
    assert got.shape == (40, 50, 3) and got.dtype == F32
    assert float(np.abs(got - ref).max()) < 2e-6
    assert float(np.abs(km_layer_fast(a, [], r) - to_linear_rgb(r)).max()) < 1e-6


def test_gouache_still_covers_in_bands() -> None:
    pal = default_palette()
    white = pal.get("Titanium White")
    a = np.full((1, 4, 4), 1.0, F32)
    dark = np.full((4, 4, N_BANDS), 0.05, F32)
    ks = tuple(map(float, white.spectra()[0])), tuple(map(float, white.spectra()[1]))
    out = to_linear_rgb(gouache_layer(a, [white], dark, 0.6, 0.25, ks))
    assert out.min() > 0.8  # opaque white over a dark layer


def test_states_keep_their_bands_through_save_and_load(tmp_path: Path) -> None:
    c = NumpyCanvas(24, 16, seed=1)
    paint(c, rect(16, 24, 2, 14, 2, 22), 0.4, {"French Ultramarine": 0.4})
    c.new_layer()
    st = c.state()
    assert st.r_composed.shape == (16, 24, N_BANDS)
    st.save(tmp_path / "s.npz")
    back = CanvasState.load(tmp_path / "s.npz")
    assert np.array_equal(back.r_composed, st.r_composed)
    assert np.array_equal(render_state(back, "km"), render_state(st, "km"))
    # a state of the RGB renderer (an older file) loads and renders as it did
    old = NumpyCanvas(24, 16, seed=1, params=SimParams(render_bands=3))
    paint(old, rect(16, 24, 2, 14, 2, 22), 0.4, {"French Ultramarine": 0.4})
    old.new_layer()
    ost = old.state()
    ost.params = SimParams()  # what an older file's metadata decodes to
    ost.save(tmp_path / "o.npz")
    back = CanvasState.load(tmp_path / "o.npz")
    assert back.r_composed.shape == (16, 24, 3) and back.params.render_bands == 3
    assert np.array_equal(render_state(back, "km"), old.render())
    with pytest.raises(CanvasInputError):
        SimParams(render_bands=5)


def test_region_render_and_upsampled_pigments() -> None:
    c = NumpyCanvas(32, 24, seed=3)
    paint(c, rect(24, 32, 4, 20, 4, 28), 0.4, {"Cerulean Blue": 0.3})
    for _ in range(10):
        c.step()
    st = c.live_state
    full = render_state(st, "km")
    part = render_region(st, "km", slice(3, 17), slice(5, 30))
    assert np.array_equal(part, full[3:17, 5:30])
    # a pigment known only by RGB (a user profile's) gets a smooth spectrum; flat stays flat
    grey = Pigment("Grey", (0.5, 0.5, 0.5), (0.1, 0.1, 0.1), 1.0, 0.0, 0.5)
    k, s = grey.spectra()
    assert np.allclose(k, 0.5) and np.allclose(s, 0.1)
    red = Pigment("Red", (0.1, 1.0, 2.0), (0.1, 0.1, 0.1), 1.0, 0.0, 0.5)
    rgb = masstone(red, 0.5, N_BANDS)
    assert rgb[0] > rgb[1] > rgb[2]
    assert Palette([red]).get("red").spectra()[0].shape == (N_BANDS,)
    with pytest.raises(CanvasInputError):
        Pigment("Bad", (0.1, 0.1, 0.1), (0.1, 0.1, 0.1), 1.0, 0.0, 0.5, K_spec=(0.1,) * 3,
                S_spec=(0.1,) * 3)


@pytest.mark.skipif(importlib.util.find_spec("colour") is None,
                    reason="colour-science (generation time only) is not installed")
def test_spectral_table_is_what_the_generator_writes() -> None:
    out = subprocess.run([sys.executable, str(ROOT / "tools" / "gen_spectral_palette.py"),
                          "--check"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr


def test_a_profile_selects_the_rgb_renderer() -> None:
    from importlib import resources

    from station.canvas.profiles import parse_profile

    text = resources.files("station").joinpath("data", "profiles", "watercolor.xml").read_text()
    rgb = text.replace('gouache_white="0.25"/>', 'gouache_white="0.25" render_bands="3"/>')
    assert rgb != text
    assert parse_profile(rgb.encode(), "rgb.xml").params.render_bands == 3
    assert parse_profile(text.encode(), "w.xml").params.render_bands == N_BANDS
    with pytest.raises(CanvasInputError):
        parse_profile(rgb.replace('render_bands="3"', 'render_bands="5"').encode(), "bad.xml")
