"""The effects sheet's tiles painted through the brush (issue 21): value range, glazing,
paper texture, edges, dry-brush from the round brush, step artefacts."""

from __future__ import annotations

import colorsys
import itertools

import numpy as np

from station.backends.numpy_canvas import NumpyCanvas
from station.brush.stamp import BrushModel
from station.pictures.effects_core import (
    DARK_PIGMENTS,
    PALE_PIGMENTS,
    PEN_HZ,
    REAL_MASSTONE_HUE,
    Effect,
    _played,
    _row_mask,
    darkness_map,
    delta_e76,
    hue_deg,
    lab_hue_deg,
    luma,
    new_canvas,
)
from station.pictures.measure import EdgeBand, edge_band
from station.render.km import linear_to_srgb
from station.sim.player import SessionPlayer
from station.sim.script import Script, taper

VALUE_W, VALUE_H = 72, 60
TINT_AMOUNT = 0.03
"""The control's pale end: a brush amount of 3 % of tube strength."""


def _value_canvas(pigment: str, profile: str = "watercolor") -> NumpyCanvas:
    """Three strokes of one pigment, each 50 cells long in 0.45 s (110 cells/s) at
    pressure 0.7 with a size-12 round brush: a tint (amount 0.03), a full-strength pass
    (amount 1), and a full-strength pass laid again over itself once it has dried."""
    s = Script(VALUE_W, VALUE_H, profile=profile, seed=11, rate_hz=PEN_HZ)
    rows = (0.2, 0.5, 0.8)
    for row, amount in zip(rows, (TINT_AMOUNT, 1.0, 1.0), strict=True):
        s.brush(size=12, water=0.8, pigment={pigment: amount})
        s.line((0.15, row), (0.85, row), 0.45, pressure=0.7)
        s.wait(0.3)
    s.wait(45.0)  # the paper dries before the second pass
    s.dry()
    s.line((0.15, rows[2]), (0.85, rows[2]), 0.45, pressure=0.7)
    return _played(s)


def value_stats(c: NumpyCanvas) -> tuple[float, float, float, float]:
    """Mean darkness of the tint, the full pass and the double pass of
    :func:`_value_canvas`, and the HSV hue [deg] of the full pass's mean sRGB colour."""
    d = darkness_map(c)
    x0, x1 = int(0.25 * VALUE_W), int(0.75 * VALUE_W)
    rgb = c.render()
    out = []
    for row in (0.2, 0.5, 0.8):
        m = _row_mask(c, int(row * VALUE_H), 4, x0, x1)
        out.append(float(d[m].mean()))
    full = _row_mask(c, int(0.5 * VALUE_H), 4, x0, x1)
    hue = colorsys.rgb_to_hsv(*(float(v) for v in linear_to_srgb(rgb[full].mean(axis=0))))[0]
    return out[0], out[1], out[2], 360.0 * hue


