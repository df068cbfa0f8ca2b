"""The bundled demo: a watercolor landscape, scripted as pen input.

:func:`landscape` writes, with the station's own scripted pen
(:mod:`station.sim.script`), a session that uses what the canvas model does
(issue 10 item 9: the demo beside the effects sheet):

1. **wet-in-wet sky** — clear water over the paper, then French Ultramarine and
   Cerulean Blue (both granulating) graded from the top, laid round clouds left as
   paper (their edges feather into the wet), a warm glow dropped in at the horizon
   and a grey along the clouds' bases while it is wet, the crowns blotted with a
   tissue;
2. **distant mountains** — two ranges, each body pulled down its slopes into wetted
   paper; the crests laid into **damp** paper (soft), on dry paper (**hard, dark
   edges**) and into wet paper (**lost**), the foot run into mist;
3. **hills** — clear water under the crest, a pale yellow-green along it pulled down
   the slopes into the water, greens and umber dropped in **wet-in-wet** near the
   crest, warm light touched into the slopes; a nearer knoll on a new layer,
   wet-on-dry, its crest a hard edge and its foot lost in water;
4. **lake** — clear water over all of it, then a pale blue at the far shore and a
   deeper blue down to the near bank laid into it: one graded wash, no white steps
   where a front would stop at dry paper; dried, a broken far shore of headlands of
   uneven length and value with tree masses, and quick **dry-brush** ripples of the
   deformable tuft;
5. **foreground** — a near bank rising to the right (the picture's diagonal), laid
   over the lake's dried edge: wet paper, warm ochre in varied strokes along it,
   Burnt Umber with French Ultramarine dropped in wet (**granulating** in the paper's
   valleys), greens at the grass; dried, grass **flicked** up with the rigger;
6. **ink** — a profile switch to ``ink`` for a slender tree on the bank's high end
   (the focal point) and birds in Sumi Ink.

The committed ``station/data/demo/landscape.jsonl`` is exactly
``landscape().text()``; regenerate it with ``python -m station.pictures.demo``
(a test checks the two are equal).
"""

from __future__ import annotations

import itertools
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from station.sim.script import Script, swell, taper, tilt_const, tilt_sweep

DEMO_WIDTH, DEMO_HEIGHT = 400, 300
DEMO_SEED = 11
DAMP_WAIT = 2.5  # s: clear water soaked in until damp (no shine), not dry
DEMO_FILE = Path(__file__).resolve().parent.parent / "data" / "demo" / "landscape.jsonl"


def _ridge(x: float, base: float, amp: float, phase: float, waves: float,
           sharp: float = 0.0) -> float:
    """Height (y, normalised, down) of a hill line at ``x``; ``sharp`` adds crags."""
    v = (0.6 * math.sin(2 * math.pi * (waves * x + phase))
         + 0.4 * math.sin(2 * math.pi * (2.3 * waves * x + 1.7 * phase)))
    if sharp:
        v += sharp * (abs(math.sin(2 * math.pi * (3.1 * waves * x + 0.3 * phase))) - 0.5)
    return base - amp * v


def _tree(s: Script, cells: float, foot: tuple[float, float], height: float) -> None:
    """An ink tree: a trunk pressed hard at the foot and lifted towards the crown, branches
    that taper from the trunk to a hair, twigs drawn with the rigger."""
    fx, fy = foot
    s.brush(size=1.6 * cells, water=0.5, pigment={"Sumi Ink": 0.9})
    s.curve([foot, (fx - 0.006, fy - 0.35 * height), (fx + 0.006, fy - 0.7 * height),
             (fx - 0.01, fy - height)], 1.1,
            pressure=taper(0.95, 0.95, 0.1, attack=0.05, release=0.8),
            tilt=tilt_const(-10.0, 30.0))
    s.brush(size=0.8 * cells, water=0.5, pigment={"Sumi Ink": 0.75})
    branches = ((0.42, -1, 0.12, 0.06), (0.52, 1, 0.12, 0.08), (0.66, -1, 0.09, 0.07),
                (0.76, 1, 0.09, 0.06), (0.87, -1, 0.06, 0.05))
    ends = []
    for at, side, length, rise in branches:
        bx, by = fx - 0.004 * at, fy - at * height
        dx, dy = side * length, -rise
        end = (bx + dx, by + dy)
        ends.append((end, side))
        s.curve([(bx, by), (bx + 0.5 * dx, by + 0.25 * dy), end], 0.35,
                pressure=taper(0.85, 0.85, 0.0, attack=0.05, release=0.9))
    s.brush(size=1.4 * cells, water=0.5, pigment={"Sumi Ink": 0.7}, kind="rigger")
    for k, (end, side) in enumerate(ends):
        for t in (-1, 1):
            tw = (end[0] + 0.025 * (side + 0.6 * t), end[1] - 0.03 * (1 + k % 2))
            s.line(end, tw, 0.15, pressure=taper(0.5, 0.5, 0.0, attack=0.05, release=0.8))


