"""The footprint: the deformed tuft seen from below the canvas (§7.4.2).

Each bristle is a tube of radius ``r_b`` around its polyline.  Looking up
through the canvas with an orthographic camera, a cell sees the lowest point
of every tube above it: ``z_low = z(τ) - sqrt(r_b² - d²)`` where ``d`` is the
cell's distance to the bristle's axis and ``τ`` the closest point.  The back
clip plane sits ``ε`` above the canvas plane: nothing higher touches.

The rasteriser writes two maps over a window of cells:

* ``cover``: the anti-aliased coverage of the bristles (max over bristles);
* ``depth``: how far the lowest bristle reaches below the plane, ``-z_low``
  (max over bristles; ``-inf`` where none);
* ``tag`` (optional): a per-bristle value of the lowest bristle, the one that
  touches the paper there (the deformable brush passes each bristle's ink
  retention, so a drying tuft gives up its ink bristle by bristle and the
  stroke breaks into streaks that follow the bristles).

The weight the paint sees is computed per cell *where the stamp lands*, from
the paper's height: the plane is the top of the paper's tooth and a cell's
surface lies ``tooth · (1 - h)`` below it, so a bristle reaches it when
``depth ≥ tooth · (1 - h)`` (:func:`weight`).  A light touch with few bristles
only reaches the hills: dry-brush.  Pressing harder pushes more of the tuft
below the plane and fills the valleys.

:func:`rasterise` is the numba path for headless CPUs;
:mod:`station.brush.footprint_gl` draws the same tubes, and the same tags,
with OpenGL and the tests hold the two together
(``tests/test_brush_footprint_gl.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from scipy import ndimage

NO_DEPTH = -1.0e6
CLIP_ABOVE = 0.05
"""ε: the back clip plane's height above the canvas plane, cells."""
LONE_MIN = 8
"""A mark of at least this many cells loses its lone dots (:func:`prune_spurs`); a
smaller one (a tiny brush's tip) is all the stroke there is."""


@dataclass(frozen=True, slots=True)
class FootprintMaps:
    """Cover and depth over a window whose cell (0, 0) is canvas cell (y0, x0)."""

    y0: int
    x0: int
    cover: np.ndarray  # float32 (h, w)
    depth: np.ndarray  # float32 (h, w), cells below the plane
    tag: np.ndarray | None = None  # float32 (h, w), the lowest bristle's tag (NaN: none)

    @property
    def area(self) -> float:
        return float(self.cover.sum(dtype=np.float64))


def segments(points: np.ndarray) -> np.ndarray:
    """Bristle polylines (B, S, 3) → segments (B·(S-1), 2, 3)."""
    a = points[:, :-1, :]
    b = points[:, 1:, :]
    return np.ascontiguousarray(np.stack([a, b], axis=2).reshape(-1, 2, 3))


def window(segs: np.ndarray, radius: float) -> tuple[int, int, int, int]:
    """Cells ``(y0, x0, h, w)`` that can be touched (segments in cell units)."""
    low = segs[:, :, 2].min(axis=1) <= CLIP_ABOVE + radius
    if not low.any():
        return 0, 0, 0, 0
    pts = segs[low].reshape(-1, 3)
    x0 = int(math.floor(pts[:, 0].min() - radius - 1.0))
    y0 = int(math.floor(pts[:, 1].min() - radius - 1.0))
    x1 = int(math.ceil(pts[:, 0].max() + radius + 1.0))
    y1 = int(math.ceil(pts[:, 1].max() + radius + 1.0))
    return y0, x0, y1 - y0, x1 - x0


