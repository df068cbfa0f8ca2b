"""look-b's measurements of brush-painted strokes (issue 21 items 3, 4, 5, 8).

Every canvas here is painted from pen samples through the brush by the session player,
at painter speeds; nothing is injected. Run ``python tools/brush_look.py [names]``;
it prints JSON and writes PNGs under ``/tmp/brush_look``.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from station.backends.numpy_canvas import NumpyCanvas
from station.pictures.scenarios import distance_inside, run_until_dry
from station.render.km import linear_to_srgb
from station.render.png import write_png
from station.sim.player import SessionPlayer
from station.sim.script import Script, taper

OUT = Path("/tmp/brush_look")
PIG = "French Ultramarine"


def luma(rgb_linear: np.ndarray) -> np.ndarray:
    s = linear_to_srgb(np.clip(rgb_linear, 0.0, 1.0))
    return 0.2126 * s[..., 0] + 0.7152 * s[..., 1] + 0.0722 * s[..., 2]


def darkness(c: NumpyCanvas, blank: np.ndarray) -> np.ndarray:
    """1 - luma/luma_paper per cell (the blank canvas of the same seed is the paper)."""
    return 1.0 - luma(c.render()) / np.maximum(blank, 1e-6)


def paint(script: Script, w: int, h: int, seed: int = 7, paper: str | None = None,
          dry: bool = True, max_steps: int = 4000) -> tuple[NumpyCanvas, np.ndarray]:
    kw: dict[str, Any] = {"paper": paper} if paper else {}
    c = NumpyCanvas(w, h, seed=seed, **kw)
    blank = luma(c.render())
    pl = SessionPlayer(c, w, h)
    pl.play(script.records)
    if dry:
        run_until_dry(c, max_steps)
        c.dry()
    return c, blank


def save(name: str, rgb: np.ndarray, scale: int = 3,
         region: tuple[slice, slice] | None = None) -> None:
    OUT.mkdir(exist_ok=True)
    if region is not None:
        rgb = rgb[region]
    img = linear_to_srgb(np.clip(rgb, 0, 1))
    img = np.repeat(np.repeat(img, scale, 0), scale, 1)
    write_png(OUT / f"{name}.png", (img * 255 + 0.5).astype(np.uint8))


def rim(d: np.ndarray, painted: np.ndarray, interior_from: int = 7) -> dict[str, object]:
    dist = distance_inside(painted.astype(np.float32))
    inner = dist >= interior_from
    interior = float(d[inner].mean())
    rings = [float(d[dist == k].mean()) / interior for k in range(1, interior_from)]
    width = 0
    for r in rings:
        if r < 1.4:
            break
        width += 1
    return {"interior": interior, "rings": [round(r, 3) for r in rings], "band_width": width,
            "band_ratio": float(np.mean(rings[:max(width, 2)]))}


def edge_std(painted: np.ndarray, cols: slice) -> float:
    """Std [cells] of the top and bottom edges of a horizontal stroke (linear trend out)."""
    sub = painted[:, cols]
    has = sub.any(axis=0)
    x = np.arange(sub.shape[1])[has].astype(float)
    out = []
    for rows in (np.argmax(sub, axis=0), sub.shape[0] - 1 - np.argmax(sub[::-1], axis=0)):
        y = rows[has].astype(float)
        fit = np.polyval(np.polyfit(x, y, 1), x)
        out.append(float((y - fit).std()))
    return float(np.mean(out))


def edges() -> dict[str, object]:
    """Item 3: a loaded round-brush stroke on dry paper, dried."""
    w, h = 200, 64
    s = Script(w, h, seed=7, rate_hz=120.0)
    s.brush(size=24, water=0.8, pigment={PIG: 1.0})
    s.line((0.1, 0.5), (0.9, 0.5), 1.2, pressure=0.8)
    c, blank = paint(s, w, h)
    d = darkness(c, blank)
    painted = d > 0.03
    save("edges", c.render())
    save("edges-crop", c.render(), 8, (slice(14, 50), slice(60, 140)))
    out = rim(d, painted)
    out["edge_std"] = edge_std(painted, slice(40, 160))
    out["mean_darkness"] = float(d[painted].mean())
    return out


def taper_end() -> dict[str, object]:
    """Item 3: a stroke lifted while moving (pressure falling over the last 30 %)."""
    w, h = 200, 64
    s = Script(w, h, seed=7, rate_hz=120.0)
    s.brush(size=24, water=0.8, pigment={PIG: 1.0})
    s.line((0.1, 0.5), (0.9, 0.5), 0.6, pressure=taper(0.9, start=0.05, end=0.35))
    c, blank = paint(s, w, h)
    d = darkness(c, blank)
    painted = d > 0.03
    save("taper", c.render())
    cols = np.nonzero(painted.any(axis=0))[0]
    widths = painted.sum(axis=0)
    end = int(cols.max())
    return {"width_mid": int(widths[100]),
            "width_end": [int(widths[end - k]) for k in (0, 3, 6, 10, 15, 20, 30)]}


def bloom() -> dict[str, object]:
    """Item 4: clear water dropped into a damp wash."""
    w, h = 128, 96
    s = Script(w, h, seed=7, rate_hz=120.0)
    s.brush(size=20, water=0.8, pigment={PIG: 0.6})
    for i in range(6):
        y = 0.2 + 0.12 * i
        a, b = ((0.1, y), (0.9, y)) if i % 2 == 0 else ((0.9, y), (0.1, y))
        s.line(a, b, 0.5, pressure=0.8, gap=0.05)
    s.pause(6.0)
    s.brush(size=14, water=1.0, pigment={})
    s.dab((0.5, 0.5), duration=0.3, pressure=0.8)
    c, blank = paint(s, w, h, max_steps=6000)
    d = darkness(c, blank)
    save("bloom", c.render())
    yy, xx = np.mgrid[0:h, 0:w]
    cx, cy = 0.5 * w, 0.5 * h
    r = np.hypot(xx - cx + 0.5, yy - cy + 0.5)
    ang = np.arctan2(yy - cy + 0.5, xx - cx + 0.5)
    wash = float(np.median(d[(r > 30) & (r < 40)]))
    radii = []
    fronts = []
    for k in range(36):
        a = -np.pi + (k + 0.5) * 2 * np.pi / 36
        sel = (np.abs(np.angle(np.exp(1j * (ang - a)))) < np.pi / 36) & (r < 35)
        rr, dd = r[sel], d[sel]
        order = np.argsort(rr)
        rr, dd = rr[order], dd[order]
        i = int(np.argmax(dd))
        radii.append(float(rr[i]))
        fronts.append(float(dd[i]))
    radii_a = np.array(radii)
    return {"wash": wash, "front_ratio": float(np.mean(fronts) / max(wash, 1e-6)),
            "radius_mean": float(radii_a.mean()),
            "radius_cv": float(radii_a.std() / max(radii_a.mean(), 1e-6))}


def drybrush() -> dict[str, object]:
    """Item 5: the round brush, little water, dragged fast."""
    w, h = 200, 64
    s = Script(w, h, seed=7, rate_hz=120.0)
    s.brush(size=24, water=0.15, pigment={PIG: 1.0})
    s.line((0.1, 0.5), (0.9, 0.5), 0.25, pressure=0.6)
    c, blank = paint(s, w, h)
    d = darkness(c, blank)
    save("drybrush", c.render())
    save("drybrush-crop", c.render(), 8, (slice(14, 50), slice(60, 140)))
    painted = d > 0.03
    env = np.zeros_like(painted)
    rows = np.nonzero(painted[:, 40:160].any(axis=1))[0]
    env[rows.min():rows.max() + 1, 40:160] = True
    bare = 1.0 - painted[env].mean()
    m = painted[rows.min():rows.max() + 1, 40:160].astype(float)
    m -= m.mean()

    def corr_len(a: np.ndarray, axis: int) -> float:
        var = float((a * a).mean())
        if var <= 0:
            return 0.0
        for lag in range(1, 40):
            x = np.take(a, range(lag, a.shape[axis]), axis=axis)
            y = np.take(a, range(0, a.shape[axis] - lag), axis=axis)
            if float((x * y).mean()) / var < np.exp(-1):
                return lag - 1 + 0.5
        return 40.0
    dark = float(d[painted & env].mean()) if (painted & env).any() else 0.0
    return {"bare": float(bare), "corr_along": corr_len(m, 1), "corr_across": corr_len(m, 0),
            "painted_mean": dark}


ALL = {"edges": edges, "taper": taper_end, "bloom": bloom, "drybrush": drybrush}

def zigzag(gap: float = 0.3) -> dict[str, object]:
    """Item 8: a wash laid in zig-zag rows, each over the lower edge of the previous,
    half-dry row (a painter's graded wash): the darkest line between rows over the wash."""
    w, h = 160, 96
    s = Script(w, h, seed=7, rate_hz=120.0)
    s.brush(size=20, water=0.8, pigment={PIG: 0.6})
    ys = [0.15 + 0.13 * k for k in range(6)]
    for k, y in enumerate(ys):
        a, b = ((0.1, y), (0.9, y)) if k % 2 == 0 else ((0.9, y), (0.1, y))
        s.line(a, b, 0.8, pressure=0.8, gap=gap)
    c, blank = paint(s, w, h, max_steps=6000)
    d = darkness(c, blank)
    save(f"zigzag-{gap:g}", c.render())
    inner = d[int(ys[0] * h):int(ys[-1] * h), 30:130]
    wash = float(np.median(inner))
    rows = inner.mean(axis=1)
    return {"wash": wash, "darkest_row_over_wash": float(rows.max() / wash),
            "p99_over_wash": float(np.percentile(inner, 99) / wash)}


ALL["zigzag"] = zigzag
ALL["zigzag-halfdry"] = lambda: zigzag(3.0)


if __name__ == "__main__":
    names = sys.argv[1:] or list(ALL)
    res = {}
    for n in names:
        t0 = time.time()
        res[n] = ALL[n]()
        res[n]["seconds"] = round(time.time() - t0, 1)
        print(n, json.dumps(res[n]), flush=True)