def _blow_dry(s: Script, seconds: float) -> None:
    """A hair dryer over the whole sheet for ``seconds`` of painting time, then ``dry``
    for what is left: the paint dries by evaporation (rims, backruns), only faster."""
    s.cmd("hairdryer", x=0.5, y=0.5, radius=500, seconds=seconds)
    s.wait(seconds)
    s.dry()


def _wavy(x0: float, x1: float, y: float, amp: float, freq: float, phase: float,
          n: int = 8) -> list[tuple[float, float]]:
    return [(x0 + (x1 - x0) * k / n, y + amp * math.sin(freq * k / n + phase))
            for k in range(n + 1)]


def _wet(s: Script, c: float, rows: list[float], x0: float = 0.0, x1: float = 1.0,
         size: float = 9.0) -> None:
    """Clear water brushed across the rows ``rows`` (y) with a ``size`` % brush: paint
    touched into it next spreads and feathers (wet-in-wet) instead of stopping at a hard
    edge."""
    s.brush(size=size * c, water=1.0, pigment={})
    for k, y in enumerate(rows):
        a, b = (x0, y), (x1, y + 0.004)
        s.line(*((a, b) if k % 2 == 0 else (b, a)), 0.5, pressure=taper(0.9, 0.7, 0.7),
               tilt=tilt_const(15.0, 10.0))


# Clouds left as paper in the sky, each a few lobes: centre (x, y) and half-width,
# half-height (normalised), a flat-ish base and a bumpy crown; the blue is laid round
# them into wet paper, so their edges feather.
Lobe = tuple[float, float, float, float]
_CLOUDS: tuple[tuple[Lobe, ...], ...] = (
    ((0.1, 0.19, 0.06, 0.035), (0.18, 0.15, 0.08, 0.065), (0.27, 0.165, 0.07, 0.05),
     (0.35, 0.195, 0.05, 0.025)),
    ((0.54, 0.12, 0.06, 0.035), (0.625, 0.08, 0.075, 0.06), (0.71, 0.1, 0.07, 0.05),
     (0.8, 0.13, 0.05, 0.028)),
    ((0.88, 0.26, 0.04, 0.022), (0.93, 0.245, 0.04, 0.03)),
    ((0.42, 0.285, 0.08, 0.016), (0.5, 0.278, 0.05, 0.014)))


def _around_clouds(y: float, x0: float, x1: float, margin: float
                   ) -> list[tuple[float, float]]:
    """The spans of the row ``y`` from ``x0`` to ``x1`` that miss every cloud's lobes
    (grown by ``margin``, the brush's reach): where a painter's wash goes round them."""
    spans = [(x0, x1)]
    for cx, cy, rx, ry in (lobe for cloud in _CLOUDS for lobe in cloud):
        dy = (y - cy) / (ry + margin)
        if abs(dy) >= 1.0:
            continue
        half = (rx + margin) * math.sqrt(1.0 - dy * dy)
        cut = []
        for a, b in spans:
            if b <= cx - half or a >= cx + half:
                cut.append((a, b))
                continue
            if a < cx - half:
                cut.append((a, cx - half))
            if b > cx + half:
                cut.append((cx + half, b))
        spans = cut
    return [(a, b) for a, b in spans if b - a > 0.03]