@numba.njit(cache=True)
def _raster(segs: np.ndarray, radius: float, y0: int, x0: int, cover: np.ndarray,
            depth: np.ndarray, tags: np.ndarray, tag: np.ndarray
            ) -> None:  # pragma: no cover - compiled
    h, w = cover.shape
    r2 = radius * radius
    for k in range(segs.shape[0]):
        ax, ay, az = segs[k, 0, 0], segs[k, 0, 1], segs[k, 0, 2]
        bx, by, bz = segs[k, 1, 0], segs[k, 1, 1], segs[k, 1, 2]
        if min(az, bz) - radius > CLIP_ABOVE:
            continue
        ex, ey = bx - ax, by - ay
        ll = ex * ex + ey * ey
        lo_x = int(math.floor(min(ax, bx) - radius - 1.0)) - x0
        hi_x = int(math.ceil(max(ax, bx) + radius + 1.0)) - x0
        lo_y = int(math.floor(min(ay, by) - radius - 1.0)) - y0
        hi_y = int(math.ceil(max(ay, by) + radius + 1.0)) - y0
        for i in range(max(lo_y, 0), min(hi_y, h)):
            cy = y0 + i + 0.5
            for j in range(max(lo_x, 0), min(hi_x, w)):
                cx = x0 + j + 0.5
                tau = 0.0
                if ll > 1e-12:
                    tau = ((cx - ax) * ex + (cy - ay) * ey) / ll
                    tau = min(1.0, max(0.0, tau))
                px, py = ax + tau * ex - cx, ay + tau * ey - cy
                d2 = px * px + py * py
                d = math.sqrt(d2)
                c = min(1.0, max(0.0, radius - d + 0.5))
                if c <= 0.0:
                    continue
                zl = az + tau * (bz - az) - math.sqrt(max(r2 - d2, 0.0))
                if zl > CLIP_ABOVE:
                    continue
                if c > cover[i, j]:
                    cover[i, j] = c
                if -zl > depth[i, j]:
                    depth[i, j] = -zl
                    if tags.shape[0]:
                        tag[i, j] = tags[k]


def rasterise(segs: np.ndarray, radius: float,
              win: tuple[int, int, int, int] | None = None,
              tags: np.ndarray | None = None) -> FootprintMaps:
    """Cover and depth maps of tube segments (cells; see the module docstring); with
    ``tags`` (one value per segment) also the tag of the lowest segment per cell."""
    segs = np.ascontiguousarray(segs, np.float64)
    y0, x0, h, w = win if win is not None else window(segs, radius)
    cover = np.zeros((max(h, 0), max(w, 0)), np.float32)
    depth = np.full((max(h, 0), max(w, 0)), NO_DEPTH, np.float32)
    t_in = np.zeros(0, np.float64) if tags is None else np.ascontiguousarray(tags, np.float64)
    if t_in.shape[0] not in (0, segs.shape[0]):
        raise ValueError(f"{t_in.shape[0]} tags for {segs.shape[0]} segments")
    tag = np.full(cover.shape if tags is not None else (0, 0), np.nan, np.float32)
    if h > 0 and w > 0 and segs.shape[0]:
        _raster(segs, float(radius), y0, x0, cover, depth, t_in, tag)
    return FootprintMaps(y0, x0, cover, depth, tag if tags is not None else None)


