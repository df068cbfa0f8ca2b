"""Kubelka–Munk of a canvas region, compiled with numba (the display's hot loop).

The same formulas, constants and float32 arithmetic as
:func:`station.render.km.km_layer` followed by
:func:`station.render.km.to_linear_rgb` (the NumPy reference, which tests hold
this to), fused into one pass per cell instead of a dozen array temporaries: on the
2-core development machine about five times faster, which is what lets the kiosk
re-render a wet stroke's tiles every simulation step. The bands are the canvas's
(``r_composed``'s last axis): 3 RGB channels, or 12 spectral bands reduced to linear
sRGB in the same pass.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from station.canvas.palette import Pigment
from station.render.km import band_matrix, km_coefficients

F32 = np.float32


@numba.njit(parallel=True, cache=True, fastmath=False, error_model="numpy", nogil=True)
def _km(amount: np.ndarray, kk: np.ndarray, ss: np.ndarray, r_prev: np.ndarray,
        to_rgb: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - compiled
    n, h, w = amount.shape
    nb = r_prev.shape[2]
    one = np.float32(1.0)
    zero = np.float32(0.0)
    identity = nb == 3
    for y in numba.prange(h):
        band = np.empty(nb, np.float32)
        conc = np.empty(n, np.float32)
        for x in range(w):
            d = zero
            for k in range(n):
                d += amount[k, y, x]
            if not d > zero:
                for c in range(nb):
                    band[c] = r_prev[y, x, c]
            else:
                for k in range(n):
                    conc[k] = amount[k, y, x] / d
                for c in range(nb):
                    km = zero
                    sm = zero
                    for k in range(n):
                        km += conc[k] * kk[k, c]
                        sm += conc[k] * ss[k, c]
                    sm = max(sm, np.float32(1e-12))
                    a = (sm + km) / sm
                    b = np.float32(math.sqrt(max(a * a - one, zero)))
                    rp = r_prev[y, x, c]
                    if b < np.float32(1e-4):
                        sd = sm * d
                        r = sd / (one + sd)
                        tr = one / (one + sd)
                    else:
                        t = min(b * sm * d, np.float32(30.0))
                        # one exp for both (float64: no cancellation for small t)
                        e = math.exp(np.float64(t))
                        ei = 1.0 / e
                        sh = np.float32(0.5 * (e - ei))
                        ch = np.float32(0.5 * (e + ei))
                        den = a * sh + b * ch
                        r = sh / den
                        tr = b / den
                    total = r + tr * tr * rp / (one - r * rp)
                    band[c] = min(max(total, zero), one)
            if identity:
                for c in range(3):
                    out[y, x, c] = band[c]
            else:
                for c in range(3):
                    acc = zero
                    for j in range(nb):
                        acc += to_rgb[c, j] * band[j]
                    out[y, x, c] = min(max(acc, zero), one)


def km_layer_fast(amount: np.ndarray, pigments: list[Pigment], r_prev: np.ndarray
                  ) -> np.ndarray:
    """``to_linear_rgb(km_layer(amount, pigments, r_prev))``, compiled: float32
    (h, w, 3) linear sRGB in [0, 1] for ``r_prev`` of 3 or 12 bands."""
    r_prev = np.ascontiguousarray(r_prev, F32)
    bands = r_prev.shape[-1]
    out = np.empty((*r_prev.shape[:2], 3), F32)
    if pigments:
        kk, ss = km_coefficients(pigments, bands)
        use = np.ascontiguousarray(amount[:len(pigments)], F32)
    else:  # nothing painted: the layers below, through the same band reduction
        kk = ss = np.ones((0, bands), F32)
        use = np.zeros((0, *r_prev.shape[:2]), F32)
    _km(use, kk, ss, r_prev, np.ascontiguousarray(band_matrix(bands), F32), out)
    return out
