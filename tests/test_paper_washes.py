"""Issue 21 item 7 on hot-press paper: a flat Ultramarine wash brushed on it is broadband
(no band of its radial spectrum above 1.5x its neighbours half an octave away)."""

from __future__ import annotations

import numpy as np

import station.pictures.effects as fx


def test_a_brushed_wash_on_hot_press_is_broadband() -> None:
    """1.18 on a 128-cell sheet (seed 13; 1.29 on seed 14, 1.24 the two averaged) with
    settled pigment lifted 5x faster than it settles (lift_gain 5, lift7); 1.14 (1.19,
    1.13) without. The 64x72 window of a 96-cell wash, which this test used before, read
    1.445 -> 1.51 for the same change: white noise reads 1.0-1.75 there, the paper's own
    height 1.26-1.58."""
    n = fx.SPECTRUM_WASH
    c = fx.flat_wash("French Ultramarine", 0.7, "hot-press", seed=13, size=n)
    inner = (slice(16, n - 16), slice(12, n - 12))
    lum = fx.luma(c.render())[inner]
    assert float(fx.darkness_map(c)[inner].mean()) >= 0.3
    peak, _ = fx.spectral_peak(lum)
    assert peak <= 1.45, peak


def test_the_spectrum_window_resolves_a_1_5_floor_on_white_noise() -> None:
    """The paper tile's window (a SPECTRUM_WASH sheet less its margins: 96x104 cells, 9
    Welch tiles) reads white noise at 1.09-1.29 (60 draws); the 64x72 window of a 96-cell
    wash (2 tiles) read 1.0-1.75, so a wash's 1.78 there was mostly the measure's noise."""
    rng = np.random.default_rng(5)
    n = fx.SPECTRUM_WASH
    peaks = [fx.spectral_peak(rng.normal(size=(n - 32, n - 24)))[0] for _ in range(12)]
    assert max(peaks) <= 1.35, peaks
    # averaging independent images narrows it further
    assert fx.spectral_peak([rng.normal(size=(n - 32, n - 24)) for _ in range(4)])[0] <= 1.2


def test_a_brushed_wash_on_rough_paper_is_broadband() -> None:
    """Issue 21 item 7: the rough paper's wash read 1.78 (4.6 cells) in the 64x72 window;
    on a 128-cell sheet it reads 1.39 (1.38-1.39 on three papers), the rough paper's own
    height 1.30 averaged over 16 papers: the paper was broadband, the window was not."""
    n = fx.SPECTRUM_WASH
    c = fx.flat_wash("French Ultramarine", 0.7, "rough", seed=13, size=n)
    inner = (slice(16, n - 16), slice(12, n - 12))
    lum = fx.luma(c.render())[inner]
    assert float(fx.darkness_map(c)[inner].mean()) >= 0.3
    assert float(lum.std()) * 255 >= 8.0  # rough granulates visibly
    peak, _ = fx.spectral_peak(lum)
    assert peak <= 1.45, peak
