"""Rendering beyond the simulation grid (seed future work 9.2.1; MoXi renders a 512²
simulation at 1536²): ``render_scaled(state, renderer, k)`` draws a canvas at ``k`` pixels
per cell.

The pigment fields and the reflectance of the dried layers are resampled bicubically
(Pillow), so they vary smoothly inside the paint. Detail below the
cell comes from the paper: a finer Worley texture of the same preset (seed-derived),
high-passed so it adds grain without moving the cell averages. The grain shades the blank
paper (``paper_shade``, as the one-cell renderer does) and, for deposited pigment, applies
the surface layer's own granulation law below the cell: deposits favour the valleys by
``1 - gamma * h'`` (``h'`` the sub-cell height deviation), renormalised per cell so every
cell keeps its simulated amount.

The edge of the paint (between painted and blank cells) is drawn as a smooth sub-cell
contour instead of the cells' staircase (MoXi draws its edges from an upsampled field
too): the painted-cell indicator is blurred (Gaussian, ``EDGE_SIGMA`` cells), divided by
its 3x3 local peak (so a lone cell or a one-cell line keeps a 1/2 level), resampled
bicubically, and its 1/2 level set becomes the edge, anti-aliased over one output pixel.
Inside the contour each pigment has its cell's density, extended into the blank cells the
contour reaches (the mean of their painted 3x3 neighbours), so paint reaches the smooth
contour instead of stopping at the cell border. The dried layers below (``r_composed``)
get the same treatment through their difference from the blank paper. Interior cells keep
their amounts; along the edge a cell's paint is redistributed within about a cell, and no
pigment appears farther than a cell from where the simulation put it.
"""

from __future__ import annotations

import numpy as np
from PIL import Image
from scipy import ndimage

from station.canvas.paper import make_paper
from station.canvas.params import CanvasInputError
from station.canvas.state import CanvasState
from station.render.km import gouache_layer, gouache_white_ks, km_layer, to_linear_rgb
from station.render.km import render_state as render_cells

F32 = np.float32
MAX_SCALE = 4


def _resample(a: np.ndarray, k: int) -> np.ndarray:
    """Bicubic resampling of a float field (H, W) to (kH, kW), cell centres kept; >= 0."""
    hh, ww = a.shape
    im = Image.fromarray(np.ascontiguousarray(a, dtype=np.float32), mode="F")
    out = np.asarray(im.resize((ww * k, hh * k), Image.Resampling.BICUBIC), dtype=F32)
    return np.maximum(out, F32(0.0))


def _resample_signed(a: np.ndarray, k: int) -> np.ndarray:
    """Bicubic resampling of a signed float field (H, W) to (kH, kW), cell centres kept."""
    hh, ww = a.shape
    im = Image.fromarray(np.ascontiguousarray(a, dtype=np.float32), mode="F")
    return np.asarray(im.resize((ww * k, hh * k), Image.Resampling.BICUBIC), dtype=F32)


def _cell_mean(a: np.ndarray, k: int) -> np.ndarray:
    hh, ww = a.shape[0] // k, a.shape[1] // k
    out: np.ndarray = a.reshape(hh, k, ww, k).mean(axis=(1, 3))
    return out


def paper_detail(state: CanvasState, k: int) -> np.ndarray:
    """Zero-mean-per-cell paper height detail at ``k`` pixels per cell (float32, [-1, 1])."""
    fine = make_paper(state.paper_preset, state.height * k, state.width * k, state.seed + 7919)
    hp = fine - np.repeat(np.repeat(_cell_mean(fine, k), k, 0), k, 1)
    out: np.ndarray = hp.astype(F32)
    return out


EDGE_SIGMA = 0.8  # [cells] blur of the painted-cell indicator that rounds the staircase


def edge_coverage(painted: np.ndarray, k: int) -> np.ndarray:
    """Sub-cell coverage (float32 (kH, kW) in [0, 1]) of the painted cells ``painted``
    (bool (H, W)): the 1/2 level set of the blurred, bicubically resampled indicator,
    anti-aliased over one output pixel."""
    lvl = ndimage.gaussian_filter(painted.astype(F32), EDGE_SIGMA, mode="constant")
    # relative to the local peak, so a lone cell or a one-cell line keeps its 1/2 level
    peak = ndimage.maximum_filter(lvl, size=3, mode="constant")
    lvl = np.where(peak > 0, lvl / np.maximum(peak, F32(1e-6)), F32(0)).astype(F32)
    up = _resample(lvl, k)
    gy, gx = np.gradient(up)
    slope = np.maximum(np.hypot(gx, gy), F32(1e-6))
    out: np.ndarray = np.clip((up - F32(0.5)) / slope + F32(0.5), 0.0, 1.0).astype(F32)
    return out


def _extended(a: np.ndarray, painted: np.ndarray) -> np.ndarray:
    """``a`` on painted cells; on blank cells the mean of their painted 3x3 neighbours."""
    box = np.ones((3, 3), F32)
    num = ndimage.convolve(np.where(painted, a, F32(0)).astype(F32), box, mode="constant")
    den = ndimage.convolve(painted.astype(F32), box, mode="constant")
    return np.where(painted, a, np.where(den > 0, num / np.maximum(den, F32(1)), F32(0))
                    ).astype(F32)


def render_scaled(state: CanvasState, renderer: str, k: int) -> np.ndarray:
    """Linear reflectance at ``k`` pixels per cell, float32 (kH, kW, 3) in [0, 1]."""
    if not isinstance(k, int) or not 1 <= k <= MAX_SCALE:
        raise CanvasInputError(f"render scale {k!r} must be an integer 1..{MAX_SCALE}",
                               "--scale")
    if k == 1:
        return render_cells(state, renderer)
    hp = paper_detail(state, k)
    shade = F32(state.params.paper_shade)
    # the dried layers below: blank paper plus their difference from it, inside their own
    # smooth contour
    paper = state.paper_reflectance()
    diff = state.r_composed - paper[..., None]
    dried = np.abs(diff).max(axis=-1) > F32(1e-4)
    dcover = edge_coverage(dried, k)
    base = _resample(paper, k)
    r_prev = np.stack([base + dcover * _resample_signed(_extended(diff[..., c], dried), k)
                       for c in range(diff.shape[-1])], axis=-1)
    r_prev = np.clip(r_prev * (F32(1.0) + shade * hp)[..., None], 0.0, 1.0).astype(F32)
    pigments = state.slot_pigments()
    n = len(pigments)
    painted = (state.p[:n] + state.q[:n]).sum(axis=0) > F32(1e-6)
    cover = edge_coverage(painted, k)
    amounts = []
    for i, pig in enumerate(pigments):
        p = _resample(_extended(state.p[i], painted), k) * cover
        q = _resample(_extended(state.q[i], painted), k) * cover
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
        return to_linear_rgb(gouache_layer(amount, pigments, r_prev,
                                           state.params.gouache_opaque,
                                           state.params.gouache_white, gouache_white_ks(state)))
    return to_linear_rgb(km_layer(amount, pigments, r_prev))