def _sky(s: Script, c: float) -> None:
    """The sky, wet-in-wet: the paper wetted with clear water, a graded wash of French
    Ultramarine into Cerulean laid from the top in slanting strokes that go round the
    clouds (left as paper: their edges feather into the wet), their bumpy crowns cut
    round with a smaller brush, a pale warm glow dropped in at the horizon, a grey of
    Ultramarine and Burnt Umber dropped along the clouds' bases while it is wet, the
    crowns softened by a tissue; dried."""
    s.brush(size=16 * c, water=1.0, pigment={})
    for i in range(6):
        y = 0.03 + i * 0.08
        left, right = (0.0, y), (1.0, y + 0.015)
        s.line(*((left, right) if i % 2 == 0 else (right, left)), 0.5,
               pressure=taper(0.95, 0.8, 0.8),
               tilt=tilt_const(20.0, 15.0))
    # the graded wash: strong at the top, weaker row by row (the brush is recharged
    # with paler paint), each row slanting a little and broken by the clouds
    rows = ((0.02, {"French Ultramarine": 0.75, "Cerulean Blue": 0.25}, 0.95),
            (0.075, {"French Ultramarine": 0.55, "Cerulean Blue": 0.3}, 0.85),
            (0.13, {"French Ultramarine": 0.38, "Cerulean Blue": 0.35}, 0.75),
            (0.185, {"French Ultramarine": 0.24, "Cerulean Blue": 0.35}, 0.65),
            (0.24, {"French Ultramarine": 0.1, "Cerulean Blue": 0.3}, 0.55),
            (0.3, {"Cerulean Blue": 0.18}, 0.45))
    for k, (y, paint, p) in enumerate(rows):
        s.brush(size=6 * c, water=0.85, pigment=paint)
        spans = _around_clouds(y, -0.02, 1.02, 0.015)
        if k % 2:
            spans = [(b, a) for a, b in reversed(spans)]
        for j, (a, b) in enumerate(spans):
            slope = 0.012 * math.sin(2.1 * k + 1.3 * j)
            s.curve([(a, y - slope), ((a + b) / 2, y + 0.006 * math.sin(3.0 * k + j)),
                     (b, y + slope)], 0.15 + 0.35 * abs(b - a),
                    pressure=swell(0.75 * p, p, 0.7 + 0.3 * (j % 2)),
                    tilt=tilt_sweep((25.0, 10.0), (-10.0, 20.0)))
    # the crowns cut round, lobe by lobe, with a smaller brush of the row's blue
    s.brush(size=3 * c, water=0.85, pigment={"French Ultramarine": 0.35, "Cerulean Blue": 0.3})
    for cloud in _CLOUDS[:3]:
        for cx, cy, rx, ry in cloud:
            s.arc((cx, cy), (rx + 0.018, ry + 0.03), 200.0, 340.0, 0.3,
                  pressure=swell(0.35, 0.6, 1.0))
    # a pale warm glow at the horizon, dropped into the wet blue: it feathers upwards
    s.brush(size=6 * c, water=0.85, pigment={"Quinacridone Rose": 0.12, "Hansa Yellow": 0.2})
    s.curve([(1.0, 0.385), (0.7, 0.37), (0.4, 0.395), (0.0, 0.38)], 0.9,
            pressure=swell(0.3, 0.6, 1.5))
    # cloud shadows: a soft grey dropped into the wet along each cloud's base
    s.brush(size=3 * c, water=0.8, pigment={"French Ultramarine": 0.2, "Burnt Umber": 0.12,
                                             "Quinacridone Rose": 0.04})
    for cloud in _CLOUDS:
        (xl, _, rl, _), (xr, _, rr, _) = cloud[0], cloud[-1]
        base = max(cy + 0.6 * ry for _, cy, _, ry in cloud)
        s.curve([(xl - 0.6 * rl, base - 0.006), (xl, base), (xr, base + 0.004),
                 (xr + 0.5 * rr, base - 0.01)], 0.5,
                pressure=swell(0.2, 0.45, 1.0))
    s.wait(1.0)
    # the crowns blotted with a crumpled tissue while the wash is still wet
    for k, cloud in enumerate(_CLOUDS[:3]):
        for cx, cy, _rx, ry in cloud:
            s.cmd("tissue", kind="crepe", scale=16, size=round(2.2 * ry * 100 * c, 2),
                  absorb=0.5, seed=k, x=cx, y=round(cy - 0.3 * ry, 4))
    s.wait(1.5)
    _blow_dry(s, 8.0)
    s.new_layer()


def _slopes(s: Script, top: Callable[[float], float], x0: float, x1: float, foot: float,
            n: int, p: float, seed: float) -> None:
    """A range's body in strokes pulled down its slopes from the crest ``top(x)`` (as a
    painter shapes a mountain: not in rows), each a little shorter or longer, lighter
    towards the foot."""
    for k in range(n):
        u = (k + 0.5 + 0.35 * math.sin(seed + 2.7 * k)) / n
        x = x0 + (x1 - x0) * u
        y = top(x)
        lean = 0.025 * math.sin(seed + 1.9 * k)
        length = (foot - y) * (0.8 + 0.2 * math.sin(seed + 3.3 * k))
        s.curve([(x, y + 0.008), (x + 0.4 * lean, y + 0.45 * length),
                 (x + lean, y + length)], 0.25 + 0.2 * length,
                pressure=taper(p, 0.8 * p, 0.3 * p, attack=0.1, release=0.6),
                tilt=tilt_const(10.0 * math.sin(seed + k), 15.0))


