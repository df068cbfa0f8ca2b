"""The canvas at the screen's resolution: sub-cell contours and paper grain on the GPU.

The headless renderer draws a canvas at ``k`` pixels per cell
(:mod:`station.render.upscale`): the paint's colour resampled bicubically, the
edge of the paint as the 1/2 level set of the blurred, peak-normalised
painted-cell indicator (anti-aliased over one output pixel), paint extended
into the blank cells that contour reaches, and the paper's sub-cell grain (a
finer Worley texture of the same preset, high-passed so it keeps the cells'
means).  The kiosk draws the same at whatever resolution the screen has, in
the window's fragment shader:

* per cell, on the CPU, where the display re-renders anyway (dirty tiles, the
  preview): the linear reflectance, *extended* into blank cells that touch paint
  (the mean of their painted 3×3 neighbours, as ``upscale._extended``), and the
  contour level (``upscale.edge_coverage``'s blurred, peak-normalised indicator)
  in the texture's alpha.  A cell's level depends on the indicator
  :data:`LEVEL_REACH` cells around it, so a changed region is re-uploaded grown
  by that much (:func:`grow`);
* per screen pixel, in the shader: Catmull–Rom bicubic of that texture (five
  bilinear fetches), the level's 1/2 contour anti-aliased over one pixel
  (``fwidth``), blank paper from the cells' paper reflectance, and the paper's
  sub-cell grain (:func:`grain_patch`, :data:`GRAIN_K` texels per cell) shading
  paper and paint alike, faded out where a pixel covers a cell or more (the far
  side of the table) so it cannot alias.

Edges inside the paint (one paint over another, a dried glaze's edge) get the same:
where the cells' optical density steps hard between painted neighbours
(:func:`step_fields`, the headless renderer's :func:`upscale.density_edges` on the
cells' colour; its side indicator's contour is the isotropic blur of the paint's edge,
not the headless renderer's blur along the edge, whose reach a region's update could
not afford), the canvas texture holds the step's high side's colour on both sides
of it, a second texture (``steps``) the low side's colour and the 1/2 contour level of
the step's high side, and the shader mixes the two colours across that contour.  Away
from a step both textures hold the same colour (the shader's mix changes nothing).

Blocks and staircases are gone in every view; the brush view's magnification
shows the paper's grain and the paint's edge, not cells.
"""

from __future__ import annotations

from functools import cache

import numba
import numpy as np
from scipy import ndimage

from station.canvas.paper import make_paper
from station.render import upscale

F32 = np.float32

#: The painted-cell indicator's blur (cells; ``upscale.EDGE_SIGMA``), cut at two cells.
EDGE_SIGMA = 0.8
_TRUNCATE = 2.5  # gaussian_filter's radius: int(2.5 * 0.8 + 0.5) = 2 cells

#: Cells around a changed cell whose contour level may change (blur 2 + local peak 1).
LEVEL_REACH = 3

#: Cells beyond a region whose indicator its fields need (its level's reach), and whose
#: reflectance they need (the extension's 3×3).
INDICATOR_HALO = LEVEL_REACH
COLOUR_HALO = 1

#: Cells around a changed texel whose pixels change on screen (the Catmull-Rom's 4×4
#: support reaches two texels each way).
BICUBIC_REACH = 2

#: Grain texels per cell, and the grain patch's side in cells (repeated over the canvas:
#: a whole canvas at 4 texels per cell is seconds of Worley noise at every fresh canvas).
GRAIN_K = 4
GRAIN_CELLS = 128

#: Painted: more pigment than this in a cell, or dried layers this far from bare paper.
PAINTED_AMOUNT = 1e-6
DRIED_DIFF = 1e-4


def grow(ys: slice, xs: slice, by: int, height: int, width: int) -> tuple[slice, slice]:
    """``[ys, xs]`` grown by ``by`` cells, clipped to the canvas."""
    return (slice(max(ys.start - by, 0), min(ys.stop + by, height)),
            slice(max(xs.start - by, 0), min(xs.stop + by, width)))


def contour_level(painted: np.ndarray) -> np.ndarray:
    """The painted-cell indicator blurred and divided by its 3×3 peak (float32), whose
    1/2 level set is the paint's edge (``upscale.edge_coverage`` before resampling)."""
    lvl = ndimage.gaussian_filter(painted.astype(F32), EDGE_SIGMA, mode="constant",
                                  truncate=_TRUNCATE)
    peak = ndimage.maximum_filter(lvl, size=3, mode="constant")
    return np.where(peak > 0, lvl / np.maximum(peak, F32(1e-6)), F32(0)).astype(F32)


