"""Rendering beyond the simulation grid (seed future work 9.2.1; MoXi renders a 512²
simulation at 1536²): ``render_scaled(state, renderer, k)`` draws a canvas at ``k`` pixels
per cell.

The pigment fields and the reflectance of the dried layers are resampled bicubically
(Pillow), so stroke edges become smooth ramps instead of cell staircases. Detail below the
cell comes from the paper: a finer Worley texture of the same preset (seed-derived),
high-passed so it adds grain without moving the cell averages. The grain shades the blank
paper (``paper_shade``, as the one-cell renderer does) and, for deposited pigment, applies
the surface layer's own granulation law below the cell: deposits favour the valleys by
``1 - gamma * h'`` (``h'`` the sub-cell height deviation), renormalised per cell so every
cell keeps its simulated amount. Nothing else is invented: no pigment appears where the
simulation has none.
"""

from __future__ import annotations

import numpy as np
from PIL import Image

from station.canvas.paper import make_paper
from station.canvas.params import CanvasInputError
from station.canvas.render import WHITE_K, WHITE_S, gouache_layer, km_layer
from station.canvas.render import render_state as render_cells
from station.canvas.state import CanvasState

F32 = np.float32
MAX_SCALE = 4


def _resample(a: np.ndarray, k: int) -> np.ndarray:
    """Bicubic resampling of a float field (H, W) to (kH, kW), cell centres kept; >= 0."""
    hh, ww = a.shape
    im = Image.fromarray(np.ascontiguousarray(a, dtype=np.float32), mode="F")
    out = np.asarray(im.resize((ww * k, hh * k), Image.Resampling.BICUBIC), dtype=F32)
    return np.maximum(out, F32(0.0))


def _cell_mean(a: np.ndarray, k: int) -> np.ndarray:
    hh, ww = a.shape[0] // k, a.shape[1] // k
    return a.reshape(hh, k, ww, k).mean(axis=(1, 3))


def paper_detail(state: CanvasState, k: int) -> np.ndarray:
    """Zero-mean-per-cell paper height detail at ``k`` pixels per cell (float32, [-1, 1])."""
    fine = make_paper(state.paper_preset, state.height * k, state.width * k, state.seed + 7919)
    hp = fine - np.repeat(np.repeat(_cell_mean(fine, k), k, 0), k, 1)
    return hp.astype(F32)


def render_scaled(state: CanvasState, renderer: str, k: int) -> np.ndarray:
    """Linear reflectance at ``k`` pixels per cell, float32 (kH, kW, 3) in [0, 1]."""
    if not isinstance(k, int) or not 1 <= k <= MAX_SCALE:
        raise CanvasInputError(f"render scale {k!r} must be an integer 1..{MAX_SCALE}",
                               "--scale")
    if k == 1:
        return render_cells(state, renderer)
    hp = paper_detail(state, k)
    shade = F32(state.params.paper_shade)
    r_prev = np.stack([_resample(state.r_composed[..., c], k) for c in range(3)], axis=-1)
    r_prev = np.clip(r_prev * (F32(1.0) + shade * hp)[..., None], 0.0, 1.0).astype(F32)
    pigments = state.slot_pigments()
    amounts = []
    for i, pig in enumerate(pigments):
        p = _resample(state.p[i], k)
        q = _resample(state.q[i], k)
        if pig.gamma > 0:
            g = np.maximum(F32(1.0) - F32(pig.gamma) * hp, F32(0.0))
            gq = q * g
            cell_q = np.repeat(np.repeat(_cell_mean(q, k), k, 0), k, 1)
            cell_gq = np.repeat(np.repeat(_cell_mean(gq, k), k, 0), k, 1)
            q = np.where(cell_gq > 0, gq * (cell_q / np.where(cell_gq > 0, cell_gq, 1)), q)
        amounts.append(p + q)
    amount = (np.stack(amounts) if amounts
              else np.zeros((0, state.height * k, state.width * k), F32)).astype(F32)
    if renderer == "gouache":
        ks = (WHITE_K, WHITE_S)
        if "Titanium White" in state.palette:
            white = state.palette.get("Titanium White")
            ks = (white.K, white.S)
        return gouache_layer(amount, pigments, r_prev, state.params.gouache_opaque,
                             state.params.gouache_white, ks)
    return km_layer(amount, pigments, r_prev)