def _wet_under(s: Script, c: float, top: Callable[[float], float], x0: float, x1: float,
               below: float, foot: float, size: float = 7.0, step: float = 0.055,
               duration: float = 0.0) -> None:
    """Clear water over a range's body, from ``below`` under its crest ``top(x)`` down to
    ``foot``, in strokes following the crest: the paint pulled down next runs together
    and fades into it, while the crest itself stays on dry paper."""
    s.brush(size=size * c, water=1.0, pigment={})
    y, k = below, 0
    while True:
        pts = [(x, min(top(x) + y, foot)) for x in (x0 + (x1 - x0) * i / 8 for i in range(9))]
        s.curve(pts if k % 2 == 0 else pts[::-1], duration or 0.15 + 0.3 * (x1 - x0),
                pressure=taper(0.85, 0.7, 0.7))
        if all(py >= foot for _, py in pts):
            break
        y += step
        k += 1


def _mountains(s: Script, c: float) -> None:
    """Distant mountains on the dried sky, in two ranges. The far range, a pale cool
    violet: the paper under its crest wetted first, its crest laid wet-on-dry on the left
    (a hard edge, darkened as it dries) and into clear water on the right (a lost edge),
    its body pulled down the slopes into the wet, its foot lost into water (mist), a
    warmer violet dropped in. Dried, a nearer, darker peak on the left: the same, its
    crest hard, its shadow side dropped in wet."""

    def far(x: float) -> float:
        return _ridge(x, 0.36, 0.06, 0.1, 1.3, 0.45)

    # clear water over the whole range and a little above its crest, left to soak in
    # until damp: the crest laid next spreads a little (a soft, distant edge), except on
    # the left summits, wetted after, under the crest only (hard edges there)
    _wet_under(s, c, far, -0.02, 0.47, -0.025, 0.5, 5.0, 0.04, 0.5)

    def lost(x: float) -> float:  # under the crest, rising above it to the right
        return far(x) + 0.065 - 0.11 * min(max((x - 0.7) / 0.15, 0.0), 1.0)

    _wet_under(s, c, lost, 0.45, 1.02, 0.0, 0.5)
    s.wait(DAMP_WAIT)
    s.brush(size=4 * c, water=0.75, pigment={"French Ultramarine": 0.3,
                                             "Quinacridone Rose": 0.14, "Burnt Umber": 0.05,
                                             "Cerulean Blue": 0.06})
    for a, b in ((-0.02, 0.3), (0.28, 0.6), (0.58, 1.02)):  # the crest, in three strokes
        s.curve([(x, far(x)) for x in (a + (b - a) * i / 6 for i in range(7))], 0.5,
                pressure=swell(0.55, 0.85, 1.2), tilt=tilt_const(15.0, 10.0))
    s.brush(size=7 * c, water=0.85, pigment={"French Ultramarine": 0.22,
                                             "Quinacridone Rose": 0.1, "Burnt Umber": 0.04,
                                             "Cerulean Blue": 0.05})
    _slopes(s, far, -0.02, 1.02, 0.47, 14, 0.8, 0.3)
    # a warmer violet dropped into the far range while it is wet
    s.brush(size=3.5 * c, water=0.8, pigment={"Quinacridone Rose": 0.16,
                                               "French Ultramarine": 0.1})
    for x in (0.18, 0.47, 0.83):
        s.curve([(x - 0.03, far(x) + 0.03), (x, far(x) + 0.05), (x + 0.02, far(x) + 0.08)],
                0.3, pressure=taper(0.5, 0.3, 0.1))
    # a pale violet and then a clean damp brush run along the foot while it is wet:
    # the strokes' ends melt together into mist instead of hanging as separate drips
    s.brush(size=8 * c, water=0.9, pigment={"French Ultramarine": 0.08,
                                             "Quinacridone Rose": 0.04})
    s.curve(_wavy(-0.02, 1.02, 0.435, 0.008, 6.0, 1.1), 0.8, pressure=taper(0.7, 0.5, 0.5))
    s.brush(size=7 * c, water=0.9, pigment={})
    s.curve(_wavy(1.02, -0.02, 0.475, 0.006, 7.0, 0.4), 0.8, pressure=taper(0.75, 0.6, 0.6))
    _blow_dry(s, 8.0)
    s.new_layer()

    # the nearer peak on the left, darker: the same order
    peak = ((-0.02, 0.415), (0.07, 0.385), (0.15, 0.35), (0.2, 0.335), (0.24, 0.35),
            (0.3, 0.385), (0.37, 0.42), (0.45, 0.455), (0.52, 0.49))

    def near(x: float) -> float:
        for (xa, ya), (xb, yb) in itertools.pairwise(peak):
            if x <= xb:
                return ya + (yb - ya) * (x - xa) / (xb - xa)
        return peak[-1][1]

    _wet_under(s, c, near, -0.02, 0.5, -0.02, 0.52, 5.0, 0.04, 0.5)
    s.wait(DAMP_WAIT)
    s.brush(size=3.5 * c, water=0.7, pigment={"French Ultramarine": 0.4, "Burnt Umber": 0.12,
                                               "Quinacridone Rose": 0.12})
    s.curve(list(peak[:6]), 0.5, pressure=taper(0.8, 0.5, 0.5), tilt=tilt_const(-15.0, 10.0))
    s.curve(list(peak[4:]), 0.5, pressure=taper(0.7, 0.5, 0.2), tilt=tilt_const(15.0, 10.0))
    s.brush(size=6 * c, water=0.85, pigment={"French Ultramarine": 0.3, "Burnt Umber": 0.08,
                                             "Quinacridone Rose": 0.1})
    _slopes(s, near, -0.02, 0.48, 0.52, 7, 0.75, 1.7)
    # its foot run into mist too, with the pale violet
    s.brush(size=8 * c, water=0.9, pigment={"French Ultramarine": 0.08,
                                             "Quinacridone Rose": 0.04})
    s.curve(_wavy(0.5, -0.02, 0.475, 0.006, 5.0, 2.0), 0.5, pressure=taper(0.7, 0.5, 0.5))
    # the shadow side (right of the summit), a darker mix dropped in wet
    s.brush(size=3 * c, water=0.7, pigment={"French Ultramarine": 0.45, "Burnt Umber": 0.25})
    for x in (0.22, 0.29, 0.36):
        s.curve([(x, near(x) + 0.012), (x + 0.02, near(x) + 0.04), (x + 0.03, near(x) + 0.08)],
                0.3, pressure=taper(0.55, 0.3, 0.1))
    # a few crags near the summit, dragged with the deformable round nearly dry once
    # the crest has dried a little: broken hard edges
    s.wait(DAMP_WAIT)
    s.brush(size=2.5 * c, water=0.35, pigment={"French Ultramarine": 0.5, "Burnt Umber": 0.3},
            kind="round3d")
    for x, dx in ((0.17, -0.03), (0.205, 0.025), (0.25, 0.035)):
        s.line((x, near(x) + 0.004), (x + dx, near(x) + 0.045), 0.2, pressure=0.45,
               tilt=(25.0, 0.0))
    _blow_dry(s, 8.0)
    s.new_layer()


