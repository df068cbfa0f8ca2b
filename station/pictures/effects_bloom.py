"""The effects sheet's bloom tile (issue 21 item 4), painted through the brush: clear
water and a second colour dropped into a damp wash, a drop of colour into a wet one."""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.spatial import ConvexHull, QhullError

from station.backends.numpy_canvas import NumpyCanvas
from station.brush.stamp import BrushModel
from station.pictures.effects_core import (
    PEN_HZ,
    Effect,
    _played,
    darkness_map,
    new_canvas,
)
from station.pictures.measure import feather
from station.sim.player import SessionPlayer
from station.sim.script import Script


def _wash_then(first: Script, seed: int, until_damp: bool
               ) -> tuple[NumpyCanvas, SessionPlayer]:
    h = first.header
    c = new_canvas(h.width, h.height, profile=h.profile, seed=seed)
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
    (cy, cx): along each of ``n`` rays the last cell still inside (:func:`_radii`)."""
    rr = _radii(region, cy, cx, n)
    return float(rr.mean()), float(rr.std() / max(rr.mean(), 1e-9))


DROP_SIZE, DROP_S = 12, 0.3
"""The clear-water drop of the bloom tile: brush size and how long the brush touches [s]."""
N = 80
"""Edge of the bloom tile's canvases [cells]."""
WASH_PIGMENT, SECOND_PIGMENT = "French Ultramarine", "Quinacridone Rose"


def damp_wash(seed: int = 22) -> tuple[NumpyCanvas, SessionPlayer]:
    """A brushed Ultramarine wash (size 24, seven rows, 0.45 s each) left until no
    standing water remains in its middle half, the paper still damp."""
    wash = Script(N, N, seed=seed, rate_hz=PEN_HZ)
    wash.brush(size=24, water=1.0, pigment={WASH_PIGMENT: 0.4})
    for k in range(7):
        y = (8 + 11 * k) / N
        a, b = ((0.05, y), (0.95, y)) if k % 2 == 0 else ((0.95, y), (0.05, y))
        wash.line(a, b, 0.45, pressure=0.7)
        wash.wait(0.2)
    return _wash_then(wash, seed, until_damp=True)


