"""Issue 21 item 7 on the other papers: a flat Ultramarine wash brushed on hot-press and on
rough paper is broadband (no band of its radial spectrum above 1.5x its neighbours half an
octave away) and granulates more on rough than on hot-press."""

from __future__ import annotations

import pytest

import station.pictures.effects as fx


@pytest.mark.parametrize(("paper", "before"), [("hot-press", 1.56), ("rough", 1.78)])
def test_a_brushed_wash_on_the_other_papers_is_broadband(paper: str, before: float) -> None:
    """``before``: the peak with the papers' octaves half an octave apart (a bump at the
    8-cell and 4-cell octave); a quarter octave apart under smooth weights it is gone.
    The measure sees 64x72 cells: white noise there reads 1.1-1.6."""
    c = fx.flat_wash("French Ultramarine", 0.7, paper)
    inner = (slice(16, fx.WASH - 16), slice(12, fx.WASH - 12))
    lum = fx.luma(c.render())[inner]
    assert float(fx.darkness_map(c)[inner].mean()) >= 0.3
    peak, _ = fx.spectral_peak(lum)
    assert peak <= 1.45, (peak, before)
    if paper == "rough":  # granulation visible at 1:1 on the toothy paper
        assert float(lum.std()) * 255 >= 8.0
