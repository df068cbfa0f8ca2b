"""The effects sheet's bloom tile (issue 21 item 4), painted through the brush: clear
water and a second colour dropped into a damp wash, a drop of colour into a wet one."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from station.backends.numpy_canvas import NumpyCanvas
from station.brush.stamp import BrushModel
from station.pictures.effects_core import (
    PEN_HZ,
    Effect,
    _played,
    darkness_map,
)
from station.pictures.scenarios import run_until_dry
from station.sim.player import SessionPlayer
from station.sim.script import Script


def _wash_then(first: Script, seed: int, until_damp: bool
               ) -> tuple[NumpyCanvas, SessionPlayer]:
    h = first.header
    c = NumpyCanvas(h.width, h.height, profile=h.profile, seed=seed)
    p = SessionPlayer(c, h.width, h.height, h.profile)
    p.play(first.records)
    st = c.live_state
    inner = (slice(h.height // 4, 3 * h.height // 4), slice(h.width // 4, 3 * h.width // 4))
    n = 0
    while until_damp and (st.w[inner] > 0).any() and n < 6000:
        c.step()
        n += 1
    return c, p


def _later(p: SessionPlayer, w: int, h: int, seed: int) -> Script:
    s = Script(w, h, seed=seed, rate_hz=PEN_HZ)
    s.t = p.painting_time + 0.05
    return s


def _radius_cv(region: np.ndarray, cy: float, cx: float, n: int = 64) -> tuple[float, float]:
    """Mean radius [cells] and coefficient of variation of ``region``'s outline seen from
    (cy, cx): along each of ``n`` rays the last cell still inside."""
    radii = []
    for a in np.linspace(0, 2 * np.pi, n, endpoint=False):
        r = 0.0
        for t in np.arange(0.5, max(region.shape), 0.5):
            y, x = int(cy + t * np.sin(a)), int(cx + t * np.cos(a))
            if not (0 <= y < region.shape[0] and 0 <= x < region.shape[1]) or not region[y, x]:
                break
            r = t
        radii.append(r)
    rr = np.array(radii)
    return float(rr.mean()), float(rr.std() / max(rr.mean(), 1e-9))


DROP_SIZE, DROP_S = 12, 0.3
"""The clear-water drop of the bloom tile: brush size and how long the brush touches [s]."""


def blooms() -> Effect:
    """Item 4: (a) clear water dabbed (size 12, 0.3 s) into a brushed Ultramarine wash once
    its standing water is gone but the paper is still wet: the bloom's front over the wash's
    darkness, its radius CV; (b) a dab of Ultramarine (amount 1) into a fully wet clear
    wash: its spread over the brush radius, its peak darkness over the same dab on dry
    paper."""
    n = 80
    wash = Script(n, n, seed=22, rate_hz=PEN_HZ)
    wash.brush(size=24, water=1.0, pigment={"French Ultramarine": 0.4})
    for k in range(7):
        y = (8 + 11 * k) / n
        a, b = ((0.05, y), (0.95, y)) if k % 2 == 0 else ((0.95, y), (0.05, y))
        wash.line(a, b, 0.45, pressure=0.7)
        wash.wait(0.2)
    c1, p1 = _wash_then(wash, 22, until_damp=True)
    drop = _later(p1, n, n, 22)
    drop.brush(size=DROP_SIZE, water=1.0, pigment={})
    drop.dab((0.5, 0.5), DROP_S, pressure=0.7)
    p1.play(drop.records)
    run_until_dry(c1, 6000)
    c1.dry()
    d1 = darkness_map(c1)
    wash_dark = float(np.median(d1[8:n - 8, 8:n - 8]))
    pale = ndimage.binary_fill_holes(d1 < 0.85 * wash_dark)
    lab_, _ = ndimage.label(pale)
    centre = lab_[n // 2, n // 2]
    bloom = lab_ == centre if centre else np.zeros_like(pale)
    rim = ndimage.binary_dilation(bloom, iterations=3) & ~bloom
    front = float(np.percentile(d1[rim], 75)) / max(wash_dark, 1e-6) if rim.any() else 0.0
    radius, cv = _radius_cv(bloom, n / 2, n / 2) if bloom.any() else (0.0, 0.0)

    def dab(wet: bool) -> NumpyCanvas:
        s = Script(n, n, seed=23, rate_hz=PEN_HZ)
        if wet:
            s.brush(size=24, water=1.0, pigment={})
            for k in range(7):
                y = (8 + 11 * k) / n
                a, b = ((0.05, y), (0.95, y)) if k % 2 == 0 else ((0.95, y), (0.05, y))
                s.line(a, b, 0.45, pressure=0.7)
        s.brush(size=12, water=0.8, pigment={"French Ultramarine": 1.0})
        s.dab((0.5, 0.5), 0.3, pressure=0.7)
        return _played(s, seed=23)

    wet, dry = dab(True), dab(False)
    dw, dd = darkness_map(wet), darkness_map(dry)
    r_brush = BrushModel().radius(12, 0.7)
    spread_r = float(np.sqrt((dw > 0.25 * dw.max()).sum() / np.pi)) if dw.max() > 0 else 0.0
    peak_share = float(np.percentile(dw, 99.5) / max(np.percentile(dd, 99.5), 1e-6))
    return Effect("blooms (brush)", {"bloom_front_ratio": front, "bloom_radius_cells": radius,
                                     "bloom_radius_cv": cv,
                                     "drop_spread_over_brush_radius": spread_r / r_brush,
                                     "drop_peak_over_dry": peak_share},
                  {"bloom front >= 1.3x": front >= 1.3, "irregular (CV >= 0.15)": cv >= 0.15,
                   "drop spreads >= 2.5 r": spread_r >= 2.5 * r_brush,
                   "drop stays visible (>= 0.5x dry)": peak_share >= 0.5},
                  np.concatenate([c1.render(), wet.render(), dry.render()], axis=1),
                  (c1, wet, dry))