def drop_into_damp_wash(pigment: dict[str, float], seed: int = 22,
                        touch: float = 0.0,
                        report: dict[str, float] | None = None) -> NumpyCanvas:
    """:func:`damp_wash`, then the brush (size ``DROP_SIZE``, water 1) touches its middle
    for ``DROP_S`` with ``pigment`` (empty: clear water); dried and fixed. ``touch`` > 0
    [s]: the brush circles 5 cells across there for that long instead (a resting dab lays
    one stamp however long it rests; a moving touch lays more water). ``report`` (a dict)
    receives :func:`_touch_spread`'s ``touch_radius`` and ``spread_radius`` [cells]."""
    c, p = damp_wash(seed)
    drop = _later(p, N, N, seed)
    drop.brush(size=DROP_SIZE, water=1.0, pigment=pigment)
    if touch > 0:
        drop.curve([(0.5 + 2.5 / N * np.cos(1.3 * i), 0.5 + 2.5 / N * np.sin(1.3 * i))
                    for i in range(10)], touch, pressure=0.7)
    else:
        drop.dab((0.5, 0.5), DROP_S, pressure=0.7)
    p.play(drop.records)
    spread = _touch_spread(c, (slice(N // 4, 3 * N // 4), slice(N // 4, 3 * N // 4)), 6000)
    if report is not None:
        report.update(spread)
    c.dry()
    return c


def _touch_spread(c: NumpyCanvas, near: tuple[slice, slice], max_steps: int
                  ) -> dict[str, float]:
    """Run ``c`` until no fluid water is left (or ``max_steps``), right after a touch into
    a damp wash whose window ``near`` held no standing water before it. Returns the radius
    [cells] of a disc of the area the touch left wet in ``near`` (``touch_radius``) and of
    the largest area its water reached while it spread (``spread_radius``): a real backrun
    runs out well beyond the brush (Curtis et al. 1997 fig. 1c), the model's reach a
    little further than the touch and stall (see docs/canvas-model.md, session 15)."""
    st = c.live_state
    first = int((st.w[near] > 0).sum())
    most = first
    n = 0
    while n < max_steps and (st.w > 0).any():
        c.step()
        n += 1
        most = max(most, int((st.w[near] > 0).sum()))
    return {"touch_radius": float(np.sqrt(first / np.pi)),
            "spread_radius": float(np.sqrt(most / np.pi))}


def lobes(radii: np.ndarray, prominence: float = 0.15) -> int:
    """Lobes of an outline: local maxima of the radius around the circle that stand
    ``prominence`` of the mean radius above the lower of their two neighbouring minima."""
    r = np.asarray(radii, float)
    n = len(r)
    if n < 3 or r.mean() <= 0:
        return 0
    count = 0
    for i in range(n):
        if r[i] < r[i - 1] or r[i] < r[(i + 1) % n] or r[i] == r[i - 1]:
            continue
        # walk down each side to the first rise: the neighbouring minima
        lo_l = r[i]
        k = 1
        while k < n and r[(i - k) % n] <= lo_l:
            lo_l = r[(i - k) % n]
            k += 1
        lo_r = r[i]
        k = 1
        while k < n and r[(i + k) % n] <= lo_r:
            lo_r = r[(i + k) % n]
            k += 1
        if r[i] - max(lo_l, lo_r) >= prominence * r.mean():
            count += 1
    return count


def bloom_front(amount: np.ndarray, centre: tuple[float, float] = (N / 2, N / 2)
                ) -> dict[str, float]:
    """The bloom in a dried wash: ``amount`` is the wash's pigment (or darkness) per cell.

    The bloom is the connected pale region (below 0.85 of the wash's median, holes
    filled) around ``centre``; its front the 3-cell ring outside it. Returns the front's
    75th percentile over the wash's median (``front_ratio``), the outline's mean radius
    [cells], its coefficient of variation, its lobes (:func:`lobes`), and of the outline
    traced on the amount blurred by :data:`GRAIN_SIGMA`: how far it wanders
    (:func:`front_branching`) and its fingers (lobes at :data:`FINE_RAYS` rays and
    :data:`FINGER_PROMINENCE`)."""
    n = amount.shape[0]
    wash = float(np.median(amount[8:n - 8, 8:n - 8]))
    pale = ndimage.binary_fill_holes(amount < 0.85 * wash)
    lab_, _ = ndimage.label(pale)
    cy, cx = centre
    idx = lab_[int(cy), int(cx)]
    if not idx or wash <= 0:
        return {"front_ratio": 0.0, "radius": 0.0, "cv": 0.0, "lobes": 0.0, "branching": 0.0,
                "fingers": 0.0}
    bloom = lab_ == idx
    rim = ndimage.binary_dilation(bloom, iterations=3) & ~bloom
    front = float(np.percentile(amount[rim], 75)) / wash
    radii = _radii(bloom, cy, cx)
    # the outline's shape without the grain: granulation and the paper's tooth make the
    # 0.85 level wander cell by cell even around a round ring
    soft = ndimage.binary_fill_holes(ndimage.gaussian_filter(amount, GRAIN_SIGMA) < 0.85 * wash)
    lab_s, _ = ndimage.label(soft)
    shape = lab_s == lab_s[int(cy), int(cx)] if lab_s[int(cy), int(cx)] else bloom
    return {"front_ratio": front, "radius": float(radii.mean()),
            "cv": float(radii.std() / max(radii.mean(), 1e-9)), "lobes": float(lobes(radii)),
            "branching": front_branching(shape),
            "fingers": float(lobes(_radii(shape, cy, cx, FINE_RAYS), FINGER_PROMINENCE))}


GRAIN_SIGMA = 1.0
"""Gaussian blur [cells] of the amount before :func:`bloom_front` traces the outline whose
branching and fingers it measures: the round kiosk ring's raw 0.85 level measures 1.40
(the grain), blurred 1.03; a finger two cells wide survives it."""


FINE_RAYS, FINGER_PROMINENCE = 256, 0.08
"""Rays and prominence (share of the mean radius) of :func:`bloom_front`'s finger count:
four times the lobes' angular resolution, half their depth."""


def front_branching(region: np.ndarray) -> float:
    """How far a bloom's outline wanders: its length over the perimeter of its convex hull.

    The length is the count of cell edges between the region and the rest, times pi / 4
    (the mean over directions of a grid staircase's excess over a straight line, so a
    digitised disc measures about 1); the hull is that of the region's cell corners. A
    round or gently lobed crown measures about 1.0-1.2; a front that branches into fingers
    and bays (a cauliflower) walks a much longer line than its hull (1.5 and more)."""
    r = region.astype(np.int8)
    edges = int(np.abs(np.diff(r, axis=0)).sum() + np.abs(np.diff(r, axis=1)).sum())
    edges += int(r[0].sum() + r[-1].sum() + r[:, 0].sum() + r[:, -1].sum())
    ys, xs = np.nonzero(region)
    if len(ys) < 3:
        return 0.0
    corners = np.concatenate([np.stack([ys + a, xs + b], 1) for a in (0, 1) for b in (0, 1)])
    try:
        hull = ConvexHull(corners.astype(float))
    except QhullError:  # a straight line of cells: no area, nothing to wander
        return 0.0
    return float(edges * np.pi / 4 / hull.area)  # 2-D hull: .area is its perimeter


def _radii(region: np.ndarray, cy: float, cx: float, n: int = 64) -> np.ndarray:
    """Along each of ``n`` rays from (cy, cx) the distance to the last cell of ``region``."""
    radii = []
    for a in np.linspace(0, 2 * np.pi, n, endpoint=False):
        r = 0.0
        for t in np.arange(0.5, max(region.shape), 0.5):
            y, x = int(cy + t * np.sin(a)), int(cx + t * np.cos(a))
            if not (0 <= y < region.shape[0] and 0 <= x < region.shape[1]) or not region[y, x]:
                break
            r = t
        radii.append(r)
    return np.array(radii)


KIOSK_N, KIOSK_DROP = 128, (64.0, 76.0)
"""Edge of the kiosk drop's canvas [cells] and where the water touches (x, y) [cells]."""


def kiosk_drop(seed: int = 0, touch: float = 0.4) -> tuple[NumpyCanvas, dict[str, float]]:
    """Clean water dropped into a damp sky as the kiosk's scripted visitor paints it
    (``tools/kiosk_screenshots.py``, the kiosk's cells): French Ultramarine and Cerulean
    at the kiosk's strength 0.8 with the sky's brush (size 72, water 1) in four rows 31
    cells apart at the visitor's pace (550 cells/s), left until no standing water is left
    around the drop, then a fresh brush of clean water (size 26, water 1) circling 6 cells
    across for ``touch`` (0.4 s, the visitor's), dried. Returns the canvas and
    :func:`bloom_front` of its darkness around the drop (the wash's median taken over the
    middle of the sky) with :func:`_touch_spread`'s ``touch_radius`` and ``spread_radius``
    in the 60-cell window around the drop."""
    n = KIOSK_N
    s = Script(n, n, seed=seed, rate_hz=PEN_HZ)
    s.brush(size=72, water=1.0, pigment={WASH_PIGMENT: 0.4, "Cerulean Blue": 0.4})
    for k in range(4):
        y = (30 + 31 * k) / n
        a, b = ((0.02, y), (0.98, y)) if k % 2 == 0 else ((0.98, y), (0.02, y))
        s.line(a, b, 0.96 * n / 550.0, pressure=0.5)
    c = NumpyCanvas(n, n, profile="watercolor", seed=seed)
    p = SessionPlayer(c, n, n, "watercolor")
    p.play(s.records)
    st = c.live_state
    cx, cy = KIOSK_DROP
    near = (slice(int(cy) - 30, int(cy) + 30), slice(int(cx) - 30, int(cx) + 30))
    k = 0
    while (st.w[near] > 0).any() and k < 20000:
        c.step()
        k += 1
    drop = _later(p, n, n, seed)
    drop.brush(size=26, water=1.0, pigment={})
    drop.curve([((cx + 6.4 * np.cos(1.3 * i)) / n, (cy + 3.6 * np.sin(1.3 * i)) / n)
                for i in range(10)], touch, pressure=0.6)
    p.play(drop.records)
    spread = _touch_spread(c, near, 20000)
    c.dry()
    d = darkness_map(c)
    wash = float(np.median(d[near]))
    scaled = d * (float(np.median(d[8:n - 8, 8:n - 8])) / max(wash, 1e-9))
    return c, {**bloom_front(scaled, (cy, cx)), **spread}


def drop_into_wet_wash(wet: bool) -> NumpyCanvas:
    """A dab of Ultramarine (size 12, water 0.8, amount 1, 0.3 s) into a fully wet clear
    wash (``wet``), or on dry paper; dried and fixed."""
    s = Script(N, N, seed=23, rate_hz=PEN_HZ)
    if wet:
        s.brush(size=24, water=1.0, pigment={})
        for k in range(7):
            y = (8 + 11 * k) / N
            a, b = ((0.05, y), (0.95, y)) if k % 2 == 0 else ((0.95, y), (0.05, y))
            s.line(a, b, 0.45, pressure=0.7)
    s.brush(size=12, water=0.8, pigment={WASH_PIGMENT: 1.0})
    s.dab((0.5, 0.5), 0.3, pressure=0.7)
    return _played(s, seed=23)


def drop_front(dark: np.ndarray, share: float = 0.25,
               centre: tuple[float, float] = (N / 2, N / 2)) -> dict[str, float]:
    """The front of a drop of colour in a dried wash: ``dark`` its darkness (or pigment)
    per cell. The drop is the connected region at ``share`` of the darkest cell or more
    around ``centre`` (holes filled). Returns its ``feather`` (the iso-line's length over
    its convex hull's perimeter, :func:`station.pictures.measure.feather`; 1 for a round
    blot) and the outline's mean radius [cells] and radius CV (rays from ``centre``)."""
    top = float(dark.max())
    if top <= 0:
        return {"feather": 0.0, "radius": 0.0, "cv": 0.0}
    level = share * top
    lab_, _ = ndimage.label(dark >= level)
    cy, cx = centre
    idx = lab_[int(cy), int(cx)]
    if not idx:
        return {"feather": 0.0, "radius": 0.0, "cv": 0.0}
    drop = ndimage.binary_fill_holes(lab_ == idx)
    # the drop's own iso-line only: other specks at the level and the holes left out
    near = ndimage.binary_dilation(drop, iterations=2)
    f = np.where(drop, np.maximum(dark, level), np.where(near, dark, 0.0))
    radius, cv = _radius_cv(drop, cy, cx)
    return {"feather": feather(f, level), "radius": radius, "cv": cv}


def blooms() -> Effect:
    """Item 4, through the brush: (a) clear water touched (size 12, 0.3 s) into a brushed
    Ultramarine wash once its standing water is gone but the paper is still damp: the
    bloom's front over the wash's darkness, its radius CV and lobes; (b) the same touch
    with Quinacridone Rose: the Ultramarine it pushed out (front and CV measured on the
    wash pigment's amount); (c) a dab of Ultramarine into a fully wet clear wash: its
    spread over the brush radius, its peak darkness over the same dab on dry paper, and its
    front (:func:`drop_front`): feathered (iso-line over hull perimeter) and irregular
    (radius CV), not a soft round blot; (d) numbers only: the kiosk visitor's clean-water
    drop into its damp sky (:func:`kiosk_drop`). (a) and (d) also report how far the front wanders
    (:func:`front_branching`) and its fingers, and how far the bloom and the touch's water
    reach beyond the area the touch left wet (:func:`_touch_spread`: ``*_over_touch``,
    ``*_spread_over_touch``; numbers only, no check: a real backrun runs out well beyond
    the brush, the model's stays near it)."""
    reach: dict[str, float] = {}
    c1 = drop_into_damp_wash({}, report=reach)
    clear = bloom_front(darkness_map(c1))
    c2 = drop_into_damp_wash({SECOND_PIGMENT: 0.8})
    st2 = c2.live_state
    k = st2.slots.index(WASH_PIGMENT)
    colour = bloom_front(st2.q[k] + st2.p[k])
    wet, dry = drop_into_wet_wash(True), drop_into_wet_wash(False)
    dw, dd = darkness_map(wet), darkness_map(dry)
    r_brush = BrushModel().radius(12, 0.7)
    spread_r = float(np.sqrt((dw > 0.25 * dw.max()).sum() / np.pi)) if dw.max() > 0 else 0.0
    peak_share = float(np.percentile(dw, 99.5) / max(np.percentile(dd, 99.5), 1e-6))
    fr = drop_front(dw)
    _, kiosk = kiosk_drop()
    front, cv = clear["front_ratio"], clear["cv"]
    return Effect("blooms (brush)",
                  {"bloom_front_ratio": front, "bloom_radius_cells": clear["radius"],
                   "bloom_radius_cv": cv, "bloom_lobes": clear["lobes"],
                   "bloom_front_branching": clear["branching"],
                   "bloom_fingers": clear["fingers"],
                   "bloom_touch_radius_cells": reach["touch_radius"],
                   "bloom_over_touch": clear["radius"] / max(reach["touch_radius"], 1e-9),
                   "bloom_spread_over_touch": reach["spread_radius"]
                   / max(reach["touch_radius"], 1e-9),
                   "kiosk_bloom_front_ratio": kiosk["front_ratio"],
                   "kiosk_bloom_radius_cells": kiosk["radius"],
                   "kiosk_bloom_radius_cv": kiosk["cv"],
                   "kiosk_bloom_front_branching": kiosk["branching"],
                   "kiosk_bloom_fingers": kiosk["fingers"],
                   "kiosk_bloom_touch_radius_cells": kiosk["touch_radius"],
                   "kiosk_bloom_over_touch": kiosk["radius"] / max(kiosk["touch_radius"], 1e-9),
                   "kiosk_bloom_spread_over_touch": kiosk["spread_radius"]
                   / max(kiosk["touch_radius"], 1e-9),
                   "colour_bloom_front_ratio": colour["front_ratio"],
                   "colour_bloom_radius_cells": colour["radius"],
                   "colour_bloom_radius_cv": colour["cv"],
                   "drop_spread_over_brush_radius": spread_r / r_brush,
                   "drop_peak_over_dry": peak_share, "drop_feather": fr["feather"],
                   "drop_radius_cv": fr["cv"]},
                  {"bloom front >= 1.3x": front >= 1.3, "irregular (CV >= 0.15)": cv >= 0.15,
                   "branching (>= 3 lobes)": clear["lobes"] >= 3,
                   "colour bloom front >= 1.3x": colour["front_ratio"] >= 1.3,
                   "drop spreads >= 2.5 r": spread_r >= 2.5 * r_brush,
                   "drop stays visible (>= 0.5x dry)": peak_share >= 0.5,
                   "drop's front feathered (>= 1.3)": fr["feather"] >= 1.3,
                   "drop's front irregular (CV >= 0.15)": fr["cv"] >= 0.15},
                  np.concatenate([c1.render(), c2.render(), wet.render(), dry.render()],
                                 axis=1),
                  (c1, c2, wet, dry))