def extended(rgb: np.ndarray, painted: np.ndarray) -> np.ndarray:
    """``rgb`` (h, w, 3) on painted cells; on blank cells that touch paint the mean of
    their painted 3×3 neighbours (``upscale._extended``); bare paper elsewhere."""
    box = np.ones((3, 3), F32)
    den = ndimage.convolve(painted.astype(F32), box, mode="constant")
    out = rgb.astype(F32, copy=True)
    edge = (~painted) & (den > 0)
    if edge.any():
        for c in range(3):
            num = ndimage.convolve(np.where(painted, rgb[..., c], F32(0)).astype(F32), box,
                                   mode="constant")
            out[..., c] = np.where(edge, num / np.maximum(den, F32(1)), out[..., c])
    return out


def painted_cells(amount: np.ndarray, r_composed: np.ndarray, paper: np.ndarray
                  ) -> np.ndarray:
    """Cells holding paint: pigment in the surface layer (``amount``: per pigment, (n, h,
    w)), or dried layers whose reflectance ``r_composed`` (h, w, 3) is off the bare
    ``paper`` (h, w).  Compiled: the window asks it of a few small regions every frame,
    where numpy's reductions cost more in calls than in arithmetic."""
    out = np.empty(paper.shape, np.bool_)
    _painted_kernel(np.asarray(amount, F32).reshape(-1, *paper.shape),
                    np.asarray(r_composed, F32), np.asarray(paper, F32), F32(PAINTED_AMOUNT),
                    F32(DRIED_DIFF), out)
    return out


@numba.njit(cache=True, nogil=True)
def _painted_kernel(amount: np.ndarray, r_composed: np.ndarray, paper: np.ndarray,
                    wet_min: np.float32, dried_min: np.float32,
                    out: np.ndarray) -> None:  # pragma: no cover
    n = amount.shape[0]
    h, w = paper.shape
    for y in range(h):
        for x in range(w):
            acc = np.float32(0.0)
            for k in range(n):  # numpy's sum over the first axis, in the same order
                acc += amount[k, y, x]
            painted = 1 if acc > wet_min else 0
            if painted == 0:
                b = paper[y, x]
                for c in range(3):
                    if abs(r_composed[y, x, c] - b) > dried_min:
                        painted = 1
                        break
            out[y, x] = painted != 0


def fields_reference(rgb: np.ndarray, painted: np.ndarray, inner: tuple[slice, slice]
                     ) -> np.ndarray:
    """:func:`fields` with scipy (the definition; :func:`fields` is its compiled twin)."""
    lvl = contour_level(painted)[inner]
    ext = extended(rgb, painted)[inner]
    return np.concatenate([ext, lvl[..., None]], axis=-1).astype(F32)


def _gauss_weights() -> np.ndarray:
    x = np.arange(-2, 3, dtype=np.float64)
    w = np.exp(-0.5 * (x / EDGE_SIGMA) ** 2)
    return np.asarray((w / w.sum()).astype(F32))


#: The blur's five weights (each axis); the GL fields pass uses them too.
EDGE_WEIGHTS = _gauss_weights()
_W = EDGE_WEIGHTS