def _hills(s: Script, c: float) -> None:
    """Far hills into damp paper: clear water under the crest, a pale yellow-green laid
    along the crest and pulled down the slopes into it (fading out at the foot), greens
    and umber dropped in wet near the crest, warm light touched into the slopes; then a
    nearer knoll on the left, wet-on-dry, its crest a hard edge and its foot lost in
    water."""
    def crest(x: float) -> float:
        return _ridge(x, 0.54, 0.045, 0.55, 1.2, 0.2)

    # clear water under the crest (it stays a crisp edge), then the green laid along the
    # crest and pulled down the slopes into it, fading out at the foot
    _wet_under(s, c, crest, -0.02, 1.02, 0.045, 0.68)
    s.brush(size=4 * c, water=0.85, pigment={"Hansa Yellow": 0.3, "Cerulean Blue": 0.22})
    s.curve([(x, crest(x)) for x in (-0.02 + 1.04 * i / 12 for i in range(13))], 0.8,
            pressure=swell(0.55, 0.85, 2.3), tilt=tilt_const(-20.0, 10.0))
    s.brush(size=6 * c, water=0.9, pigment={"Hansa Yellow": 0.26, "Cerulean Blue": 0.18})
    _slopes(s, crest, -0.02, 1.02, 0.69, 18, 0.8, 4.1)
    s.brush(size=3.5 * c, water=0.7, pigment={"Phthalo Green": 0.3, "Burnt Umber": 0.2,
                                              "French Ultramarine": 0.08})
    for k, x in enumerate((0.08, 0.27, 0.43, 0.7, 0.88)):
        y = crest(x) + 0.02
        s.curve([(x - 0.05, y + 0.004), (x, y - 0.002), (x + 0.04 + 0.01 * (k % 2), y + 0.01)],
                0.3, pressure=taper(0.55 + 0.1 * (k % 3), 0.2, 0.1))
    s.brush(size=4 * c, water=0.8, pigment={"Hansa Yellow": 0.22, "Quinacridone Rose": 0.03})
    for x, y in ((0.2, 0.615), (0.55, 0.6), (0.8, 0.62)):
        s.curve([(x - 0.06, y), (x, y - 0.006), (x + 0.06, y + 0.004)], 0.35,
                pressure=swell(0.3, 0.6, 1.0))
    _blow_dry(s, 9.0)
    s.new_layer()
    s.brush(size=5 * c, water=0.85, pigment={"Phthalo Green": 0.12, "Hansa Yellow": 0.2,
                                              "Burnt Umber": 0.06})
    # a rounded knoll, higher on the left, running out into the lake's far shore
    pts = [(-0.02 + 0.46 * u, 0.64 - 0.045 * math.sin(math.pi * (0.15 + 0.85 * u)) ** 1.5
            + 0.004 * math.sin(17.0 * u)) for u in (i / 10 for i in range(11))]
    s.curve(pts, 0.8, pressure=taper(0.75, 0.3, 0.2), tilt=tilt_const(-15.0, 10.0))
    s.brush(size=6 * c, water=1.0, pigment={"Hansa Yellow": 0.05})
    s.curve([(p[0], p[1] + 0.03) for p in pts[::-1]], 0.8, pressure=taper(0.7, 0.4, 0.3))
    _blow_dry(s, 8.0)
    s.new_layer()


