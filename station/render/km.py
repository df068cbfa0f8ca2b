"""Rendering the canvas: Kubelka-Munk per band (seed 6.2.3) and a gouache blend.

The KM formulas below run per *band*: the 3 RGB channels of Curtis's table, or (the
default, ``SimParams.render_bands = 12``) twelve 25 nm bands over 400-700 nm with each
pigment's K(λ), S(λ) from ``station/data/spectral-palette.json``. ``r_composed`` holds the
dried layers per band, so a glaze composes with the spectrum below, not with its RGB
summary; :func:`to_linear_rgb` turns bands into linear sRGB at the very end (a fixed
(3, 12) matrix from the CIE 1931 observer under D65, rows summing to 1, so the paper's
flat grey stays grey).

Kubelka-Munk (spec formulas): per cell, thickness ``d = sum_k (p[k] + q[k])``; if
``d == 0`` the cell shows ``R_composed``; otherwise concentration-weighted
``K = sum s_k K_k``, ``S = sum s_k S_k`` with ``s_k = (p[k]+q[k])/d``, then

    a = (S + K)/S,  b = sqrt(max(a^2 - 1, 0)),  t = b S d
    R = sinh t / (a sinh t + b cosh t),  T = b / (a sinh t + b cosh t)
    R_total = R + T^2 R_prev / (1 - R R_prev)

with ``R_prev = R_composed``. Two numerical decisions: ``t`` is capped at 30
(sinh/cosh stay finite in float32; R and T have converged to 1e-13 there), and
where ``b < 1e-4`` (no absorption) the ``b -> 0`` limit ``R = S d/(1 + S d)``,
``T = 1/(1 + S d)`` is used.

Gouache (seed 6.3.2: "watercolor to which an opaque white pigment has been
added"): an opaque blend by concentration. The body colour of the paint is the
infinite-thickness KM reflectance ``R_inf = a - b`` of the concentration-weighted
mix of the cell's pigments with an implicit white filler of share
``gouache_white`` (K and S of Titanium White): ``K = (1 - g) sum s_k K_k + g K_w``,
same for S. The layer's opacity is ``o = min(1, d / gouache_opaque)`` and
``R_total = o R_inf + (1 - o) R_prev``.
"""

from __future__ import annotations

import numpy as np

from station.canvas.palette import N_BANDS, Palette, Pigment, spectral_table, upsample_rgb
from station.canvas.state import CanvasState

F32 = np.float32
RENDERERS = ("km", "gouache")


