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

Edges inside the paint (a wash's edge over another colour, a glaze's edge, a dried layer's
edge over an earlier one) get a contour of their own (:func:`hard_pairs`): where the
surface layer's absorption (:func:`layer_absorption`, one scalar for all its pigments) or
the dried layers' optical density steps hard between two painted neighbours — more than
doubles, or rises by :data:`HARD_SHARE` of its top in one cell while the cells beyond rise
little — each field is split into a high side and a low side, each extended one cell
across the step (:class:`HardEdges`), and the two are blended along the 1/2 level set of
the high side's indicator averaged along the edge (:func:`step_level`: a staircase with
long treads straightens, a one-cell line keeps its width). Where nothing steps hard
(wet-in-wet, rims, granulation) the result is exactly the bicubic resampling. Along a
step a cell's paint moves to the straight edge, within a cell.
"""

from __future__ import annotations

import numpy as np
from PIL import Image
from scipy import ndimage

from station.canvas.palette import Pigment
from station.canvas.paper import make_paper
from station.canvas.params import CanvasInputError
from station.canvas.state import CanvasState
from station.render.km import (
    gouache_layer,
    gouache_white_ks,
    km_coefficients,
    km_layer,
    to_linear_rgb,
)
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


#: A hard edge inside the paint: a cell below this share of a neighbour's pigment (a
#: wet-on-dry edge, a glaze's edge); smoother steps (wet-in-wet) stay bicubic.
HARD_RATIO = 0.5
#: ... and the step at least this much absorption (pigment amount times its mean KM
#: absorption; below it nothing shows).
HARD_MIN_AMOUNT = 1e-3
#: A hard edge in the dried layers: their mean optical density (``-ln`` of the
#: reflectance over the bare paper's, over the bands) stepping by at least this much.
HARD_MIN_DENSITY = 0.03
#: Or a step by this share of its top in one cell, the cells beyond rising less than
#: HARD_ISOLATION of it (the front mountain's glaze over the back one's wash).
HARD_SHARE = 0.3
HARD_ISOLATION = 0.35
#: Cells each way from a step's high side that its side indicator reaches.
SIDE_REACH = 2

_NEIGHBOURS = tuple((dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx)


def _shifted(a: np.ndarray, dy: int, dx: int, fill: float | bool) -> np.ndarray:
    """``a[y + dy, x + dx]`` at every (y, x), ``fill`` beyond the canvas."""
    out = np.full_like(a, fill)
    hh, ww = a.shape[:2]
    out[max(-dy, 0):hh - max(dy, 0), max(-dx, 0):ww - max(dx, 0)] = \
        a[max(dy, 0):hh + min(dy, 0) or None, max(dx, 0):ww + min(dx, 0) or None]
    return out


class HardEdges:
    """Where a field ``s`` (per pigment: its amount; for the dried layers: their optical
    density) steps sharply between neighbouring cells, and which side of the step each
    cell is on.

    ``up[d]`` (bool (H, W)) marks a cell whose neighbour at ``_NEIGHBOURS[d]`` is across a
    hard step above it, ``down[d]`` one below it.  ``high`` is the side indicator: the
    cells within :data:`SIDE_REACH` of a step's high side at or above the mid-level of
    the step nearest to them (the lower at a tie; everything farther from a step is
    out).
    Its blurred, peak-normalised 1/2 level set (:func:`step_level`) becomes the step's
    sub-cell contour."""

    def __init__(self, up: list[np.ndarray], down: list[np.ndarray], s: np.ndarray):
        self.up, self.down = up, down
        tops = np.zeros(s.shape, bool)
        for m in down:
            tops |= m
        self.any = bool(tops.any())
        # the step's mid-level at its high side's cells (between it and the mean of its
        # lower neighbours), and at every cell the nearest such cell's: a cell is on the
        # high side of the step nearest to it when above that
        low_num = np.zeros_like(s)
        low_den = np.zeros_like(s)
        for d, (dy, dx) in enumerate(_NEIGHBOURS):
            low_num += np.where(down[d], _shifted(s, dy, dx, 0.0), F32(0))
            low_den += down[d]
        mid = np.where(tops, F32(0.5) * (s + low_num / np.maximum(low_den, F32(1))),
                       -np.inf).astype(F32)
        level = np.full(s.shape, np.inf, F32)
        low_mid = np.where(tops, mid, np.inf).astype(F32)
        for r in range(SIDE_REACH + 1):
            found = ndimage.minimum_filter(low_mid, size=2 * r + 1, mode="constant",
                                           cval=np.inf)
            level = np.where(np.isinf(level), found, level)
        # (the lower at a tie: a thin band between two steps, say a mountain's wash
        # between the sky and a nearer mountain, stays whole on the high side of the
        # lower step; the upper one keeps its bicubic there)
        self.high: np.ndarray = s >= level
        # across several levels, a cell's far side is its nearest level: the lower
        # half of its higher neighbours across steps, the upper half of its lower ones
        self.up_near = self._nearest(up, s, lower=True)
        self.down_near = self._nearest(down, s, lower=False)

    @staticmethod
    def _nearest(pairs: list[np.ndarray], s: np.ndarray, lower: bool) -> list[np.ndarray]:
        vals = [_shifted(s, dy, dx, 0.0) for dy, dx in _NEIGHBOURS]
        lo = np.min([np.where(m, v, np.inf) for m, v in zip(pairs, vals, strict=True)],
                    axis=0)
        hi = np.max([np.where(m, v, -np.inf) for m, v in zip(pairs, vals, strict=True)],
                    axis=0)
        cut = np.where(np.isfinite(lo), 0.5 * (np.where(np.isfinite(lo), lo, 0)
                                               + np.where(np.isfinite(hi), hi, 0)), 0)
        return [m & ((v <= cut) if lower else (v >= cut))
                for m, v in zip(pairs, vals, strict=True)]

    def modified(self) -> tuple[np.ndarray, np.ndarray]:
        """Where :meth:`sides` changes a field: the low-side cells across a step from a
        higher neighbour, the high-side cells across one from a lower neighbour."""
        ups = np.zeros(self.high.shape, bool)
        downs = np.zeros(self.high.shape, bool)
        for u, d in zip(self.up, self.down, strict=True):
            ups |= u
            downs |= d
        return ~self.high & ups, self.high & downs

    def sides(self, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``f``'s high-side and low-side fields: each ``f`` except across a hard step,
        where a low-side cell takes the mean of its higher neighbours across steps (of
        the nearer level: the high side extended over the step, as :func:`_extended`
        extends paint over blank paper) and a high-side cell the mean of its lower
        ones."""
        hi_num = np.zeros_like(f)
        hi_den = np.zeros_like(f)
        lo_num = np.zeros_like(f)
        lo_den = np.zeros_like(f)
        for d, (dy, dx) in enumerate(_NEIGHBOURS):
            g = _shifted(f, dy, dx, 0.0)
            hi_num += np.where(self.up_near[d], g, F32(0))
            hi_den += self.up_near[d]
            lo_num += np.where(self.down_near[d], g, F32(0))
            lo_den += self.down_near[d]
        hi = np.where(~self.high & (hi_den > 0), hi_num / np.maximum(hi_den, F32(1)), f)
        lo = np.where(self.high & (lo_den > 0), lo_num / np.maximum(lo_den, F32(1)), f)
        return hi.astype(F32), lo.astype(F32)