def _bank_top(x: float) -> float:
    """The near bank's top (y) at ``x``: it rises from the left to the tree on the right
    (the picture's diagonal), with a gentle swell."""
    return 0.9 - 0.13 * x + 0.008 * math.sin(7.0 * x + 0.5)


def _lake(s: Script, c: float) -> None:
    """The lake: clear water over the whole of it first, so that the blues laid next run
    together into one graded wash (a light far half, a deeper near half) instead of
    stopping at dry paper in white steps; its top laid over the hills' dried foot, its
    bottom under where the bank will go. Dried, a few quick dry-brush ripples."""
    _wet(s, c, [0.7, 0.73, 0.76, 0.79, 0.82, 0.85], size=4.5)
    s.brush(size=4 * c, water=0.9, pigment={"French Ultramarine": 0.14, "Cerulean Blue": 0.2})
    s.curve(_wavy(0.0, 1.0, 0.69, 0.004, 3.0, 0.5), 0.8, pressure=swell(0.45, 0.75, 1.5))
    s.brush(size=5 * c, water=0.9, pigment={"French Ultramarine": 0.45, "Cerulean Blue": 0.2})
    for k, f in enumerate((0.0, 0.5, 1.0)):
        # rows from 0.755 down to the bank's top (it is laid over their dried edge)
        pts = [(x, 0.755 + f * (_bank_top(x) - 0.012 - 0.755) + 0.004 * math.sin(4.0 * x + k))
               for x in (i / 8 for i in range(9))]
        s.curve(pts[::-1] if k % 2 == 0 else pts, 0.8, pressure=swell(0.55, 0.9, 2.0))
    _blow_dry(s, 10.0)
    _far_shore(s, c)
    s.brush(size=4 * c, water=0.15, pigment={"French Ultramarine": 0.45,
                                              "Cerulean Blue": 0.2}, kind="round3d")
    for x0, x1, y in ((0.1, 0.32, 0.745), (0.55, 0.8, 0.76), (0.38, 0.52, 0.73)):
        s.line((x0, y), (x1, y + 0.003), 0.14, pressure=0.45, tilt=(30.0, 0.0))
    _blow_dry(s, 6.0)
    s.new_layer()


# The far shore's headlands: from x0 to x1 at the water line y (normalised), how thick
# (x the brush), how dark (the pigment's share) and the tree masses on it (x, width,
# height).
_HEADLANDS = ((-0.02, 0.23, 0.686, 1.0, 1.0, ((0.02, 0.05, 0.035), (0.08, 0.06, 0.05),
                                              (0.15, 0.05, 0.03))),
              (0.27, 0.38, 0.689, 0.6, 0.5, ((0.33, 0.03, 0.012),)),
              (0.42, 0.68, 0.685, 0.8, 0.85, ((0.5, 0.04, 0.02), (0.56, 0.05, 0.045),
                                               (0.62, 0.04, 0.03))),
              (0.72, 0.78, 0.69, 0.5, 0.6, ((0.75, 0.025, 0.015),)),
              (0.84, 1.02, 0.687, 0.9, 1.0, ((0.86, 0.04, 0.028), (0.92, 0.06, 0.04),
                                              (0.98, 0.04, 0.025))))