@numba.njit(cache=True, nogil=True)
def _fields_kernel(rgb: np.ndarray, painted: np.ndarray, y0: int, y1: int, x0: int,
                   x1: int, wts: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
    h, w = painted.shape
    # the blurred indicator where the peaks need it: inner grown by one (clipped)
    by0, by1 = max(y0 - 1, 0), min(y1 + 1, h)
    bx0, bx1 = max(x0 - 1, 0), min(x1 + 1, w)
    hy0, hy1 = max(by0 - 2, 0), min(by1 + 2, h)
    horiz = np.zeros((hy1 - hy0, bx1 - bx0), np.float32)
    for y in range(hy0, hy1):
        for x in range(bx0, bx1):
            acc = np.float32(0.0)
            for k in range(-2, 3):
                xx = x + k
                if 0 <= xx < w and painted[y, xx]:
                    acc += wts[k + 2]
            horiz[y - hy0, x - bx0] = acc
    blur = np.zeros((by1 - by0, bx1 - bx0), np.float32)
    for y in range(by0, by1):
        for x in range(bx0, bx1):
            acc = np.float32(0.0)
            for k in range(-2, 3):
                yy = y + k
                if 0 <= yy < h:
                    acc += wts[k + 2] * horiz[yy - hy0, x - bx0]
            blur[y - by0, x - bx0] = acc
    for y in range(y0, y1):
        for x in range(x0, x1):
            peak = np.float32(0.0)
            n = 0
            r = np.float32(0.0)
            g = np.float32(0.0)
            b = np.float32(0.0)
            for dy in range(-1, 2):
                yy = y + dy
                if yy < 0 or yy >= h:
                    continue
                for dx in range(-1, 2):
                    xx = x + dx
                    if xx < 0 or xx >= w:
                        continue
                    v = blur[yy - by0, xx - bx0]
                    if v > peak:
                        peak = v
                    if painted[yy, xx]:
                        n += 1
                        r += rgb[yy, xx, 0]
                        g += rgb[yy, xx, 1]
                        b += rgb[yy, xx, 2]
            o = out[y - y0, x - x0]
            if painted[y, x] or n == 0:
                o[0], o[1], o[2] = rgb[y, x, 0], rgb[y, x, 1], rgb[y, x, 2]
            else:
                o[0], o[1], o[2] = r / n, g / n, b / n
            o[3] = blur[y - by0, x - bx0] / max(peak, np.float32(1e-6)) if peak > 0 else 0.0


def fields(rgb: np.ndarray, painted: np.ndarray, inner: tuple[slice, slice]
           ) -> np.ndarray:
    """The texture's RGBA (h, w, 4) on ``inner`` (slices into the arrays given):
    extended colour and contour level.  ``rgb`` and ``painted`` cover ``inner`` grown by
    :data:`INDICATOR_HALO` where the canvas goes on (its edges are blank beyond).
    Compiled (a frame renders many small regions; scipy's filters cost more in calls
    than in arithmetic there); :func:`fields_reference` is the definition."""
    ys, xs = inner
    out = np.empty((ys.stop - ys.start, xs.stop - xs.start, 4), F32)
    _fields_kernel(np.ascontiguousarray(rgb, F32), np.ascontiguousarray(painted),
                   ys.start, ys.stop, xs.start, xs.stop, _W, out)
    return out


#: Hard steps inside the paint (one paint over another, a dried glaze's edge; the
#: headless renderer's :func:`upscale.density_edges` on the cells' rendered colour): a
#: painted cell whose optical density is below STEP_RATIO of a painted neighbour's, by at
#: least STEP_MIN_DENSITY; the side indicator reaches STEP_SIDE_REACH cells from a step.
STEP_RATIO = upscale.HARD_RATIO
STEP_MIN_DENSITY = upscale.HARD_MIN_DENSITY
STEP_SIDE_REACH = upscale.SIDE_REACH
_STEP_CONSTS = np.array([STEP_MIN_DENSITY, STEP_RATIO, upscale.HARD_SHARE,
                         upscale.HARD_ISOLATION], F32)

#: Cells around a changed cell whose step fields may change (a pair and the cells
#: beyond it 2, the side indicator's reach, its contour level's), and the cells of
#: colour and indicator a region's step fields need around it.
STEP_REACH = 2 + STEP_SIDE_REACH + LEVEL_REACH
STEP_HALO = STEP_REACH

#: What a display re-renders around a changed region (the larger of the paint's contour
#: level's and the steps' reach), and the cells of colour and indicator around that.
REACH = max(LEVEL_REACH, STEP_REACH)
HALO = max(INDICATOR_HALO, COLOUR_HALO, STEP_HALO)


def density(rgb: np.ndarray, paper: np.ndarray) -> np.ndarray:
    """Mean optical density of the cells' colour ``rgb`` (h, w, 3) over the bare
    ``paper`` (h, w): ``-ln`` of their mean reflectance over the paper's (float32)."""
    mean = rgb.astype(F32).mean(axis=-1)
    out: np.ndarray = -np.log(np.maximum(mean, F32(1e-4))
                              / np.maximum(paper.astype(F32), F32(1e-4)))
    return out.astype(F32)


def step_fields_reference(rgb: np.ndarray, paper: np.ndarray, painted: np.ndarray,
                          ext: np.ndarray, inner: tuple[slice, slice]
                          ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`step_fields` with numpy and scipy (the definition).  Of the cells' colour
    ``rgb`` (h, w, 3) over the bare ``paper`` (h, w), the ``painted`` cells, and the
    colour the canvas texture holds (``ext``, (h, w, 3): :func:`fields`' colour), on
    ``inner``: the high side's colour (``ext`` but on the low side of a hard step, where
    it is the mean of the higher neighbours) and the low side's colour with the step's
    contour level (RGBA: ``ext`` but on the high side of a step, where it is the mean of
    the lower neighbours; :func:`contour_level` of the side indicator)."""
    edges = upscale.density_edges(density(rgb, paper), painted)
    hi = ext.astype(F32, copy=True)
    lo = ext.astype(F32, copy=True)
    if edges.any:
        hi_mask, lo_mask = edges.modified()
        for c in range(3):
            h_c, l_c = edges.sides(rgb[..., c].astype(F32))
            hi[..., c] = np.where(hi_mask, h_c, hi[..., c])
            lo[..., c] = np.where(lo_mask, l_c, lo[..., c])
    lvl = contour_level(edges.high)
    return (hi[inner], np.concatenate([lo[inner], lvl[inner][..., None]], axis=-1
                                      ).astype(F32))


@numba.njit(cache=True, nogil=True, inline="always")
def _across(a: np.float32, g: np.float32, before: np.float32, after: np.float32,
            known: bool, least: np.float32, ratio: np.float32, share: np.float32,
            iso: np.float32) -> bool:  # pragma: no cover
    """``upscale.hard_pairs``: from ``a`` up to its neighbour ``g`` a hard step
    (``before`` the cell before ``a``, ``after`` the one after ``g``, along the way;
    ``known``: both painted)."""
    rise = g - a
    ramp = max(max(a - before, after - g), np.float32(0.0))
    return bool(rise > least and (a < ratio * g or (known and rise > share * g
                                                   and rise * iso > ramp)))


@numba.njit(cache=True, nogil=True, inline="always")
def _inside_paint(painted: np.ndarray, y: int, x: int) -> bool:  # pragma: no cover
    """(y, x) and its neighbours on the canvas all painted (``upscale.hard_pairs``' low
    side of a step)."""
    h, w = painted.shape
    for yy in range(max(y - 1, 0), min(y + 2, h)):
        for xx in range(max(x - 1, 0), min(x + 2, w)):
            if not painted[yy, xx]:
                return False
    return True


@numba.njit(cache=True, nogil=True)
def _steps_kernel(rgb: np.ndarray, paper: np.ndarray, painted: np.ndarray, y0: int,
                  y1: int, x0: int, x1: int, consts: np.ndarray, reach: int,
                  wts: np.ndarray, hi: np.ndarray, lo: np.ndarray) -> None:  # pragma: no cover
    least, ratio, share, iso = consts[0], consts[1], consts[2], consts[3]
    h, w = paper.shape
    s = np.empty((h, w), np.float32)
    for y in range(h):
        for x in range(w):
            m = (rgb[y, x, 0] + rgb[y, x, 1] + rgb[y, x, 2]) / np.float32(3.0)
            s[y, x] = -np.log(max(m, np.float32(1e-4)) / max(paper[y, x], np.float32(1e-4)))
    # the cells on a step's high side, and the step's mid-level there (where the side
    # indicator of the inner cells grown by the level's reach can see them)
    mid = np.full((h, w), np.inf, np.float32)
    found = False
    for y in range(max(y0 - 3 - reach, 0), min(y1 + 3 + reach, h)):
        for x in range(max(x0 - 3 - reach, 0), min(x1 + 3 + reach, w)):
            if not painted[y, x]:
                continue
            n = 0
            acc = np.float32(0.0)
            for dy in range(-1, 2):
                for dx in range(-1, 2):
                    yy, xx = y + dy, x + dx
                    if (dy == 0 and dx == 0) or yy < 0 or yy >= h or xx < 0 or xx >= w:
                        continue
                    if not painted[yy, xx]:
                        continue
                    by, bx = min(max(y - dy, 0), h - 1), min(max(x - dx, 0), w - 1)
                    ay, ax = min(max(y + 2 * dy, 0), h - 1), min(max(x + 2 * dx, 0), w - 1)
                    known = painted[by, bx] and painted[ay, ax]
                    # down from (y, x) to (yy, xx): up from the neighbour, seen from it
                    if _inside_paint(painted, yy, xx) and _across(
                            s[yy, xx], s[y, x], s[ay, ax], s[by, bx], known, least, ratio,
                            share, iso):
                        n += 1
                        acc += s[yy, xx]
            if n > 0:
                mid[y, x] = np.float32(0.5) * (s[y, x] + acc / n)
                found = True
    if not found:  # no step near: both sides the paint's colour, level 0
        for y in range(y0, y1):
            for x in range(x0, x1):
                lo[y - y0, x - x0, 3] = 0.0
        return
    # the side indicator on the inner cells grown by the level's reach (3): above the
    # nearest step's mid-level (the lower at a tie)
    gy0, gy1 = max(y0 - 3, 0), min(y1 + 3, h)
    gx0, gx1 = max(x0 - 3, 0), min(x1 + 3, w)
    high = np.zeros((h, w), np.float32)
    for y in range(gy0, gy1):
        for x in range(gx0, gx1):
            level = np.float32(np.inf)
            for r in range(reach + 1):
                for yy in range(max(y - r, 0), min(y + r + 1, h)):
                    for xx in range(max(x - r, 0), min(x + r + 1, w)):
                        level = min(level, mid[yy, xx])
                if level < np.inf:
                    break
            if s[y, x] >= level:
                high[y, x] = 1.0
    # its blur (5 taps each way, zero outside) on the inner cells grown by one
    by0, by1 = max(y0 - 1, 0), min(y1 + 1, h)
    bx0, bx1 = max(x0 - 1, 0), min(x1 + 1, w)
    horiz = np.zeros((h, w), np.float32)
    for y in range(max(by0 - 2, 0), min(by1 + 2, h)):
        for x in range(bx0, bx1):
            acc = np.float32(0.0)
            for k in range(-2, 3):
                xx = x + k
                if 0 <= xx < w:
                    acc += wts[k + 2] * high[y, xx]
            horiz[y, x] = acc
    blur = np.zeros((h, w), np.float32)
    for y in range(by0, by1):
        for x in range(bx0, bx1):
            acc = np.float32(0.0)
            for k in range(-2, 3):
                yy = y + k
                if 0 <= yy < h:
                    acc += wts[k + 2] * horiz[yy, x]
            blur[y, x] = acc
    vals = np.empty(8, np.float32)
    cols = np.empty((8, 3), np.float32)
    for y in range(y0, y1):
        for x in range(x0, x1):
            peak = np.float32(0.0)
            for yy in range(max(y - 1, 0), min(y + 2, h)):
                for xx in range(max(x - 1, 0), min(x + 2, w)):
                    peak = max(peak, blur[yy, xx])
            lo[y - y0, x - x0, 3] = blur[y, x] / max(peak, np.float32(1e-6)) \
                if peak > 0 else np.float32(0.0)
            if not painted[y, x]:
                continue
            is_high = high[y, x] > 0.5
            a = s[y, x]
            n = 0
            for dy in range(-1, 2):
                for dx in range(-1, 2):
                    yy, xx = y + dy, x + dx
                    if (dy == 0 and dx == 0) or yy < 0 or yy >= h or xx < 0 or xx >= w:
                        continue
                    if not painted[yy, xx]:
                        continue
                    g = s[yy, xx]
                    by, bx = min(max(y - dy, 0), h - 1), min(max(x - dx, 0), w - 1)
                    ay, ax = min(max(y + 2 * dy, 0), h - 1), min(max(x + 2 * dx, 0), w - 1)
                    known = painted[by, bx] and painted[ay, ax]
                    before, after = s[by, bx], s[ay, ax]
                    if is_high:
                        ok = _inside_paint(painted, yy, xx) and _across(
                            g, a, after, before, known, least, ratio, share, iso)
                    else:
                        ok = _inside_paint(painted, y, x) and _across(
                            a, g, before, after, known, least, ratio, share, iso)
                    if ok:
                        vals[n] = g
                        cols[n, 0], cols[n, 1], cols[n, 2] = \
                            rgb[yy, xx, 0], rgb[yy, xx, 1], rgb[yy, xx, 2]
                        n += 1
            if n == 0:
                continue
            # the nearest level across: the lower half of the higher neighbours, the
            # upper half of the lower ones
            vmin, vmax = vals[0], vals[0]
            for i in range(1, n):
                vmin, vmax = min(vmin, vals[i]), max(vmax, vals[i])
            cut = np.float32(0.5) * (vmin + vmax)
            m = 0
            acc0 = np.float32(0.0)
            acc1 = np.float32(0.0)
            acc2 = np.float32(0.0)
            for i in range(n):
                if (vals[i] >= cut) if is_high else (vals[i] <= cut):
                    m += 1
                    acc0 += cols[i, 0]
                    acc1 += cols[i, 1]
                    acc2 += cols[i, 2]
            o = lo[y - y0, x - x0] if is_high else hi[y - y0, x - x0]
            o[0], o[1], o[2] = acc0 / m, acc1 / m, acc2 / m


def step_fields(rgb: np.ndarray, paper: np.ndarray, painted: np.ndarray,
                ext: np.ndarray, inner: tuple[slice, slice]
                ) -> tuple[np.ndarray, np.ndarray]:
    """The high side's colour (h, w, 3) and the low side's colour with the hard steps'
    contour level (h, w, 4) on ``inner`` (:func:`step_fields_reference`, its definition;
    compiled).  ``rgb``, ``paper`` and ``painted`` cover ``inner`` grown by
    :data:`STEP_HALO` where the canvas goes on; ``ext`` (the colour :func:`fields` gave,
    (h, w, 3)) covers ``inner`` only."""
    ys, xs = inner
    hi = np.ascontiguousarray(ext, F32).copy()
    lo = np.empty((hi.shape[0], hi.shape[1], 4), F32)
    lo[..., :3] = hi
    _steps_kernel(np.ascontiguousarray(rgb, F32), np.ascontiguousarray(paper, F32),
                  np.ascontiguousarray(painted), ys.start, ys.stop, xs.start, xs.stop,
                  _STEP_CONSTS, STEP_SIDE_REACH, _W, hi, lo)
    return hi, lo


@cache
def grain_patch(preset: str, seed: int) -> np.ndarray:
    """Sub-cell paper height detail of ``preset`` (float32 (GRAIN_CELLS·GRAIN_K)², zero
    mean per cell, about [-1, 1]; ``upscale.paper_detail`` on a patch), made once per
    process."""
    k, n = GRAIN_K, GRAIN_CELLS
    fine = make_paper(preset, n * k, n * k, seed + 7919)
    cell = fine.reshape(n, k, n, k).mean(axis=(1, 3))
    return np.asarray((fine - np.repeat(np.repeat(cell, k, 0), k, 1)).astype(F32))


CANVAS_VERT = """
#version 330
uniform mat4 vp;
in vec3 pos;
in vec2 uv;
out vec2 f_uv;
void main() { f_uv = uv; gl_Position = vp * vec4(pos, 1.0); }
"""

CANVAS_FRAG = """
#version 330
uniform sampler2D canvas;   // rgb: linear reflectance (extended), a: contour level
uniform sampler2D paper;    // r: bare paper reflectance per cell
uniform sampler2D grain;    // r: sub-cell paper detail, GRAIN_K texels per cell, repeated
uniform vec2 cells;         // the canvas in cells (width, height)
uniform float grain_k;      // grain texels per cell
uniform float grain_texels; // the grain patch's side in texels
uniform float shade;        // paper_shade: how much the paper's relief shades it
uniform float granulation;  // extra relief shading of paint (deposits in the valleys)
uniform bool contours;      // the alpha holds a contour level (CPU displays)
uniform sampler2D steps;    // rgb: the low side's colour of hard steps inside the paint
                            // (canvas's rgb: the high side's), a: their contour level
uniform bool step_contours; // steps holds them (else it is not read)
in vec2 f_uv;
out vec4 frag;

vec3 srgb(vec3 x) {  // the sRGB transfer function (render.linear_to_srgb)
    x = clamp(x, 0.0, 1.0);
    return mix(12.92 * x, 1.055 * pow(x, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, x));
}

// Catmull-Rom bicubic from five bilinear fetches (the weights of each pair of
// neighbouring texels folded into one fetch between them; the four corner fetches,
// whose weights are tiny, left out and the rest renormalised): a texture fetch is
// the dearest part of a pixel on a software rasteriser.  c in texels.
vec4 bicubic(sampler2D t, vec2 c, vec2 size) {
    vec2 p = c - 0.5;
    vec2 i = floor(p);
    vec2 f = p - i;
    vec2 w0 = f * (-0.5 + f * (1.0 - 0.5 * f));
    vec2 w1 = 1.0 + f * f * (-2.5 + 1.5 * f);
    vec2 w2 = f * (0.5 + f * (2.0 - 1.5 * f));
    vec2 w3 = f * f * (-0.5 + 0.5 * f);
    vec2 w12 = w1 + w2;
    vec2 o12 = w2 / w12;
    vec2 t0 = (i - 0.5) / size;
    vec2 t3 = (i + 2.5) / size;
    vec2 t12 = (i + 0.5 + o12) / size;
    vec4 r = texture(t, vec2(t12.x, t0.y)) * (w12.x * w0.y)
           + texture(t, vec2(t0.x, t12.y)) * (w0.x * w12.y)
           + texture(t, t12) * (w12.x * w12.y)
           + texture(t, vec2(t3.x, t12.y)) * (w3.x * w12.y)
           + texture(t, vec2(t12.x, t3.y)) * (w12.x * w3.y);
    float norm = w12.x * w0.y + w0.x * w12.y + w12.x * w12.y + w3.x * w12.y + w12.x * w3.y;
    return r / norm;
}

void main() {
    vec2 c = f_uv * cells;
    vec4 s = bicubic(canvas, c, cells);
    // a pixel's footprint in cells: the grain fades out from half a cell to a cell
    vec2 dx = dFdx(c), dy = dFdy(c);
    float foot = max(length(dx), length(dy));
    float fade = clamp(2.0 - 2.0 * foot, 0.0, 1.0);
    float hp = texture(grain, c * grain_k / grain_texels).r * fade;
    float bare = texture(paper, f_uv).r;
    vec3 paint = clamp(s.rgb, 0.0, 1.0);
    if (step_contours) {
        // an edge inside the paint (one paint over another): the 1/2 contour of its
        // high side's level between the two sides' colours, anti-aliased over a pixel
        vec4 t = bicubic(steps, c, cells);
        float sw = max(fwidth(t.a), 1e-4);
        float sc = clamp((t.a - 0.5) / sw + 0.5, 0.0, 1.0);
        paint = clamp(mix(t.rgb, s.rgb, sc), 0.0, 1.0);
    }
    float cover = 1.0;
    if (contours) {
        float w = max(fwidth(s.a), 1e-4);
        cover = clamp((s.a - 0.5) / w + 0.5, 0.0, 1.0);
    }
    // deposits favour the valleys: the more the paint absorbs, the more relief it shows
    float absorbed = clamp(1.0 - dot(paint, vec3(1.0 / 3.0)) / max(bare, 1e-3), 0.0, 1.0);
    vec3 wet = paint * (1.0 + (shade + granulation * absorbed) * hp);
    vec3 dry = vec3(bare * (1.0 + shade * hp));
    frag = vec4(srgb(mix(dry, wet, cover)), 1.0);
}
"""

def _bilinear(t: np.ndarray, cx: np.ndarray, cy: np.ndarray) -> np.ndarray:
    """A LINEAR, clamp-to-edge texture fetch of ``t`` (h, w, ch) at texel coordinates
    (``cx``, ``cy``; texel centres at i + 0.5)."""
    h, w = t.shape[:2]
    px, py = cx - 0.5, cy - 0.5
    x0, y0 = np.floor(px), np.floor(py)
    fx, fy = (px - x0)[..., None], (py - y0)[..., None]
    xa, xb = np.clip(x0, 0, w - 1).astype(int), np.clip(x0 + 1, 0, w - 1).astype(int)
    ya, yb = np.clip(y0, 0, h - 1).astype(int), np.clip(y0 + 1, 0, h - 1).astype(int)
    out: np.ndarray = ((t[ya, xa] * (1 - fx) + t[ya, xb] * fx) * (1 - fy)
                       + (t[yb, xa] * (1 - fx) + t[yb, xb] * fx) * fy)
    return out


def _bicubic(t: np.ndarray, cx: np.ndarray, cy: np.ndarray) -> np.ndarray:
    """The shader's ``bicubic``: Catmull-Rom from five bilinear fetches."""
    px, py = cx - 0.5, cy - 0.5
    ix, iy = np.floor(px), np.floor(py)
    w = []
    for f in (px - ix, py - iy):
        w0 = f * (-0.5 + f * (1.0 - 0.5 * f))
        w1 = 1.0 + f * f * (-2.5 + 1.5 * f)
        w2 = f * (0.5 + f * (2.0 - 1.5 * f))
        w3 = f * f * (-0.5 + 0.5 * f)
        w.append((w0, w1 + w2, w2 / (w1 + w2), w3))
    (x0, x12, ox, x3), (y0, y12, oy, y3) = w
    # texel coordinates of the fetches (the shader's (i - 0.5) / size etc. times size)
    tx0, tx3, tx12 = ix - 0.5, ix + 2.5, ix + 0.5 + ox
    ty0, ty3, ty12 = iy - 0.5, iy + 2.5, iy + 0.5 + oy
    parts = [(tx12, ty0, x12 * y0), (tx0, ty12, x0 * y12), (tx12, ty12, x12 * y12),
             (tx3, ty12, x3 * y12), (tx12, ty3, x12 * y3)]
    acc = np.zeros((*cx.shape, t.shape[-1]))
    norm = np.zeros(cx.shape)
    for a, b, wt in parts:
        acc += _bilinear(t, a, b) * wt[..., None]
        norm += wt
    out: np.ndarray = acc / norm[..., None]
    return out


def _fwidth(v: np.ndarray) -> np.ndarray:
    """GLSL's ``fwidth`` with coarse derivatives: per 2x2 quad of pixels (rows counted
    from the framebuffer's bottom), the first row's and the first column's difference."""
    q = v[::-1]  # framebuffer rows
    dx = np.repeat(np.repeat(q[0::2, 1::2] - q[0::2, 0::2], 2, 0), 2, 1)
    dy = np.repeat(np.repeat(q[1::2, 0::2] - q[0::2, 0::2], 2, 0), 2, 1)
    out: np.ndarray = (np.abs(dx) + np.abs(dy))[::-1]
    return out


def draw_reference(canvas: np.ndarray, steps: np.ndarray | None, paper: np.ndarray,
                   k: int) -> np.ndarray:
    """The window's canvas shader (:data:`CANVAS_FRAG`, contours on; the paper's grain
    and granulation, which only shade, left out) in numpy at ``k`` pixels a cell, top
    row first: sRGB8 (kH, kW, 3) of the ``canvas`` texture (h, w, 4), the ``steps``
    texture (h, w, 4; None: none) and the bare ``paper`` (h, w).  The definition the
    shader's contours are held to (its fetches, contours and mixes)."""
    h, w = paper.shape
    cy, cx = np.mgrid[0:h * k, 0:w * k].astype(np.float64)
    cx, cy = (cx + 0.5) / k, (cy + 0.5) / k
    s = _bicubic(canvas.astype(np.float64), cx, cy)
    paint = np.clip(s[..., :3], 0.0, 1.0)
    if steps is not None:
        t = _bicubic(steps.astype(np.float64), cx, cy)
        sw = np.maximum(_fwidth(t[..., 3]), 1e-4)
        sc = np.clip((t[..., 3] - 0.5) / sw + 0.5, 0.0, 1.0)[..., None]
        paint = np.clip(t[..., :3] * (1 - sc) + s[..., :3] * sc, 0.0, 1.0)
    cw = np.maximum(_fwidth(s[..., 3]), 1e-4)
    cover = np.clip((s[..., 3] - 0.5) / cw + 0.5, 0.0, 1.0)[..., None]
    bare = _bilinear(paper.astype(np.float64)[..., None], cx, cy)
    x = np.clip(bare * (1 - cover) + paint * cover, 0.0, 1.0)
    srgb = np.where(x > 0.0031308, 1.055 * x ** (1 / 2.4) - 0.055, 12.92 * x)
    out: np.ndarray = np.round(srgb * 255).astype(int)
    return out


#: Extra relief shading of fully absorbing paint (granulation below the cell).
GRANULATION = 0.5

#: The sub-cell grain's shading relative to the profile's ``paper_shade`` (the headless
#: renderer's 1×: there the grain's standard deviation is about 1/255 of the paper,
#: invisible at the kiosk's distance; 4× reads as paper in the brush view and stays
#: quiet in the top view).
GRAIN_GAIN = 4.0