def _clamped(a: np.ndarray, dy: int, dx: int) -> np.ndarray:
    """``a[y + dy, x + dx]`` at every (y, x), the nearest cell's beyond the canvas."""
    hh, ww = a.shape[:2]
    ys = np.clip(np.arange(hh) + dy, 0, hh - 1)
    xs = np.clip(np.arange(ww) + dx, 0, ww - 1)
    out: np.ndarray = a[ys][:, xs]
    return out


def hard_pairs(s: np.ndarray, within: np.ndarray, least: float
               ) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Hard steps of ``s`` (H, W) between neighbouring cells of ``within``, the lower one
    with all its neighbours in ``within``: per neighbour direction (:data:`_NEIGHBOURS`),
    the cells whose neighbour is across a step above them, and those whose neighbour is
    across one below.  A step rises by at least
    ``least`` and either more than doubles (:data:`HARD_RATIO`: a wash's edge over
    another paint) or rises by :data:`HARD_SHARE` of its top in one cell while the
    cells beyond it on either side rise less than :data:`HARD_ISOLATION` of that (a
    glaze's edge over a wash of the same colour; a wet-in-wet blend or a rim rises over
    several cells, granulation's noise by less)."""
    up, down = [], []
    # the low side of a step is inside the paint (all its neighbours painted): the pale
    # cells along the paint's own edge are its coverage of the cell, which the paint's
    # contour draws, not a step (a contour there left them as a pale band)
    inner = ndimage.binary_erosion(within, np.ones((3, 3), bool), border_value=1)
    for dy, dx in _NEIGHBOURS:
        g = _shifted(s, dy, dx, 0.0)
        both = within & _shifted(within, dy, dx, False)
        before = _clamped(s, -dy, -dx)  # the cell before this one, along the direction
        after = _clamped(s, 2 * dy, 2 * dx)  # the one after the neighbour
        # (isolated only where both are inside too: beyond the paint nothing is known)
        known = both & _clamped(within, -dy, -dx) & _clamped(within, 2 * dy, 2 * dx)
        rise = g - s
        ramp = np.maximum(np.maximum(s - before, after - g), F32(0))
        up.append(both & inner & (rise > F32(least))
                  & ((s < F32(HARD_RATIO) * g)
                     | (known & (rise > F32(HARD_SHARE) * g)
                        & (rise * F32(HARD_ISOLATION) > ramp))))
        fall = s - g
        ramp_d = np.maximum(np.maximum(g - after, before - s), F32(0))
        down.append(both & _shifted(inner, dy, dx, False) & (fall > F32(least))
                    & ((g < F32(HARD_RATIO) * s)
                       | (known & (fall > F32(HARD_SHARE) * s)
                          & (fall * F32(HARD_ISOLATION) > ramp_d))))
    return up, down


def layer_absorption(p: list[np.ndarray], q: list[np.ndarray], pigments: list[Pigment],
                     bands: int) -> np.ndarray:
    """The surface layer's absorption per cell (float32 (H, W)): each pigment's amount
    ``p + q`` times its mean Kubelka-Munk absorption over the bands (a weak yellow's step
    weighs less than an ink's)."""
    out = np.zeros(p[0].shape if p else (0, 0), F32)
    if not pigments:
        return out
    kk, _ = km_coefficients(pigments, bands)
    for i in range(len(pigments)):
        out += F32(kk[i].mean()) * (p[i] + q[i])
    return out


def pigment_edges(a: np.ndarray, within: np.ndarray) -> HardEdges:
    """Hard steps (:func:`hard_pairs`) of the surface layer's absorption ``a`` (H, W;
    :func:`layer_absorption`) between two cells of ``within`` (the painted cells: the
    edge of the paint on blank paper has its own contour), by at least
    :data:`HARD_MIN_AMOUNT`."""
    up, down = hard_pairs(a, within, HARD_MIN_AMOUNT)
    return HardEdges(up, down, a)


def density_edges(s: np.ndarray, within: np.ndarray) -> HardEdges:
    """Hard steps (:func:`hard_pairs`) of the dried layers' optical density ``s`` (H, W)
    between two cells of ``within`` (the dried cells), by at least
    :data:`HARD_MIN_DENSITY`."""
    up, down = hard_pairs(s, within, HARD_MIN_DENSITY)
    return HardEdges(up, down, s)


#: The step contour's smoothing: the side indicator is averaged along the edge (over a
#: Gaussian of ``STEP_ALONG`` cells, sampled every ``_STEP_SPACING`` cells each way to
#: ``_STEP_TAPS``) and across it only by ``STEP_ACROSS`` cells, so a staircase with long
#: treads straightens while a one-cell line keeps its width.
STEP_ALONG = 2.4
STEP_ACROSS = 0.6
#: The scale (cells) over which the edge's direction is estimated (structure tensor).
STEP_ORIENT = 1.5
_STEP_TAPS = 4
_STEP_SPACING = 0.8


def step_level(high: np.ndarray) -> np.ndarray:
    """The level function (float32 (H, W), about [0, 1]) whose 1/2 level set is the
    contour of a hard step's high side ``high`` (bool (H, W)): the indicator averaged
    along the edge's direction (the structure tensor of its blurred self) and barely
    across, divided by its 3x3 local peak (a one-cell line keeps its 1/2 level)."""
    ind = high.astype(F32)
    b = ndimage.gaussian_filter(ind, 1.0, mode="nearest")
    gy, gx = np.gradient(b)
    jxx = ndimage.gaussian_filter(gx * gx, STEP_ORIENT, mode="nearest")
    jxy = ndimage.gaussian_filter(gx * gy, STEP_ORIENT, mode="nearest")
    jyy = ndimage.gaussian_filter(gy * gy, STEP_ORIENT, mode="nearest")
    normal = 0.5 * np.arctan2(2 * jxy, jxx - jyy)  # the edge's normal, (x, y) angle
    ty, tx = np.cos(normal), -np.sin(normal)  # along the edge
    src = ndimage.gaussian_filter(ind, STEP_ACROSS, mode="nearest")
    yy, xx = np.mgrid[0:ind.shape[0], 0:ind.shape[1]].astype(F32)
    acc = np.zeros_like(ind)
    wsum = 0.0
    for j in range(-_STEP_TAPS, _STEP_TAPS + 1):
        d = j * _STEP_SPACING
        w = float(np.exp(-0.5 * (d / STEP_ALONG) ** 2))
        acc += F32(w) * ndimage.map_coordinates(src, [yy + d * ty, xx + d * tx], order=1,
                                                mode="nearest").astype(F32)
        wsum += w
    lvl = acc / F32(wsum)
    peak = ndimage.maximum_filter(lvl, size=3, mode="nearest")
    out: np.ndarray = np.where(peak > 0, lvl / np.maximum(peak, F32(1e-6)), F32(0)
                               ).astype(F32)
    return out


def step_coverage(high: np.ndarray, k: int) -> np.ndarray:
    """Sub-cell coverage (float32 (kH, kW) in [0, 1]) of a hard step's high side: the
    1/2 level set of :func:`step_level`, bicubic, anti-aliased over one output pixel."""
    up = _resample_signed(step_level(high), k)
    gy, gx = np.gradient(up)
    slope = np.maximum(np.hypot(gx, gy), F32(1e-6))
    out: np.ndarray = np.clip((up - F32(0.5)) / slope + F32(0.5), 0.0, 1.0).astype(F32)
    return out


def _sharpened(f: np.ndarray, edges: HardEdges, cover: np.ndarray | None, k: int,
               signed: bool = False) -> np.ndarray:
    """``f`` resampled to ``k`` pixels per cell, its hard steps drawn as the sub-cell
    contour ``cover`` (blend of the resampled high and low sides); elsewhere exactly the
    plain bicubic resampling."""
    res = _resample_signed if signed else _resample
    if cover is None:
        return res(f, k)
    hi, lo = edges.sides(f)
    lo_up = res(lo, k)
    out: np.ndarray = (lo_up + cover * (res(hi, k) - lo_up)).astype(F32)
    return out


def scaled_layers(state: CanvasState, k: int) -> tuple[np.ndarray, np.ndarray]:
    """What :func:`render_scaled` composes at ``k`` (2..MAX_SCALE) pixels per cell: the
    surface layer's pigment amounts (float32 (N, kH, kW), ``p + q`` per slot pigment, in
    the state's units) and the dried layers' reflectance below (float32 (kH, kW, B))."""
    hp = paper_detail(state, k)
    shade = F32(state.params.paper_shade)
    # the dried layers below: blank paper plus their difference from it, inside their own
    # smooth contour; a hard step inside them (a dried glaze's edge over an earlier wash)
    # gets its own contour
    paper = state.paper_reflectance()
    diff = state.r_composed - paper[..., None]
    dried = np.abs(diff).max(axis=-1) > F32(1e-4)
    dcover = edge_coverage(dried, k)
    base = _resample(paper, k)
    density = -np.log(np.maximum(state.r_composed, F32(1e-4))
                      / np.maximum(paper, F32(1e-4))[..., None]).mean(axis=-1)
    dedges = density_edges(density.astype(F32), dried)
    dstep = step_coverage(dedges.high, k) if dedges.any else None
    r_prev = np.stack([base + dcover * _sharpened(_extended(diff[..., c], dried), dedges,
                                                  dstep, k, signed=True)
                       for c in range(diff.shape[-1])], axis=-1)
    r_prev = np.clip(r_prev * (F32(1.0) + shade * hp)[..., None], 0.0, 1.0).astype(F32)
    pigments = state.slot_pigments()
    n = len(pigments)
    painted = (state.p[:n] + state.q[:n]).sum(axis=0) > F32(1e-6)
    cover = edge_coverage(painted, k)
    # hard steps inside the paint (a wet-on-dry edge over another colour, a glaze's
    # edge): one sub-cell contour for all the layer's pigments, where its absorption
    # steps (a contour per pigment would part a mixed stroke's pigments at its edge)
    ext_p = [_extended(state.p[i], painted) for i in range(n)]
    ext_q = [_extended(state.q[i], painted) for i in range(n)]
    edges = pigment_edges(layer_absorption(ext_p, ext_q, pigments, diff.shape[-1]),
                          painted)
    step = step_coverage(edges.high, k) if edges.any else None
    amounts = []
    for i, pig in enumerate(pigments):
        p = _sharpened(ext_p[i], edges, step, k) * cover
        q = _sharpened(ext_q[i], edges, step, k) * cover
        if pig.gamma > 0:
            g = np.maximum(F32(1.0) - F32(pig.gamma) * hp, F32(0.0))
            gq = q * g
            cell_q = np.repeat(np.repeat(_cell_mean(q, k), k, 0), k, 1)
            cell_gq = np.repeat(np.repeat(_cell_mean(gq, k), k, 0), k, 1)
            q = np.where(cell_gq > 0, gq * (cell_q / np.where(cell_gq > 0, cell_gq, 1)), q)
        amounts.append(p + q)
    amount = (np.stack(amounts) if amounts
              else np.zeros((0, state.height * k, state.width * k), F32)).astype(F32)
    return amount, r_prev


def render_scaled(state: CanvasState, renderer: str, k: int) -> np.ndarray:
    """Linear reflectance at ``k`` pixels per cell, float32 (kH, kW, 3) in [0, 1]."""
    if not isinstance(k, int) or not 1 <= k <= MAX_SCALE:
        raise CanvasInputError(f"render scale {k!r} must be an integer 1..{MAX_SCALE}",
                               "--scale")
    if k == 1:
        return render_cells(state, renderer)
    amount, r_prev = scaled_layers(state, k)
    pigments = state.slot_pigments()
    if renderer == "gouache":
        return to_linear_rgb(gouache_layer(amount, pigments, r_prev,
                                           state.params.gouache_opaque,
                                           state.params.gouache_white, gouache_white_ks(state)))
    return to_linear_rgb(km_layer(amount, pigments, r_prev))
