"""The bundled demo: a small watercolor landscape, scripted as pen input.

:func:`landscape` writes, with the station's own scripted pen
(:mod:`station.sim.script`), a session that shows what the canvas model does:

1. **wet-in-wet sky** — a clear-water wash over the sky, then Cerulean Blue and
   French Ultramarine (both granulating, γ > 0) and a touch of Quinacridone
   Rose dropped into it while wet: they spread with soft, feathered edges;
2. **distant hills** — a violet mix laid wet-on-dry on the dried sky: the
   strokes keep hard, **dark edges**;
3. **glazed hills** — nearer hills in Cerulean Blue, dried, a new layer, then
   a Hansa Yellow **glaze** over them: blue under yellow reads green;
4. **foreground** — Burnt Umber with French Ultramarine, granulating in the
   paper's valleys, and a pond laid wet-on-dry with much water whose rim
   darkens as it dries;
5. **ink** — a profile switch to ``ink`` for a tree, grass and birds in Sumi Ink.

The committed ``station/data/demo/landscape.jsonl`` is exactly
``landscape().text()``; regenerate it with ``python -m station.sim.demo``
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


def _ridge(x: float, base: float, amp: float, phase: float, waves: float) -> float:
    """Height (y, normalised, down) of a hill line at ``x``."""
    return base - amp * (0.6 * math.sin(2 * math.pi * (waves * x + phase))
                         + 0.4 * math.sin(2 * math.pi * (2.3 * waves * x + 1.7 * phase)))


def _fill_hill(s: Script, base: float, amp: float, phase: float, waves: float, bottom: float,
               rows: int, size_px: float, duration: float, lean: float) -> None:
    """A hill: a stroke along its ridge, then back-and-forth strokes below it."""
    xs = [i / 8 for i in range(9)]
    ridge = [(max(0.0, min(1.0, x)), _ridge(x, base, amp, phase, waves)) for x in xs]
    s.curve(ridge, duration, pressure=taper(0.85, 0.5, 0.5), tilt=tilt_const(lean, 10.0))
    for r in range(1, rows + 1):
        f = r / rows
        pts = [(x, _ridge(x, base, amp, phase, waves) + f * (bottom - base + amp) * 0.9)
               for x in xs]
        if r % 2 == 0:
            pts.reverse()
        s.curve(pts, duration, pressure=taper(0.9, 0.6, 0.6), tilt=tilt_const(-lean, 8.0))


def _tree(s: Script, cells: float, foot: tuple[float, float], height: float, lean: float,
          scale: float) -> None:
    """An ink tree: a tapering trunk, curved branches, twigs at their ends."""
    fx, fy = foot
    top = (fx + lean, fy - height)
    s.brush(size=2.2 * cells * scale, water=0.5, pigment={"Sumi Ink": 0.8})
    s.curve([foot, (fx - 0.005, fy - 0.35 * height), (fx + 0.008 + lean * 0.5, fy - 0.7 * height),
             top], 0.9 * scale + 0.2, pressure=taper(1.0, 0.9, 0.15, release=0.4),
            tilt=tilt_const(-10.0, 30.0))
    s.brush(size=1.1 * cells * scale, water=0.5, pigment={"Sumi Ink": 0.75})
    for k, (at, side, length, rise) in enumerate(((0.45, -1, 0.11, 0.06), (0.55, 1, 0.12, 0.07),
                                                 (0.7, -1, 0.08, 0.07), (0.78, 1, 0.09, 0.06),
                                                 (0.88, -1, 0.05, 0.05))):
        bx = fx + lean * at + 0.004 * math.sin(9.0 * at)
        by = fy - at * height
        dx, dy = side * length * scale, -rise * scale
        end = (bx + dx, by + dy)
        s.curve([(bx, by), (bx + 0.5 * dx, by + 0.2 * dy), end], 0.3,
                pressure=taper(0.9, 0.8, 0.1, release=0.5))
        for t in (-1, 1):  # two twigs fanning from the branch end
            tw = (end[0] + 0.025 * scale * (side + 0.6 * t), end[1] - 0.03 * scale * (1 + k % 2))
            s.line(end, tw, 0.12, pressure=taper(0.6, 0.6, 0.05, attack=0.05, release=0.7))


def _blow_dry(s: Script, seconds: float) -> None:
    """A hair dryer over the whole sheet for ``seconds`` of painting time, then ``dry``
    for what is left: the paint dries by evaporation (rims, backruns), only faster."""
    s.cmd("hairdryer", x=0.5, y=0.5, radius=500, seconds=seconds)
    s.wait(seconds)
    s.dry()


def landscape(width: int = DEMO_WIDTH, height: int = DEMO_HEIGHT) -> Script:
    """The demo session (see the module docstring)."""
    s = Script(width, height, profile="watercolor", seed=DEMO_SEED, device="demo-0",
               rate_hz=60.0)
    cells = width / 100.0  # brush sizes below are in % of the canvas width

    # 1. Wet-in-wet sky: clear water first, then colour dropped into the wet wash.
    s.brush(size=16 * cells, water=1.0, pigment={})
    for i in range(6):
        y = 0.05 + i * 0.085
        a, b = (0.0, y), (1.0, y + 0.01)
        s.line(a, b, 0.55, pressure=taper(0.95, 0.8, 0.8), tilt=tilt_const(20.0, 15.0))
    s.brush(size=11 * cells, water=0.6, pigment={"Cerulean Blue": 0.6})
    for i in range(4):
        y = 0.07 + i * 0.07
        s.curve([(0.02, y + 0.03), (0.25, y), (0.55, y + 0.035), (0.8, y - 0.01), (0.98, y + 0.02)],
                0.7, pressure=swell(0.45, 0.95, 1.5 + 0.5 * i),
                tilt=tilt_sweep((25.0, 10.0), (-10.0, 20.0)))
    s.brush(size=9 * cells, water=0.5, pigment={"French Ultramarine": 0.8})
    s.line((0.0, 0.02), (1.0, 0.04), 0.5, pressure=taper(0.95))
    s.curve([(0.0, 0.1), (0.12, 0.05), (0.3, 0.02)], 0.35, pressure=taper(0.9))
    s.curve([(1.0, 0.12), (0.85, 0.06), (0.65, 0.03)], 0.35, pressure=taper(0.9))
    s.brush(size=7 * cells, water=0.6, pigment={"Quinacridone Rose": 0.4})
    for x in (0.15, 0.42, 0.7, 0.9):
        s.curve([(x - 0.08, 0.36), (x, 0.34), (x + 0.08, 0.37)], 0.3, pressure=taper(0.7))
    _blow_dry(s, 12.0)
    s.new_layer()

    # 2. Distant hills, wet-on-dry on the dried sky: hard, dark edges.
    s.brush(size=6 * cells, water=0.7,
            pigment={"French Ultramarine": 0.45, "Quinacridone Rose": 0.25})
    _fill_hill(s, base=0.47, amp=0.06, phase=0.1, waves=1.2, bottom=0.56, rows=3,
               size_px=6 * cells, duration=0.8, lean=15.0)
    _blow_dry(s, 12.0)
    s.new_layer()

    # 3. Nearer hills in granulating Cerulean Blue, dried, then a yellow glaze.
    s.brush(size=8 * cells, water=0.8, pigment={"Cerulean Blue": 0.7})
    _fill_hill(s, base=0.62, amp=0.05, phase=0.55, waves=0.9, bottom=0.8, rows=5,
               size_px=8 * cells, duration=0.7, lean=-20.0)
    _blow_dry(s, 12.0)
    s.new_layer()
    s.brush(size=12 * cells, water=0.8, pigment={"Hansa Yellow": 0.6})
    for i in range(5):
        y = 0.6 + i * 0.07
        a, b = ((0.0, y), (1.0, y + 0.02)) if i % 2 == 0 else ((1.0, y + 0.02), (0.0, y))
        s.line(a, b, 0.6, pressure=taper(0.95, 0.7, 0.7), tilt=tilt_const(0.0, 25.0))
    _blow_dry(s, 10.0)
    s.new_layer()

    # 4. Foreground: granulating earth, wet-on-dry.
    s.brush(size=7 * cells, water=0.8,
            pigment={"Burnt Umber": 0.6, "French Ultramarine": 0.3})
    for i in range(4):
        y = 0.85 + i * 0.045
        pts = [(x / 6, y + 0.015 * math.sin(3.0 * x + i)) for x in range(7)]
        if i % 2:
            pts.reverse()
        s.curve(pts, 0.8, pressure=swell(0.5, 1.0, 2.0), tilt=tilt_const(30.0, 5.0))
    _blow_dry(s, 12.0)

    # A pond laid wet-on-dry with plenty of water: left to dry, its rim darkens.
    s.brush(size=3.5 * cells, water=1.0,
            pigment={"Phthalo Green": 0.35, "French Ultramarine": 0.5})
    for i in range(5):
        y = 0.845 + i * 0.013
        half = 0.16 * math.sqrt(max(0.0, 1.0 - ((y - 0.87) / 0.04) ** 2))
        a, b = (0.3 - half, y), (0.3 + half, y)
        s.line(a if i % 2 == 0 else b, b if i % 2 == 0 else a, 0.5, pressure=0.85)
    _blow_dry(s, 14.0)

    # 5. Ink: a tree, grass and birds.
    s.profile("ink")
    _tree(s, cells, foot=(0.78, 0.9), height=0.44, lean=-0.01, scale=1.0)
    _tree(s, cells, foot=(0.915, 0.72), height=0.2, lean=0.01, scale=0.55)
    s.brush(size=0.8 * cells, water=0.5, pigment={"Sumi Ink": 0.55})
    for i, x in enumerate((0.05, 0.2, 0.36, 0.52, 0.63, 0.9)):
        base = 0.99 - 0.01 * (i % 2)
        for j in range(5):
            lean = (j - 2) * 0.012 + 0.004 * math.sin(5.0 * i + j)
            hgt = 0.06 + 0.025 * ((i + 2 * j) % 3)
            s.curve([(x + 0.003 * j, base), (x + 0.003 * j + lean * 0.3, base - hgt * 0.5),
                     (x + 0.003 * j + lean, base - hgt)], 0.15,
                    pressure=taper(0.8, 0.8, 0.02, attack=0.05, release=0.8))
    s.brush(size=0.9 * cells, water=0.4, pigment={"Sumi Ink": 0.7})
    for bx, by, w in ((0.3, 0.15, 0.035), (0.38, 0.2, 0.025), (0.24, 0.22, 0.02)):
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
