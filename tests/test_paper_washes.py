"""Issue 21 item 7 on hot-press paper: a flat Ultramarine wash brushed on it is broadband
(no band of its radial spectrum above 1.5x its neighbours half an octave away)."""

from __future__ import annotations

import station.pictures.effects as fx


def test_a_brushed_wash_on_hot_press_is_broadband() -> None:
    """1.56 (at 7.8 cells) with the paper's octaves half an octave apart; 1.37 a quarter
    octave apart with weights in proportion to the spacing. The measure sees 64x72 cells,
    where white noise reads 1.1-1.6 (20 draws) and the paper itself 1.26-1.58 (16 seeds)."""
    c = fx.flat_wash("French Ultramarine", 0.7, "hot-press")
    inner = (slice(16, fx.WASH - 16), slice(12, fx.WASH - 12))
    lum = fx.luma(c.render())[inner]
    assert float(fx.darkness_map(c)[inner].mean()) >= 0.3
    peak, _ = fx.spectral_peak(lum)
    assert peak <= 1.45, peak