def _hue_off(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def value_range(pigments: tuple[str, ...] = (
        "French Ultramarine", "Burnt Umber", "Sepia", "Quinacridone Rose", "Cerulean Blue",
        "Phthalo Green", "Hookers Green", "Indian Red", "Cadmium Red", "Brilliant Orange",
        "Hansa Yellow")) -> Effect:
    """Item 2: a pale tint to a full-strength pass per pigment, two passes darker than one;
    item 6: the full-strength pass's hue against the real pigment's masstone."""
    numbers: dict[str, float] = {}
    checks: dict[str, bool] = {}
    canvases = []
    for name in (*pigments, "Sumi Ink"):
        c = _value_canvas(name, "ink" if name == "Sumi Ink" else "watercolor")
        canvases.append(c)
        tint, full, two, hue = value_stats(c)
        key = name.lower().replace(" ", "_")
        numbers.update({f"{key}_tint": tint, f"{key}_full": full, f"{key}_two_passes": two})
        floor = 0.35 if name in DARK_PIGMENTS else 0.0 if name in PALE_PIGMENTS else 0.20
        checks[f"{name} tint <= 0.08"] = tint <= 0.08
        if floor:
            checks[f"{name} full >= {floor:.2f}"] = full >= floor
        checks[f"{name} two passes darker"] = two >= full + 0.03
        if name in REAL_MASSTONE_HUE:
            numbers[f"{key}_hue_deg"] = hue
            checks[f"{name} hue within 10 deg"] = _hue_off(hue, REAL_MASSTONE_HUE[name]) <= 10
    return Effect("value range (brush)", numbers, checks,
                  np.concatenate([c.render() for c in canvases], axis=1), tuple(canvases))


def brush_glazing() -> Effect:
    """Item 6 through the brush: a Cerulean Blue stroke, left to dry, a new layer, then a
    Hansa Yellow stroke over it; against one stroke of the two pigments mixed on the brush
    (the same amounts). Each stroke 50 cells long in 0.45 s, size 16, pressure 0.7.

    Cerulean, not Ultramarine: PB29's absorption band takes the 500-550 nm window a glaze
    needs, so Hansa Yellow over real French Ultramarine reads olive (its hue is reported,
    ``ultramarine_glaze_hue_srgb_deg``); cerulean over a yellow is the painter's green."""
    # yellow 0.6 parts: a glaze a painter would lay over a mid blue (0.5 read as a thin
    # yellow veil once the rim took its share of the yellow to the stroke's edge)
    blue, yellow = 0.8, 0.6

    def canvas(mixed: bool, name: str = "Cerulean Blue") -> NumpyCanvas:
        s = Script(VALUE_W, 36, seed=12, rate_hz=PEN_HZ)
        if mixed:
            s.brush(size=16, water=0.8, pigment={name: blue, "Hansa Yellow": yellow})
            s.line((0.15, 0.5), (0.85, 0.5), 0.45, pressure=0.7)
        else:
            s.brush(size=16, water=0.8, pigment={name: blue})
            s.line((0.15, 0.5), (0.85, 0.5), 0.45, pressure=0.7)
            s.wait(45.0)
            s.dry()
            s.new_layer()
            s.brush(size=16, water=0.8, pigment={"Hansa Yellow": yellow})
            s.line((0.15, 0.5), (0.85, 0.5), 0.45, pressure=0.7)
        return _played(s, paper="hot-press")

    glaze, mixed = canvas(False), canvas(True)
    x0, x1 = int(0.3 * VALUE_W), int(0.7 * VALUE_W)
    g = glaze.render()[_row_mask(glaze, 18, 3, x0, x1)].mean(axis=0)
    m = mixed.render()[_row_mask(mixed, 18, 3, x0, x1)].mean(axis=0)
    de = delta_e76(g, m)
    hue = hue_deg(linear_to_srgb(g))
    ug = canvas(False, "French Ultramarine")
    u = ug.render()[_row_mask(ug, 18, 3, x0, x1)].mean(axis=0)
    return Effect("glazing (brush)", {"delta_e76_glaze_vs_mix": de, "glaze_hue_srgb_deg": hue,
                                      "glaze_hue_lab_deg": lab_hue_deg(g),
                                      "ultramarine_glaze_hue_srgb_deg":
                                          hue_deg(linear_to_srgb(u)),
                                      "mix_hue_srgb_deg": hue_deg(linear_to_srgb(m))},
                  {"dE76 >= 5": de >= 5.0, "glaze reads green (90-160)": 90 <= hue <= 160},
                  np.concatenate([glaze.render(), mixed.render()], axis=0), (glaze, mixed))


WASH = 96
SPECTRUM_WASH = 128
"""The paper tile's washes: a 96x104-cell window inside (9 Welch tiles of 48 cells), where
white noise reads a spectral peak of 1.09-1.29 (60 draws); the 64x72 window of a
:data:`WASH` canvas (2 tiles) reads 1.0-1.75 on white noise and cannot hold a 1.5 floor."""


def flat_wash(pigment: str, amount: float, paper: str | None = None,
              seed: int = 13, size: int = WASH) -> NumpyCanvas:
    """A flat wash as a painter lays one on a ``size``-square sheet: a size-24 brush,
    loaded (water 1), pulled across the sheet at 173 cells/s, row under row 10 cells apart
    so each stroke takes up the bead the last one left, then the sheet dries on its own."""
    s = Script(size, size, seed=seed, rate_hz=PEN_HZ,
               extra={"paper": paper} if paper is not None else None)
    s.brush(size=24, water=1.0, pigment={pigment: amount})
    for k in range((size - 16) // 10 + 1):
        y = (8 + 10 * k) / size
        a, b = ((0.05, y), (0.95, y)) if k % 2 == 0 else ((0.95, y), (0.05, y))
        s.line(a, b, 0.5 * size / WASH, pressure=0.7)
        s.wait(0.2)
    return _played(s, seed=seed)


def radial_spectrum(img: np.ndarray, tile: int = 48, per_octave: int = 4
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Radially averaged power spectrum of ``img`` (Welch: Hann-windowed ``tile``-square
    patches overlapping by half, averaged): band centres [cycles/cell] and mean power,
    ``per_octave`` bands per octave from 4 cycles per tile to the Nyquist frequency."""
    a = np.asarray(img, np.float64)
    win = np.outer(np.hanning(tile), np.hanning(tile))
    acc = np.zeros((tile, tile))
    n = 0
    for y in range(0, a.shape[0] - tile + 1, tile // 2):
        for x in range(0, a.shape[1] - tile + 1, tile // 2):
            t = a[y:y + tile, x:x + tile]
            acc += np.abs(np.fft.fft2((t - t.mean()) * win)) ** 2
            n += 1
    p = acc / max(n, 1)
    f = np.hypot(np.fft.fftfreq(tile)[:, None], np.fft.fftfreq(tile)[None, :])
    edges = 2.0 ** np.arange(np.log2(4.0 / tile), np.log2(0.5) + 1e-9, 1.0 / per_octave)
    centres = np.sqrt(edges[:-1] * edges[1:])
    power = np.array([p[(f >= lo) & (f < hi)].mean() for lo, hi in itertools.pairwise(edges)])
    return centres, power


def spectral_peak(img: np.ndarray | list[np.ndarray]) -> tuple[float, float]:
    """The strongest peak of the radial power spectrum (of one image, or averaged over
    several: independent washes, as a spectrum analyser averages sweeps): its power over
    the geometric mean of its neighbours half an octave away on either side (a bump above
    the local power-law trend; white or 1/f noise ~ 1.1), and its wavelength [cells]."""
    imgs = img if isinstance(img, list) else [img]
    spectra = [radial_spectrum(a) for a in imgs]
    f = spectra[0][0]
    p = np.mean([s[1] for s in spectra], axis=0)
    r = p[2:-2] / np.sqrt(p[:-4] * p[4:])
    i = int(np.argmax(r))
    return float(r[i]), float(1.0 / f[2 + i])


PAPER_SEEDS = (13, 14)
"""The papers each of the paper tile's washes is painted on; its spectrum is the average."""


def paper_texture() -> Effect:
    """Item 7: a flat wash of a granulating pigment (French Ultramarine) and of a staining,
    non-granulating one (Quinacridone Rose), both brushed on cold-press: the texture's
    spectrum (no peak), the granulating wash's luminance spread at 1:1; the same Ultramarine
    wash on hot-press and on rough paper (papers are data, chosen per canvas). Each wash is
    painted on a :data:`SPECTRUM_WASH` sheet on the :data:`PAPER_SEEDS` papers; the
    spectrum is their average, the other numbers the first's."""
    numbers: dict[str, float] = {}
    checks: dict[str, bool] = {}
    canvases = []
    inner = (slice(16, SPECTRUM_WASH - 16), slice(12, SPECTRUM_WASH - 12))
    for key, pig, amount, paper in (("ultramarine", "French Ultramarine", 0.7, None),
                                    ("rose", "Quinacridone Rose", 0.5, None),
                                    ("ultramarine_hot_press", "French Ultramarine", 0.7,
                                     "hot-press"),
                                    ("ultramarine_rough", "French Ultramarine", 0.7, "rough")):
        washes = [flat_wash(pig, amount, paper, seed, SPECTRUM_WASH) for seed in PAPER_SEEDS]
        c = washes[0]
        canvases.append(c)
        lums = [luma(w.render())[inner] for w in washes]
        dark = float(darkness_map(c)[inner].mean())
        peak, wavelength = spectral_peak(lums)
        numbers.update({f"{key}_darkness": dark,
                        f"{key}_luma_std_8bit": float(lums[0].std()) * 255,
                        f"{key}_spectrum_peak": peak, f"{key}_peak_wavelength_cells": wavelength})
    numbers["papers_averaged"] = float(len(PAPER_SEEDS))
    checks["granulating wash dark (>= 0.3)"] = numbers["ultramarine_darkness"] >= 0.3
    checks["granulation visible (std >= 8/255)"] = numbers["ultramarine_luma_std_8bit"] >= 8.0
    checks["broadband on cold-press (peak <= 1.5x)"] = max(
        numbers["ultramarine_spectrum_peak"], numbers["rose_spectrum_peak"]) <= 1.5
    checks["broadband on hot-press and rough"] = max(
        numbers["ultramarine_hot_press_spectrum_peak"],
        numbers["ultramarine_rough_spectrum_peak"]) <= 1.5
    checks["papers differ (rough > hot-press)"] = (numbers["ultramarine_rough_luma_std_8bit"]
                                                   > numbers["ultramarine_hot_press_luma_std_8bit"])
    return Effect("paper (brush)", numbers, checks,
                  np.concatenate([c.render() for c in canvases], axis=1), tuple(canvases))


# ------------------------------------------------------------------ look-b's effects, measured
# through the brush (issue 21 items 3, 4, 5, 8): the sheet measures, the physics is look-b's.

def _envelope(shape: tuple[int, int], a: tuple[float, float], b: tuple[float, float],
              radius: float) -> np.ndarray:
    """Cells within ``radius`` of the pen path from ``a`` to ``b`` (cell coordinates)."""
    y, x = np.mgrid[0:shape[0], 0:shape[1]] + 0.5
    ax, ay, bx, by = a[0], a[1], b[0], b[1]
    dx, dy = bx - ax, by - ay
    t = np.clip(((x - ax) * dx + (y - ay) * dy) / max(dx * dx + dy * dy, 1e-9), 0.0, 1.0)
    return np.asarray(np.hypot(x - ax - t * dx, y - ay - t * dy) <= radius)


def edge_position_std(dark: np.ndarray, cols: slice, top: bool = True) -> float:
    """Standard deviation [cells] of a horizontal stroke's edge along ``cols``: per column
    the sub-cell row where darkness first crosses half the stroke's median (linear
    interpolation between cells), a linear trend removed. A ruler edge gives ~0."""
    d = dark[:, cols] if top else dark[::-1, cols]
    level = 0.5 * float(np.median(d[d > 0.02])) if (d > 0.02).any() else 0.01
    rows = []
    for j in range(d.shape[1]):
        col = d[:, j]
        k = int(np.argmax(col >= level))
        if col[k] < level or k == 0:
            continue
        rows.append(k - 1 + (level - col[k - 1]) / max(col[k] - col[k - 1], 1e-9))
    if len(rows) < 8:
        return 0.0
    r = np.array(rows)
    xs = np.arange(len(r))
    return float((r - np.polyval(np.polyfit(xs, r, 1), xs)).std())


RIM_STROKE = ("French Ultramarine", 32, 0.8, 0.6)
"""The sheet's stroke for item 3: pigment, brush size, water, amount."""
PAINTER_STROKES = (
    ("French Ultramarine", 12, 0.8, 0.6),
    ("Burnt Umber", 20, 1.0, 0.8),
    ("French Ultramarine", 26, 1.0, 0.8),
    ("Quinacridone Rose", 16, 0.5, 0.3),
    ("Burnt Umber", 32, 0.6, 0.5),
    ("Quinacridone Rose", 26, 0.8, 0.6),
)
"""Strokes a painter lays (sizes 12-32, amounts 0.3-0.8, water 0.5-1; the kiosk's default
stroke is the third): the rim must read on every one of them, not on one setting."""


def rim_interior(size: int) -> int:
    """Cells from a stroke's edge where its interior starts for the rim measure: 6, or a
    fifth of the brush size on small brushes (a size-12 stroke is about 10 cells across,
    so its interior starts 3 cells in)."""
    return max(3, min(6, size // 5))


def stroke_rim(pigment: str, size: int, water: float, amount: float
               ) -> tuple[EdgeBand, EdgeBand, NumpyCanvas]:
    """One wet-on-dry stroke through the round brush (92 cells in 0.7 s, pressure tapering
    off as the pen lifts while moving) dried on its own: its rim on the darkness (the
    issue's measure: rings from the painted edge over the interior) and on the deposited
    pigment ``q`` (the model's own: the Kubelka-Munk render saturates, so a ``q`` ratio of
    1.6 reads as a darkness ratio of about 1.45)."""
    w, h = 120, 56
    s = Script(w, h, seed=21, rate_hz=PEN_HZ)
    s.brush(size=size, water=water, pigment={pigment: amount})
    s.line((0.12, 0.5), (0.88, 0.5), 0.7, pressure=taper(0.75, start=0.4, end=0.05))
    c = _played(s)
    inner = rim_interior(size)
    dark = edge_band(darkness_map(c), threshold=1.4, interior_from=inner, deposit=0.03)
    q = edge_band(c.live_state.q.sum(axis=0), threshold=1.4, interior_from=inner)
    return dark, q, c


def _rings(band: EdgeBand, n: int = 2) -> tuple[float, ...]:
    return tuple(band.ring_ratio[k] if len(band.ring_ratio) > k else 0.0 for k in range(n))


def brush_edges() -> Effect:
    """Item 3: one wet-on-dry stroke of a size-32 round brush (Ultramarine 0.6, water 0.8,
    :func:`stroke_rim`) dried on its own. Numbers: the rim on the darkness (rings from the
    painted edge over the interior; the checks), the same on the deposited pigment
    (``rim_q_*``), the edge position's std along the stroke (sub-cell), and the end's
    length over the stroke's half-width (a semicircle: 1)."""
    band, qband, c = stroke_rim(*RIM_STROKE)
    dark = darkness_map(c)
    std = 0.5 * (edge_position_std(dark, slice(35, 85)) +
                 edge_position_std(dark, slice(35, 85), top=False))
    painted = dark > 0.03
    widths = painted.sum(axis=0)
    half = 0.5 * float(np.median(widths[35:85]))
    cols = np.nonzero(widths)[0]
    tip = int(cols.max()) if cols.size else 0
    full = int(np.nonzero(widths >= 0.9 * 2 * half)[0].max()) if (widths >= 1.8 * half).any() \
        else tip
    cap = (tip - full) / max(half, 1e-6)
    r1, r2 = _rings(band)
    q1, q2 = _rings(qband)
    return Effect("edges (brush)", {"rim_width_cells": band.width, "rim_ratio": band.ratio,
                                    "rim_ring1": r1, "rim_ring2": r2,
                                    "rim_q_width_cells": qband.width,
                                    "rim_q_ratio": qband.ratio,
                                    "rim_q_ring1": q1, "rim_q_ring2": q2,
                                    "edge_position_std_cells": std,
                                    "end_length_over_half_width": cap},
                  {"rim 2-5 cells": 2 <= band.width <= 5, "rim >= 1.4x": band.ratio >= 1.4,
                   "edge follows the tooth (std >= 0.3)": std >= 0.3,
                   "tapered end (> 1.5 half-widths)": cap > 1.5},
                  c.render(), (c,))


def round_dry_brush() -> Effect:
    """Item 5: the ordinary round brush (size 20) with little water (0.1), Ultramarine 1,
    dragged 100 cells in 0.15 s at pressure 0.5 over rough paper: bare paper inside the
    stroke's envelope, the painted cells' darkness, streaks (correlation length along the
    stroke over across it)."""
    w, h = 128, 40
    s = Script(w, h, seed=24, rate_hz=PEN_HZ, extra={"paper": "rough"})
    s.brush(size=20, water=0.1, pigment={"French Ultramarine": 1.0})
    s.line((0.1, 0.5), (0.9, 0.5), 0.15, pressure=0.5)
    c = _played(s, seed=24)
    r = BrushModel().radius(20, 0.5)
    env = _envelope((h, w), (0.2 * w, 0.5 * h), (0.8 * w, 0.5 * h), 0.8 * r)
    dark = darkness_map(c)
    painted = dark > 0.03
    bare = float(1.0 - painted[env].mean())
    mean_dark = float(dark[env & painted].mean()) if (env & painted).any() else 0.0
    sub = painted[int(0.5 * h - 0.6 * r):int(0.5 * h + 0.6 * r) + 1, int(0.2 * w):int(0.8 * w)]
    ratio = _corr_length(sub.astype(np.float64), 1) / max(_corr_length(sub.astype(np.float64),
                                                                         0), 1e-6)
    return Effect("round dry-brush (brush)", {"bare_share": bare, "painted_darkness": mean_dark,
                                              "streak_along_over_across": ratio},
                  {"bare >= 25 %": bare >= 0.25, "painted visible (>= 0.20)": mean_dark >= 0.2,
                   "streaks (along >= 2x across)": ratio >= 2.0},
                  c.render(), (c,))


def _corr_length(a: np.ndarray, axis: int) -> float:
    """Lag [cells] at which the autocorrelation of ``a`` along ``axis`` falls below 1/e."""
    a = a - a.mean()
    var = float((a * a).mean())
    if var <= 0:
        return 0.0
    for lag in range(1, a.shape[axis] // 2):
        x = np.take(a, range(a.shape[axis] - lag), axis=axis)
        y = np.take(a, range(lag, a.shape[axis]), axis=axis)
        if float((x * y).mean()) / var < np.exp(-1.0):
            return float(lag)
    return float(a.shape[axis] // 2)


STEP_W, STEP_H = 400, 48
"""The step-artefact tile's canvas: 320 measured cells, 16 periods of the step length."""
STEP_LEN = 20
"""Cells of pen travel per simulation step on the fast stroke (600 cells/s at 30 steps/s)."""
STEP_SEEDS = {"wet": (1, 2, 3), "dry": tuple(range(1, 49))}
"""Papers each stroke is painted on. The dry stroke breaks up on the paper's tooth and its
column sums vary 1-6 % at any one frequency on one paper, so it needs more of them (the
mean over N papers has a noise floor of about 2.5 % / sqrt(N): 24 papers measured 0.0050,
at the check, once the dry-brush gaps were drawn out along the stroke; 48 give 0.0041)."""


def _step_spectrum(seed: int, water: float, speed: float, steps: int = 64
                   ) -> tuple[np.ndarray, NumpyCanvas]:
    """A size-40 stroke of Burnt Umber pulled at ``speed`` cells/s across a
    :data:`STEP_W` canvas on paper ``seed``, ``steps`` steps after it starts: its pigment
    (in the water and deposited) summed across the stroke, columns 40-360; the Fourier
    coefficients over the mean (complex: a step artefact's phase is locked to the
    stroke, the paper's texture is not), and the canvas."""
    s = Script(STEP_W, STEP_H, seed=seed, rate_hz=PEN_HZ)
    s.brush(size=40, water=water, pigment={"Burnt Umber": 0.6})
    s.line((0.02, 0.5), (0.98, 0.5), 0.96 * STEP_W / speed, pressure=0.7)
    c = new_canvas(STEP_W, STEP_H, seed=seed)
    p = SessionPlayer(c, STEP_W, STEP_H)
    p.play(s.records)
    while p.counters.steps < steps:
        p.step()
    st = c.live_state
    prof = (st.q.sum(axis=0) + st.p.sum(axis=0)).sum(axis=0)[40:360].astype(np.float64)
    out: np.ndarray = np.fft.rfft(prof - prof.mean()) / len(prof) * 2 / max(prof.mean(), 1e-9)
    return out, c


def step_artefacts(seeds: dict[str, tuple[int, ...]] | None = None) -> Effect:
    """Item 8: a wide (size 40) stroke pulled fast, :data:`STEP_LEN` cells of pen travel
    per simulation step (600 cells/s at 30 steps/s), wet (water 0.9) and dry (0.15): the
    share of its along-stroke variation at the step length (the Fourier amplitude at
    1/20 cycles per cell over the mean), the complex coefficient averaged over several
    papers (``seeds``, by default :data:`STEP_SEEDS`). The noise floor it reports is the
    same bin of a slow stroke measured the same way (200 cells/s: its steps 6.7 cells
    apart, so the 20-cell bin holds no step of its own), and the median of the fast
    stroke's other bins.
    One paper and 160 cells, as this tile measured before, read 1.5 % on the slow stroke:
    it could not resolve 1 %. The picture: the first paper's fast strokes, 64 steps (2.1 s)
    after they start."""
    out: dict[str, float] = {}
    canvases = []
    k = (360 - 40) // STEP_LEN
    for key, water in (("wet", 0.9), ("dry", 0.15)):
        papers = (seeds or STEP_SEEDS)[key]
        runs = [_step_spectrum(sd, water, 600.0) for sd in papers]
        fast = np.abs(np.mean([r[0] for r in runs], axis=0))
        slow = np.abs(np.mean([_step_spectrum(sd, water, 200.0)[0] for sd in papers], axis=0))
        out[f"step_component_{key}"] = float(fast[k])
        out[f"noise_floor_{key}"] = float(slow[k])
        out[f"other_bins_median_{key}"] = float(np.median(np.r_[fast[3:k - 2], fast[k + 3:80]]))
        out[f"papers_{key}"] = float(len(papers))
        canvases.append(runs[0][1])  # the picture: the first paper's fast stroke, still wet
    return Effect("step artefacts (brush)", out,
                  {"wet <= 1 %": out["step_component_wet"] <= 0.01,
                   "dry <= 1 %": out["step_component_dry"] <= 0.01,
                   "floor resolves 1 % (< 0.5 %)": max(out["noise_floor_wet"],
                                                       out["noise_floor_dry"]) < 0.005},
                  np.concatenate([c.render() for c in canvases], axis=0), tuple(canvases))


SKY_W, SKY_H, SKY_ROWS, SKY_GAP, SKY_TOP = 800, 240, 6, 31.0, 40.0
"""The kiosk visitor's sky (``tools/kiosk_screenshots.py``) in cells: a strip as wide as the
kiosk's canvas, six rows ``SKY_GAP`` apart from ``SKY_TOP`` down."""
SKY_SECONDS = 8.0
"""The visitor's drag through all six rows [s]: about 550 cells/s along a row, so at a
column the next row comes 0-2.7 s after the last (the turns alternate sides)."""


def sky_rows_script(seed: int = 0) -> Script:
    """The kiosk visitor's wet sky: brush size 72, water 1, French Ultramarine and Cerulean
    Blue at the kiosk's strength 0.8, one drag back and forth through ``SKY_ROWS`` rows
    (each with the visitor's 0.01-high wobble), pressure 0.5 (a fast mouse)."""
    s = Script(SKY_W, SKY_H, seed=seed, rate_hz=PEN_HZ)
    s.brush(size=72, water=1.0, pigment={"French Ultramarine": 0.4, "Cerulean Blue": 0.4})
    pts: list[tuple[float, float]] = []
    n = 40
    for r in range(SKY_ROWS):
        y = SKY_TOP + SKY_GAP * r
        us = [0.04 + 0.92 * k / (n - 1) for k in range(n)]
        pts += [(u, (y + 6.0 * np.sin(7 * u)) / SKY_H) for u in (us if r % 2 == 0 else us[::-1])]
    s.curve(pts, SKY_SECONDS, pressure=0.5)
    return s


def sky_banding(rgb: np.ndarray, c: NumpyCanvas) -> dict[str, float]:
    """Bands across the rows of a dried sky (:func:`sky_rows_script`): per row of cells the
    mean darkness over the middle 60 % of the columns (each column's profile shifted by the
    rows' wobble, so a line that follows the pen stays one row), between the first and the
    last row's paths. ``row_contrast``: the darkest over the palest row there, after a
    31-cell running mean is divided out (1.0: an even wash); ``row_period_share``: the
    profile's Fourier amplitude at the rows' spacing over its mean (the lines' regularity)."""
    lum = luma(rgb)
    st = c.live_state
    bare = (st.q.sum(axis=0) + st.p.sum(axis=0)) <= 1e-5
    d = 1.0 - lum / float(lum[bare].mean())
    x0, x1 = int(0.2 * SKY_W), int(0.8 * SKY_W)
    shifted = np.empty((SKY_H, x1 - x0))
    for j, x in enumerate(range(x0, x1)):
        off = 6.0 * np.sin(7 * x / SKY_W)
        shifted[:, j] = np.interp(np.arange(SKY_H) + off, np.arange(SKY_H), d[:, x])
    prof = shifted.mean(axis=1)
    y0, y1 = int(SKY_TOP), int(SKY_TOP + SKY_GAP * (SKY_ROWS - 1)) + 1
    k = int(SKY_GAP)
    pad = np.pad(prof, k, mode="edge")
    run = np.convolve(pad, np.ones(k) / k, mode="same")[k:-k]
    rel = prof[y0:y1] / np.maximum(run[y0:y1], 1e-6)
    seg = prof[y0:y1] - prof[y0:y1].mean()
    t = np.arange(len(seg))
    amp = 2.0 * abs(np.sum(seg * np.exp(-2j * np.pi * t / SKY_GAP))) / len(seg)
    return {"row_contrast": float(rel.max() / rel.min()),
            "row_period_share": float(amp / max(prof[y0:y1].mean(), 1e-9)),
            "sky_darkness": float(prof[y0:y1].mean())}