def weight(maps: FootprintMaps, paper: np.ndarray, tooth: float, ramp: float,
           dy: int = 0, dx: int = 0, lift: float | np.ndarray = 0.0,
           bead: float | np.ndarray = 0.0, drag: tuple[float, float] | None = None,
           sink: float = 0.25, skim: int = 0) -> tuple[int, int, np.ndarray]:
    """Contact weight in [0, 1] of ``maps`` shifted by ``(dy, dx)`` cells on paper ``h``.

    ``weight = cover · clip((depth - tooth·(1-h)) / ramp + 1/2, 0, 1)``: full
    where the bristles reach half a ramp below the local paper surface, none
    where they stay half a ramp above it.  Returns ``(y0, x0, weight)``
    clipped to the canvas (an empty array when outside).  ``lift`` (cells)
    raises the bristles: a drying brush gives paint only where it presses
    deepest into the paper.  ``bead`` (cells): the ink a loaded tuft holds
    wets the tooth down to that depth below the plane where the tuft presses at
    least half as deep as its deepest, ``bead · depth / (½ depth_max)``
    shallower (the liquid is held under the pressed body of the tuft, not under
    a lone splayed hair that grazes the plane); the contact reaches the deeper
    of the bristles and the liquid
    (:class:`~station.brush.deformable.TuftModel`).  ``lift`` and ``bead`` may be
    maps of the footprint's window (per bristle: each holds its own ink).

    ``drag`` (a unit vector of the motion, x then y) with ``skim`` cells: a hair dragged
    over the tooth does not drop into every valley; leaving a hill it sinks ``sink``
    cells per cell travelled, so the surface its bristles reach is ``min over k ≤ skim
    of tooth·(1 - h(x - k·u)) + k·sink``: the contact trails behind each hill, along
    the stroke.  The ink under the tuft moves with it: its meniscus, pinned on a hill,
    is drawn out behind it the same way.
    """
    hh, ww = paper.shape
    y0, x0 = maps.y0 + dy, maps.x0 + dx
    h, w = maps.cover.shape
    ya, yb = max(y0, 0), min(y0 + h, hh)
    xa, xb = max(x0, 0), min(x0 + w, ww)
    if ya >= yb or xa >= xb:
        return 0, 0, np.zeros((0, 0), np.float32)
    win = (slice(ya - y0, yb - y0), slice(xa - x0, xb - x0))
    cov = maps.cover[win]
    dep = maps.depth[win]
    below = np.float32(tooth) * (np.float32(1.0) - paper[ya:yb, xa:xb])
    bead_w = bead[win].astype(np.float32) if isinstance(bead, np.ndarray) else np.float32(bead)
    lift_w = lift[win].astype(np.float32) if isinstance(lift, np.ndarray) else np.float32(lift)
    hairs = below
    if drag is not None and skim > 0:
        # the paper around the window, its edge rows and columns repeated past the
        # canvas's edge, so each shift back along the drag is a plain slice
        pa, pb = max(ya - skim, 0), min(yb + skim, hh)
        qa, qb = max(xa - skim, 0), min(xb + skim, ww)
        near = np.pad(paper[pa:pb, qa:qb], ((skim - (ya - pa), skim - (pb - yb)),
                                            (skim - (xa - qa), skim - (qb - xb))), mode="edge")
        for k in range(1, skim + 1):
            oy, ox = skim - int(round(k * drag[1])), skim - int(round(k * drag[0]))
            back = (np.float32(tooth) * (np.float32(1.0) - near[oy:oy + yb - ya, ox:ox + xb - xa])
                    + np.float32(k * sink))
            hairs = np.minimum(hairs, back)
    reach = (dep - lift_w - hairs) / np.float32(ramp)
    if np.any(bead_w > 0.0):
        deepest = float(maps.depth.max(initial=0.0))
        if deepest > 0.0:
            film = bead_w * np.clip(dep / np.float32(0.5 * deepest), 0.0, 1.0)
            reach = np.maximum(reach, (film - lift_w - hairs) / np.float32(ramp))
    reach = np.clip(reach + np.float32(0.5), 0.0, 1.0)
    return ya, xa, (cov * reach).astype(np.float32)


def shifted_union(maps: FootprintMaps, shifts: list[tuple[int, int]]) -> FootprintMaps:
    """``maps`` laid at each of ``shifts`` (whole cells ``(dy, dx)``), merged: per cell
    the fullest cover and the deepest reach, with that deepest bristle's tag. One frame of
    the tuft slid over those cells; :func:`weight` of the result meets each cell against
    its own paper once, instead of once per shift."""
    if len(shifts) == 1:
        dy, dx = shifts[0]
        return FootprintMaps(maps.y0 + dy, maps.x0 + dx, maps.cover, maps.depth, maps.tag)
    top = min(p[0] for p in shifts)
    left = min(p[1] for p in shifts)
    h, w = maps.cover.shape
    hh = h + max(p[0] for p in shifts) - top
    ww = w + max(p[1] for p in shifts) - left
    cover = np.zeros((hh, ww), np.float32)
    depth = np.full((hh, ww), NO_DEPTH, np.float32)
    tag = None if maps.tag is None else np.full((hh, ww), np.nan, np.float32)
    for dy, dx in shifts:
        win = (slice(dy - top, dy - top + h), slice(dx - left, dx - left + w))
        np.maximum(cover[win], maps.cover, out=cover[win])
        deeper = maps.depth > depth[win]
        depth[win] = np.where(deeper, maps.depth, depth[win])
        if tag is not None and maps.tag is not None:
            tag[win] = np.where(deeper, maps.tag, tag[win])
    return FootprintMaps(maps.y0 + top, maps.x0 + left, cover, depth, tag)


def union_max(parts: list[tuple[int, int, np.ndarray]]) -> tuple[int, int, np.ndarray]:
    """Weights ``(y0, x0, w)`` laid over one another, the largest per cell, over the
    window that holds them all (the empty ones dropped)."""
    parts = [p for p in parts if p[2].size]
    if len(parts) <= 1:
        return parts[0] if parts else (0, 0, np.zeros((0, 0), np.float32))
    ya = min(p[0] for p in parts)
    xa = min(p[1] for p in parts)
    yb = max(p[0] + p[2].shape[0] for p in parts)
    xb = max(p[1] + p[2].shape[1] for p in parts)
    out = np.zeros((yb - ya, xb - xa), np.float32)
    for py, px, w in parts:
        win = out[py - ya:py - ya + w.shape[0], px - xa:px - xa + w.shape[1]]
        np.maximum(win, w, out=win)
    return ya, xa, out