def km_coefficients(pigments: list[Pigment], bands: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """K and S of the pigments per band, float32 (n, bands): RGB (3) or spectral."""
    if bands == 3:
        k = np.array([p.K for p in pigments], F32).reshape(len(pigments), 3)
        s = np.array([p.S for p in pigments], F32).reshape(len(pigments), 3)
        return k, s
    if bands != N_BANDS:
        raise ValueError(f"render bands {bands}: 3 or {N_BANDS}")
    spec = [p.spectra() for p in pigments]
    return (np.array([k for k, _ in spec], F32).reshape(len(pigments), bands),
            np.array([s for _, s in spec], F32).reshape(len(pigments), bands))


def band_matrix(bands: int) -> np.ndarray:
    """(3, bands) float32: band reflectance -> linear sRGB (the identity for RGB)."""
    return np.eye(3, dtype=F32) if bands == 3 else spectral_table().to_rgb


def to_linear_rgb(r: np.ndarray) -> np.ndarray:
    """Band reflectance (..., bands) -> linear sRGB (..., 3) float32 in [0, 1]."""
    if r.shape[-1] == 3:
        return r.astype(F32, copy=False)
    out = np.einsum("...b,cb->...c", r, band_matrix(r.shape[-1]))
    result: np.ndarray = np.clip(out, 0.0, 1.0).astype(F32)
    return result


def km_layer(amount: np.ndarray, pigments: list[Pigment], r_prev: np.ndarray) -> np.ndarray:
    """Compose one KM layer over ``r_prev``.

    ``amount`` float32 (N, H, W) pigment thickness per pigment (p + q), ``r_prev``
    float32 (H, W, B) per band (B = 3 RGB or 12 spectral). Returns float32 (H, W, B) in
    [0, 1].
    """
    if not pigments:
        return r_prev.astype(F32, copy=True)
    amount = amount[: len(pigments)]
    kk, ss = km_coefficients(pigments, r_prev.shape[-1])
    d = amount.sum(axis=0)
    has = d > 0
    safe_d = np.where(has, d, F32(1.0))
    conc = amount / safe_d  # s_k, (N, H, W)
    k_mix = np.einsum("nhw,nc->hwc", conc, kk).astype(F32)
    s_mix = np.einsum("nhw,nc->hwc", conc, ss).astype(F32)
    s_mix = np.maximum(s_mix, F32(1e-12))
    a = (s_mix + k_mix) / s_mix
    b = np.sqrt(np.maximum(a * a - F32(1.0), F32(0.0)))
    dd = safe_d[..., None]
    t = np.minimum(b * s_mix * dd, F32(30.0))
    sh = np.sinh(t)
    ch = np.cosh(t)
    den = a * sh + b * ch
    small = b < F32(1e-4)
    den = np.where(small, F32(1.0), den)
    r = np.where(small, s_mix * dd / (F32(1.0) + s_mix * dd), sh / den)
    tr = np.where(small, F32(1.0) / (F32(1.0) + s_mix * dd), b / den)
    total = r + tr * tr * r_prev / (F32(1.0) - r * r_prev)
    out = np.where(has[..., None], total, r_prev)
    return np.clip(out, 0.0, 1.0).astype(F32)


WHITE_K = (0.02, 0.02, 0.03)  # Titanium White of station/data/pigment-properties.csv
WHITE_S = (3.0, 3.0, 3.0)


def gouache_layer(amount: np.ndarray, pigments: list[Pigment], r_prev: np.ndarray,
                  opaque: float, white: float = 0.25,
                  white_ks: tuple[tuple[float, ...], tuple[float, ...]] = (WHITE_K, WHITE_S),
                  ) -> np.ndarray:
    """Compose one gouache layer (opaque concentration blend) over ``r_prev``.

    ``opaque``: thickness that hides what is below; ``white``: share of the implicit
    white filler in the body colour; ``white_ks``: its K and S per band (RGB values are
    upsampled when ``r_prev`` is spectral).
    """
    if not pigments:
        return r_prev.astype(F32, copy=True)
    amount = amount[: len(pigments)]
    bands = r_prev.shape[-1]
    kk, ss = km_coefficients(pigments, bands)
    if bands != 3 and len(white_ks[0]) == 3:
        white_ks = (tuple(upsample_rgb(white_ks[0])), tuple(upsample_rgb(white_ks[1])))
    d = amount.sum(axis=0)
    safe_d = np.where(d > 0, d, F32(1.0))
    conc = amount / safe_d
    g = F32(white)
    k_mix = (F32(1.0) - g) * np.einsum("nhw,nc->hwc", conc, kk) + g * np.array(white_ks[0], F32)
    s_mix = (F32(1.0) - g) * np.einsum("nhw,nc->hwc", conc, ss) + g * np.array(white_ks[1], F32)
    a = (s_mix + k_mix) / np.maximum(s_mix, F32(1e-12))
    colour = (a - np.sqrt(np.maximum(a * a - F32(1.0), F32(0.0)))).astype(F32)  # R_inf
    o = np.clip(d / F32(max(opaque, 1e-6)), 0.0, 1.0)[..., None]
    out = o * colour + (F32(1.0) - o) * r_prev
    result: np.ndarray = np.clip(out, 0.0, 1.0).astype(F32)
    return result


def gouache_white_ks(state: CanvasState) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """K and S of the gouache's white filler in the state's render bands."""
    return white_filler(state.palette, state.r_composed.shape[-1])


def white_filler(palette: Palette, bands: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """K and S of the gouache's white filler per band (3 or 12): the palette's Titanium
    White, else the packaged values."""
    white = palette.get("Titanium White") if "Titanium White" in palette else None
    if bands == 3:
        return (white.K, white.S) if white is not None else (WHITE_K, WHITE_S)
    k, s = white.spectra() if white is not None else (upsample_rgb(WHITE_K),
                                                      upsample_rgb(WHITE_S))
    return tuple(map(float, k)), tuple(map(float, s))


def on_white(amount: np.ndarray, pigments: list[Pigment], bands: int = N_BANDS) -> np.ndarray:
    """Linear sRGB (..., 3) of ``amount`` (N, h, w) of ``pigments`` as a KM layer over white
    paper, in ``bands`` render bands (a swatch: the colour the canvas would show)."""
    white = np.ones((*amount.shape[1:], bands), F32)
    return to_linear_rgb(km_layer(amount, pigments, white))


def render_bands(state: CanvasState, renderer: str) -> np.ndarray:
    """Reflectance of the canvas per band, float32 (H, W, B) in [0, 1] (what
    ``new_layer`` stores in ``r_composed``)."""
    pigments = state.slot_pigments()
    n = len(pigments)
    amount = state.p[:n] + state.q[:n]
    if renderer == "gouache":
        return gouache_layer(amount, pigments, state.r_composed, state.params.gouache_opaque,
                             state.params.gouache_white, gouache_white_ks(state))
    return km_layer(amount, pigments, state.r_composed)


def render_state(state: CanvasState, renderer: str) -> np.ndarray:
    """Linear reflectance of the canvas, float32 (H, W, 3) in [0, 1]."""
    return to_linear_rgb(render_bands(state, renderer))


def region_amount(state: CanvasState, ys: slice, xs: slice,
                  extra: dict[str, np.ndarray] | None = None
                  ) -> tuple[np.ndarray, list[Pigment]]:
    """Pigment thickness ``p + q`` per pigment of the cells ``[ys, xs]`` and the pigments,
    with ``extra`` pigment per name (region-shaped arrays) added to ``p`` and capped at 1
    per cell as ``add_sources`` caps it (a preview of stamps not yet simulated)."""
    pigments = state.slot_pigments()
    amount = state.p[:len(pigments), ys, xs] + state.q[:len(pigments), ys, xs]
    if not extra:
        return amount, pigments
    names = [p.name for p in pigments]
    rows = list(amount)
    for name, add in extra.items():
        pig = state.palette.get(name)
        if pig.name in names:
            k = names.index(pig.name)
            rows[k] = state.q[k, ys, xs] + np.minimum(state.p[k, ys, xs] + add, F32(1.0))
        else:
            names.append(pig.name)
            pigments = [*pigments, pig]
            rows.append(np.minimum(add, F32(1.0)).astype(F32))
    return (np.stack(rows) if rows else amount), pigments


def render_region(state: CanvasState, renderer: str, ys: slice, xs: slice,
                  extra: dict[str, np.ndarray] | None = None) -> np.ndarray:
    """Linear reflectance of the cells ``[ys, xs]`` only, float32 (h, w, 3).

    Equals ``render_state(state, renderer)[ys, xs]`` (every cell is rendered on its
    own), so a live view re-renders just the tiles that changed.  ``extra``: see
    :func:`region_amount`.
    """
    amount, pigments = region_amount(state, ys, xs, extra)
    r_prev = state.r_composed[ys, xs]
    if renderer == "gouache":
        return to_linear_rgb(gouache_layer(amount, pigments, r_prev,
                                           state.params.gouache_opaque,
                                           state.params.gouache_white, gouache_white_ks(state)))
    return to_linear_rgb(km_layer(amount, pigments, r_prev))


def to_srgb8(rgb: np.ndarray) -> np.ndarray:
    """Linear reflectance in [0, 1] -> uint8 sRGB (for PNG output)."""
    return np.round(linear_to_srgb(rgb) * 255.0).astype(np.uint8)


def to_srgb16(rgb: np.ndarray) -> np.ndarray:
    """Linear reflectance in [0, 1] -> uint16 sRGB (for 16-bit PNG output)."""
    return np.round(linear_to_srgb(rgb) * 65535.0).astype(np.uint16)


def linear_to_srgb(rgb: np.ndarray) -> np.ndarray:
    """The sRGB transfer function (float64 result in [0, 1])."""
    x = np.clip(np.asarray(rgb, np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
