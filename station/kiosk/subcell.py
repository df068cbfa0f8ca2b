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

Blocks and staircases are gone in every view; the brush view's magnification
shows the paper's grain and the paint's edge, not cells.
"""

from __future__ import annotations

from functools import cache

import numba
import numpy as np
from scipy import ndimage

from station.canvas.paper import make_paper

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

#: Extra relief shading of fully absorbing paint (granulation below the cell).
GRANULATION = 0.5

#: The sub-cell grain's shading relative to the profile's ``paper_shade`` (the headless
#: renderer's 1×: there the grain's standard deviation is about 1/255 of the paper,
#: invisible at the kiosk's distance; 4× reads as paper in the brush view and stays
#: quiet in the top view).
GRAIN_GAIN = 4.0