def _far_shore(s: Script, c: float) -> None:
    """The far shore on the dried lake, broken and varied: first a pale low bank along
    the whole water line (it covers the lake's dried top edge), then headlands of uneven
    length, thickness and value, each laid with the deformable round pressed in the
    middle and lifted towards its tips (tapering spits), tree masses rising from them in
    bumps of uneven width and height, a darker mix dropped into their feet while wet
    (it feathers up into them). Cool and light: it is far away."""
    s.brush(size=1.6 * c, water=0.65, pigment={"French Ultramarine": 0.08, "Burnt Umber": 0.05,
                                               "Hansa Yellow": 0.05, "Phthalo Green": 0.03})
    for a, b in ((-0.02, 0.45), (0.4, 1.02)):
        s.curve(_wavy(a, b, 0.689, 0.0025, 9.0, 3.0 * a), 0.6,
                pressure=swell(0.3, 0.6, 2.5), tilt=tilt_const(15.0, 5.0))
    for k, (x0, x1, y, thick, dark, trees) in enumerate(_HEADLANDS):
        # alternately cooler (further) and warmer (lit) headlands
        land = {"French Ultramarine": (0.17 - 0.05 * (k % 2)) * dark,
                "Burnt Umber": 0.12 * dark, "Phthalo Green": 0.09 * dark,
                "Hansa Yellow": 0.04 + 0.08 * (k % 2)}
        s.brush(size=2.4 * c * thick, water=0.7, kind="round3d", pigment=land)
        m = (x0 + x1) / 2
        s.curve([(x0, y + 0.002), (m, y - 0.004 * thick + 0.002 * math.sin(k)),
                 (x1, y + 0.003)], 0.2 + 0.6 * (x1 - x0),
                pressure=taper(0.55 + 0.2 * thick, 0.15, 0.1, attack=0.3, release=0.35),
                tilt=tilt_const(20.0, 5.0))
        for j, (tx, w, h) in enumerate(trees):
            # a mass of foliage: the brush about as wide as the trees, pushed up from
            # the shore and lifted, then a smaller crown beside it
            s.brush(size=round(0.75 * w * 100 * c, 2), water=0.7, pigment=land)
            s.curve([(tx, y - 0.003), (tx + 0.002, y - 0.5 * h), (tx - 0.001, y - 0.75 * h)],
                    0.25, pressure=taper(0.7, 0.5, 0.2, release=0.5))
            s.brush(size=round(0.45 * w * 100 * c, 2), water=0.7, pigment=land)
            side = 0.3 * w if j % 2 else -0.3 * w
            s.curve([(tx + side, y - 0.003), (tx + 1.1 * side, y - 0.5 * h)], 0.2,
                    pressure=taper(0.6, 0.5, 0.2, release=0.5))
        if dark > 0.75:  # a darker foot dropped in wet: it feathers up into the trees
            s.brush(size=1.5 * c, water=0.7, pigment={"French Ultramarine": 0.25,
                                                       "Burnt Umber": 0.25,
                                                       "Phthalo Green": 0.1})
            s.line((x0 + 0.15 * (x1 - x0), y - 0.004), (x1 - 0.2 * (x1 - x0), y - 0.002),
                   0.3, pressure=swell(0.3, 0.6, 1.5))


def _foreground(s: Script, c: float) -> None:
    """The near bank, rising to the right: a warm ochre laid in varied strokes along it,
    wet-on-dry over the lake's dried edge (a crisp shore, no white gap) and into damp paper
    below, a granulating umber-ultramarine dropped in wet at the bottom and a green at the
    grass; dried, grass flicked up from the bank with the rigger."""
    _wet(s, c, [0.9, 0.94, 0.98], size=7.0)  # below the bank's top: a crisp shore
    s.brush(size=7 * c, water=0.9, pigment={"Hansa Yellow": 0.2, "Burnt Umber": 0.14,
                                             "Quinacridone Rose": 0.03})
    for k in range(5):
        x0 = 0.0 + 0.05 * (k % 3)
        pts = [(x0 + (1.0 - x0) * u / 5, _bank_top(x0 + (1.0 - x0) * u / 5) + 0.03
                + 0.045 * k + 0.01 * math.sin(2.5 * u + k)) for u in range(6)]
        s.curve(pts[::-1] if k % 2 else pts, 0.7 + 0.1 * (k % 2),
                pressure=swell(0.35 + 0.05 * k, 0.8, 1.0 + 0.5 * (k % 2)),
                tilt=tilt_const(30.0, 5.0))
    s.brush(size=6 * c, water=0.7, pigment={"Burnt Umber": 0.55, "French Ultramarine": 0.3})
    for x, y, d in ((0.08, 0.96, 0.12), (0.35, 0.97, 0.16), (0.62, 0.94, 0.1),
                    (0.9, 0.93, 0.09)):
        s.curve([(x - d, y + 0.01), (x, y - 0.015), (x + d, y + 0.005)], 0.4,
                pressure=taper(0.7, 0.3, 0.2))
    s.brush(size=4 * c, water=0.7, pigment={"Phthalo Green": 0.2, "Burnt Umber": 0.15,
                                             "Hansa Yellow": 0.1})
    for x in (0.05, 0.24, 0.5, 0.7):
        y = _bank_top(x) + 0.02
        s.curve([(x, y), (x + 0.05, y - 0.012), (x + 0.1, y + 0.006)], 0.3,
                pressure=taper(0.6, 0.3, 0.1))
    _blow_dry(s, 12.0)
    _grass(s, c)
    _blow_dry(s, 4.0)


