"""The bundled demo: a watercolor landscape, scripted as pen input.

:func:`landscape` writes, with the station's own scripted pen
(:mod:`station.sim.script`), a session that uses what the canvas model does
(issue 10 item 9: the demo beside the effects sheet):

1. **wet-in-wet sky** — a clear-water wash, then French Ultramarine and
   Cerulean Blue (both granulating) graded from the top, and a warm glow of
   Quinacridone Rose and Hansa Yellow dropped in at the horizon; clouds are
   **lifted** with a crumpled tissue while the wash is wet;
2. **distant mountains** — a violet mix laid **wet-on-dry** on the dried sky
   (hard, **dark edges**), fading into mist; clean water touched into the
   half-dry wash makes two **blooms** (backruns) with dark fringes;
3. **hills** — Cerulean Blue with Phthalo Green and Burnt Umber dropped in
   wet, dried, then a Hansa Yellow **glaze** over most of them on a new layer;
4. **lake** — a blue wash with wavy edges, then quick, nearly dry strokes of
   the deformable tuft over it: **dry-brush** glints;
5. **foreground** — Burnt Umber with French Ultramarine, **granulating** in
   the paper's valleys;
6. **ink** — a profile switch to ``ink`` for a tree, grass and birds in Sumi Ink.

The committed ``station/data/demo/landscape.jsonl`` is exactly
``landscape().text()``; regenerate it with ``python -m station.pictures.demo``
(a test checks the two are equal).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

from station.sim.script import Script, swell, taper, tilt_const, tilt_sweep

DEMO_WIDTH, DEMO_HEIGHT = 400, 300
DEMO_SEED = 11
DEMO_FILE = Path(__file__).resolve().parent.parent / "data" / "demo" / "landscape.jsonl"


def _ridge(x: float, base: float, amp: float, phase: float, waves: float,
           sharp: float = 0.0) -> float:
    """Height (y, normalised, down) of a hill line at ``x``; ``sharp`` adds crags."""
    v = (0.6 * math.sin(2 * math.pi * (waves * x + phase))
         + 0.4 * math.sin(2 * math.pi * (2.3 * waves * x + 1.7 * phase)))
    if sharp:
        v += sharp * (abs(math.sin(2 * math.pi * (3.1 * waves * x + 0.3 * phase))) - 0.5)
    return base - amp * v


def _fill(s: Script, base: float, amp: float, phase: float, waves: float, bottom: float,
          rows: int, duration: float, lean: float, sharp: float = 0.0,
          fade: float = 0.0) -> None:
    """A hill: a stroke along its ridge, then back-and-forth strokes below it, pressed
    more lightly towards the bottom by ``fade`` (a wash graded into mist)."""
    xs = [i / 12 for i in range(13)]
    ridge = [(x, _ridge(x, base, amp, phase, waves, sharp)) for x in xs]
    s.curve(ridge, duration, pressure=taper(0.85, 0.5, 0.5), tilt=tilt_const(lean, 10.0))
    for r in range(1, rows + 1):
        f = r / rows
        pts = [(x, _ridge(x, base, amp, phase, waves, sharp) + f * (bottom - base + amp) * 0.9)
               for x in xs]
        if r % 2 == 0:
            pts.reverse()
        p = 0.9 * (1.0 - fade * f)
        s.curve(pts, duration, pressure=taper(p, 0.6 * p, 0.6 * p), tilt=tilt_const(-lean, 8.0))


def _tree(s: Script, cells: float, foot: tuple[float, float], height: float) -> None:
    """An ink tree: a tapering trunk, curved branches, two twigs at each end."""
    fx, fy = foot
    s.brush(size=2.2 * cells, water=0.5, pigment={"Sumi Ink": 0.85})
    s.curve([foot, (fx - 0.006, fy - 0.35 * height), (fx + 0.006, fy - 0.7 * height),
             (fx - 0.01, fy - height)], 1.1, pressure=taper(0.95, 0.9, 0.1, release=0.45),
            tilt=tilt_const(-10.0, 30.0))
    s.brush(size=1.1 * cells, water=0.5, pigment={"Sumi Ink": 0.8})
    branches = ((0.42, -1, 0.12, 0.06), (0.52, 1, 0.12, 0.08), (0.66, -1, 0.09, 0.07),
                (0.76, 1, 0.09, 0.06), (0.87, -1, 0.06, 0.05))
    for k, (at, side, length, rise) in enumerate(branches):
        bx, by = fx - 0.004 * at, fy - at * height
        dx, dy = side * length, -rise
        end = (bx + dx, by + dy)
        s.curve([(bx, by), (bx + 0.5 * dx, by + 0.25 * dy), end], 0.35,
                pressure=taper(0.9, 0.8, 0.05, release=0.6))
        for t in (-1, 1):
            tw = (end[0] + 0.025 * (side + 0.6 * t), end[1] - 0.03 * (1 + k % 2))
            s.line(end, tw, 0.15, pressure=taper(0.7, 0.6, 0.02, attack=0.05, release=0.7))


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


def landscape(width: int = DEMO_WIDTH, height: int = DEMO_HEIGHT) -> Script:
    """The demo session (see the module docstring)."""
    s = Script(width, height, profile="watercolor", seed=DEMO_SEED, device="demo-0",
               rate_hz=60.0)
    c = width / 100.0  # brush sizes below are in % of the canvas width

    # 1. Sky: clear water, a graded wet-in-wet wash, a warm glow at the horizon, and
    #    clouds lifted with a tissue while it is wet.
    s.brush(size=16 * c, water=1.0, pigment={})
    for i in range(6):
        y = 0.04 + i * 0.08
        s.line((0.0, y), (1.0, y + 0.01), 0.55, pressure=taper(0.95, 0.8, 0.8),
               tilt=tilt_const(20.0, 15.0))
    s.brush(size=10 * c, water=0.5, pigment={"French Ultramarine": 0.8, "Cerulean Blue": 0.3})
    s.curve([(0.0, 0.03), (0.3, 0.05), (0.6, 0.02), (1.0, 0.05)], 0.6, pressure=taper(0.95))
    s.brush(size=10 * c, water=0.6, pigment={"Cerulean Blue": 0.7})
    for i in range(3):
        y = 0.1 + i * 0.065
        s.curve([(0.0, y + 0.02), (0.3, y), (0.6, y + 0.03), (1.0, y)], 0.6,
                pressure=swell(0.4 - 0.08 * i, 0.9 - 0.15 * i, 1.3 + 0.4 * i),
                tilt=tilt_sweep((25.0, 10.0), (-10.0, 20.0)))
    s.brush(size=8 * c, water=0.6, pigment={"Quinacridone Rose": 0.35, "Hansa Yellow": 0.25})
    for y in (0.33, 0.38):
        s.curve([(0.0, y), (0.35, y + 0.01), (0.7, y - 0.01), (1.0, y)], 0.6,
                pressure=taper(0.7))
    for k, (x, y) in enumerate(((0.2, 0.14), (0.27, 0.17), (0.62, 0.1), (0.7, 0.13),
                                (0.77, 0.11))):
        s.cmd("tissue", kind="crepe", scale=8, size=14 * c, absorb=1.0, seed=k, x=x, y=y)
    _blow_dry(s, 12.0)
    s.new_layer()

    # 2. Distant mountains, wet-on-dry, graded into mist; clean water touched into the
    #    half-dry wash blooms.
    s.brush(size=6 * c, water=0.7, pigment={"French Ultramarine": 0.5,
                                             "Quinacridone Rose": 0.25, "Burnt Umber": 0.1})
    _fill(s, 0.38, 0.07, 0.1, 1.3, 0.5, 5, 0.8, 15.0, sharp=0.5, fade=0.6)
    # the wash loses its shine (no standing water, the paper still damp) before the
    # water goes in: only then does it run back into the wash as a backrun
    s.wait(25.0)  # measured: the standing water is gone at 25-28 s, the paper 85-95 % full
    s.brush(size=4 * c, water=1.0, pigment={})
    for x, y in ((0.18, 0.42), (0.63, 0.4)):
        s.dab((x, y), 0.35, pressure=0.8)
    _blow_dry(s, 14.0)
    s.new_layer()

    # 3. Hills: Cerulean Blue with green and umber dropped in wet; dried; a yellow glaze.
    s.brush(size=8 * c, water=0.8, pigment={"Cerulean Blue": 0.7})
    _fill(s, 0.55, 0.04, 0.55, 0.9, 0.66, 3, 0.7, -20.0)
    s.brush(size=5 * c, water=0.6, pigment={"Phthalo Green": 0.4, "Burnt Umber": 0.3})
    for x in (0.12, 0.4, 0.85):
        s.curve([(x - 0.07, 0.62), (x, 0.6), (x + 0.07, 0.63)], 0.3, pressure=taper(0.7))
    _blow_dry(s, 12.0)
    s.new_layer()
    s.brush(size=7 * c, water=0.8, pigment={"Hansa Yellow": 0.6})
    for x0, x1, y in ((0.0, 0.45, 0.6), (0.05, 0.38, 0.63), (0.52, 1.0, 0.59),
                      (0.6, 0.95, 0.625), (0.3, 0.7, 0.645)):
        s.curve(_wavy(x0, x1, y, 0.012, 5.0, 7 * x0, 6), 0.5, pressure=swell(0.4, 0.95, 1.0),
                tilt=tilt_const(0.0, 25.0))
    _blow_dry(s, 10.0)
    s.new_layer()

    # 4. The lake: a wash with wavy edges, then dry-brush glints of the deformable tuft.
    s.brush(size=6 * c, water=0.8, pigment={"French Ultramarine": 0.4, "Cerulean Blue": 0.3})
    for i in range(3):
        pts = _wavy(0.02, 0.98, 0.685 + i * 0.03, 0.008, 2.7 * 8, 2 * i)
        s.curve(pts[::-1] if i % 2 else pts, 0.7, pressure=swell(0.6, 0.9, 1.5 + i))
    _blow_dry(s, 10.0)
    s.brush(size=6 * c, water=0.2, pigment={"French Ultramarine": 1.0}, kind="round3d")
    for i in range(3):
        y = 0.695 + i * 0.028
        s.line((0.05 + 0.1 * i, y), (0.9 - 0.05 * i, y + 0.005), 0.18, pressure=0.5,
               tilt=(30.0, 0.0))
    _blow_dry(s, 6.0)
    s.new_layer()

    # 5. Foreground: granulating earth, wet-on-dry.
    s.brush(size=7 * c, water=0.8, pigment={"Burnt Umber": 0.6, "French Ultramarine": 0.3})
    for i in range(4):
        y = 0.8 + i * 0.05
        pts = [(x / 6, y + 0.015 * math.sin(3.0 * x + i)) for x in range(7)]
        s.curve(pts[::-1] if i % 2 else pts, 0.8, pressure=swell(0.5, 1.0, 2.0),
                tilt=tilt_const(30.0, 5.0))
    _blow_dry(s, 12.0)

    # 6. Ink: a tree, grass and birds.
    s.profile("ink")
    _tree(s, c, foot=(0.8, 0.92), height=0.45)
    s.brush(size=0.8 * c, water=0.5, pigment={"Sumi Ink": 0.55})
    for i, x in enumerate((0.05, 0.14, 0.3, 0.45, 0.58, 0.92)):
        base = 0.99 - 0.01 * (i % 2)
        for j in range(5):
            lean = (j - 2) * 0.012 + 0.004 * math.sin(5.0 * i + j)
            hgt = 0.06 + 0.025 * ((i + 2 * j) % 3)
            x0 = x + 0.003 * j
            s.curve([(x0, base), (x0 + lean * 0.3, base - hgt * 0.5), (x0 + lean, base - hgt)],
                    0.15, pressure=taper(0.8, 0.8, 0.02, attack=0.05, release=0.8))
    s.brush(size=0.9 * c, water=0.4, pigment={"Sumi Ink": 0.7})
    for bx, by, w in ((0.3, 0.2, 0.035), (0.38, 0.25, 0.025), (0.24, 0.27, 0.02)):
        s.arc((bx - w / 2, by), (w / 2, w / 3), 200.0, 340.0, 0.2, pressure=0.6)
        s.arc((bx + w / 2, by), (w / 2, w / 3), 200.0, 340.0, 0.2, pressure=0.6)
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