def toothed_rim(y0: int, x0: int, wt: np.ndarray, edge: np.ndarray, reach: float
                ) -> tuple[int, int, np.ndarray]:
    """``wt`` (a weight window at ``(y0, x0)``) with its rim moved cell by cell along the
    paper's tooth, as the round brush's footprint
    (:func:`station.brush.stamp.footprint`): a cell's signed distance inside the rim
    (``d − ½``: a rim cell ½, the cell outside it −½) plus ``reach · edge`` (``edge``
    the paper's tooth over a couple of cells, in [−1, 1], canvas-sized; ``reach`` times
    the mark's half-width over 4 cells, at most 1: a thin tip cannot wander farther than
    it is wide) says whether it is covered (above 0); a cell it brings in takes the
    weight of the nearest covered cell. A loaded tuft's liquid meets the paper at its
    contact line, which reaches out onto the tooth's hills and falls short of its
    valleys: without
    this the rim of a flat pulled straight was the line its spines' tubes drew, a ruler
    edge (0.03-0.2 cells of std). The window grows by ``ceil(reach)`` cells (clipped to
    the canvas)."""
    if reach <= 0.0 or wt.size == 0:
        return y0, x0, wt
    hh, ww = edge.shape
    m = int(math.ceil(reach))
    h, w = wt.shape
    ya, yb = max(y0 - m, 0), min(y0 + h + m, hh)
    xa, xb = max(x0 - m, 0), min(x0 + w + m, ww)
    big = np.zeros((yb - ya, xb - xa), np.float32)
    big[y0 - ya:y0 - ya + h, x0 - xa:x0 - xa + w] = wt
    on = big > 0.0
    if not on.any():
        return y0, x0, wt
    # distance [cells] from a covered cell to the nearest uncovered one (the window's
    # ring counts as uncovered), and from an uncovered one to the nearest covered
    d_in = ndimage.distance_transform_edt(np.pad(on, 1))[1:-1, 1:-1]
    # a thin tip cannot wander farther than it is wide (the round brush: r / 4)
    reach *= min(1.0, float(d_in.max()) / 4.0)
    d_out, idx = ndimage.distance_transform_edt(~on, return_indices=True)
    inside = np.where(on, d_in - 0.5, 0.5 - d_out) + reach * edge[ya:yb, xa:xb]
    # whole cells in or out (the weights keep the rasteriser's own anti-aliasing): a rim
    # moved out where the tooth is as far above its mean as it is moved in where below
    src = big[idx[0], idx[1]]
    return ya, xa, np.where(inside > 0.0, src, np.float32(0.0)).astype(np.float32)


def prune_spurs(wt: np.ndarray, passes: int = 8) -> np.ndarray:
    """``wt`` without its one-cell spurs: a covered cell with at most one covered
    4-neighbour is cleared, up to ``passes`` times (a hair's streak dragged off the body,
    :func:`sweep`, goes back to the body). In a line (fewer than a quarter of its cells
    with three or more covered neighbours: a rigger's line) only a spur sticking out of
    the line's side goes (its neighbour has three or more covered neighbours), and, in a
    mark of ``LONE_MIN`` cells or more, a lone dot: a one-cell line and its ends are the
    stroke."""
    out = wt
    for k in range(passes):
        on = out > 0
        if not on.any():
            break
        pad = np.pad(on, 1)
        nb = (pad[:-2, 1:-1].astype(np.int8) + pad[2:, 1:-1] + pad[1:-1, :-2]
              + pad[1:-1, 2:])
        spur = on & (nb <= 1)
        if k == 0 and 4 * int(np.count_nonzero(on & (nb >= 3))) < int(np.count_nonzero(on)):
            # a line (a rigger's mark): only side whiskers and lone dots, once
            busy = np.pad(on & (nb >= 3), 1)
            side = (busy[:-2, 1:-1] | busy[2:, 1:-1] | busy[1:-1, :-2] | busy[1:-1, 2:])
            lone = on & (nb == 0) if int(np.count_nonzero(on)) >= LONE_MIN else False
            return np.where((spur & side) | lone, out.dtype.type(0), out)
        if not spur.any():
            break
        out = np.where(spur, out.dtype.type(0), out)
    return out