def _grass(s: Script, c: float) -> None:
    """Grass flicked up from the bank with the rigger: each blade set down at its root and
    lifted while moving (a taper to a hair), leaning and curving, in clumps of uneven
    height; a dark green first, then a few darker blades of umber among them."""
    clumps = ((0.05, 9, 0.09), (0.17, 5, 0.05), (0.36, 10, 0.1), (0.52, 4, 0.045),
              (0.7, 6, 0.06), (0.94, 8, 0.08))
    for colour, share in (({"Phthalo Green": 0.5, "Burnt Umber": 0.5, "Hansa Yellow": 0.15},
                           1.0), ({"Burnt Umber": 0.8, "French Ultramarine": 0.35}, 0.4)):
        s.brush(size=1.6 * c, water=0.7, pigment=colour, kind="rigger")
        for i, (x, n, tall) in enumerate(clumps):
            for j in range(max(2, int(n * share))):
                u = (j + 0.5) / n - 0.5
                x0 = x + 0.05 * u + 0.005 * math.sin(3.0 * i + 5.0 * j)
                base = _bank_top(x0) + 0.05 + 0.012 * ((i + j) % 2)
                hgt = tall * (0.55 + 0.45 * abs(math.sin(2.1 * j + i + share)))
                lean = 0.6 * u * hgt + 0.01 * math.sin(1.7 * j + i)
                s.curve([(x0, base), (x0 + 0.2 * lean, base - 0.5 * hgt),
                         (x0 + lean, base - hgt)], 0.1 + 0.02 * (j % 2),
                        pressure=taper(0.7, 0.7, 0.0, attack=0.03, release=0.8))


def _ink(s: Script, c: float) -> None:
    """Ink: a slender tree standing on the bank's high end (the picture's focal point),
    three birds."""
    s.profile("ink")
    _tree(s, c, foot=(0.8, _bank_top(0.8) + 0.06), height=0.42)
    s.brush(size=0.7 * c, water=0.4, pigment={"Sumi Ink": 0.55})
    for bx, by, w in ((0.3, 0.2, 0.03), (0.37, 0.245, 0.022), (0.25, 0.265, 0.017)):
        s.arc((bx - w / 2, by), (w / 2, w / 3), 200.0, 340.0, 0.2,
              pressure=taper(0.6, 0.2, 0.1))
        s.arc((bx + w / 2, by), (w / 2, w / 3), 200.0, 340.0, 0.2,
              pressure=taper(0.6, 0.1, 0.2))


def landscape(width: int = DEMO_WIDTH, height: int = DEMO_HEIGHT,
              parts: Sequence[str] | None = None) -> Script:
    """The demo session (see the module docstring); ``parts`` paints only the named
    stages in order (``sky``, ``mountains``, ``hills``, ``lake``, ``foreground``,
    ``ink``), for working on one."""
    s = Script(width, height, profile="watercolor", seed=DEMO_SEED, device="demo-0",
               rate_hz=60.0)
    c = width / 100.0  # brush sizes below are in % of the canvas width
    stages = {"sky": _sky, "mountains": _mountains, "hills": _hills, "lake": _lake,
              "foreground": _foreground, "ink": _ink}
    for name in (parts if parts is not None else stages):
        stages[name](s, c)
    s.wait(3.0)
    s.dry()
    return s


def main(argv: list[str] | None = None) -> int:
    """Regenerate the committed demo session (or write it to ``argv[0]``)."""
    args = sys.argv[1:] if argv is None else argv
    target = Path(args[0]) if args else DEMO_FILE
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(landscape().text(), encoding="utf-8", newline="\n")
    print(target)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
