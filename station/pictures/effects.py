"""The effects sheet (issue 10 item 9): paint each watercolour effect on a small canvas,
measure it, and compare the number with the issue's threshold.

Every tile only adds water/pigment sources, steps the simulation and applies the canvas
tools (dry, new layer, pickup, hair dryer); the numbers come from
:mod:`station.pictures.measure` and from colour science on the rendered reflectance.
:func:`run_effects` returns one :class:`Effect` per tile; ``station effects`` prints them
as JSON and draws the sheet. A tile whose number misses its threshold says so (``ok``
false): the sheet reports, it does not pretend.
"""

from __future__ import annotations

import colorsys
import dataclasses
import itertools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import ndimage

from station.backends.numpy_canvas import NumpyCanvas
from station.brush.stamp import BrushModel
from station.canvas.palette import Palette, Pigment, default_palette
from station.canvas.params import SimParams
from station.canvas.profiles import get_profile
from station.canvas.removal import HairDryer, blow, pickup
from station.pictures.measure import bare_share, edge_band, edge_roughness, edge_width, spread
from station.pictures.scenarios import disc, distance_inside, paint, rect, run_until_dry
from station.render.km import linear_to_srgb, to_linear_rgb
from station.render.upscale import render_scaled
from station.sim.player import SessionPlayer
from station.sim.script import Script, taper

F32 = np.float32


@dataclass
class Effect:
    """One tile: its name, the measured numbers, the checks against the issue's thresholds
    (``{check: passed}``), and the rendered tile (linear RGB, float32 (H, W, 3))."""

    name: str
    numbers: dict[str, float]
    checks: dict[str, bool]
    image: np.ndarray = field(repr=False)
    canvases: tuple[NumpyCanvas, ...] = field(default=(), repr=False)
    """The painted canvases behind ``image`` (left to right), for :meth:`picture`."""
    row: str = "brush"
    """``brush``: painted by pen samples through a brush (the measure, issue 21);
    ``physics``: water and pigment written into the canvas as rectangles (the model's
    physics alone, never the measure)."""

    @property
    def ok(self) -> bool:
        return all(self.checks.values())

    def picture(self, k: int) -> np.ndarray:
        """The tile at ``k`` pixels per cell (linear RGB): the canvases drawn by the
        sub-cell renderer (smooth contours, paper grain), or ``image`` enlarged when the
        tile keeps no canvas."""
        if k == 1 or not self.canvases:
            return np.repeat(np.repeat(self.image, k, 0), k, 1)
        pics = [render_scaled(c.state(), get_profile(c.state().profile).renderer, k)
                for c in self.canvases]
        # long strips one above the other, the rest side by side: the sheet stays compact
        wide = pics[0].shape[1] >= 2 * pics[0].shape[0]
        return np.concatenate(pics, axis=0 if wide else 1)

    def to_json(self) -> dict[str, Any]:
        return {"row": self.row, "numbers": {k: round(v, 4) for k, v in self.numbers.items()},
                "checks": {k: bool(v) for k, v in self.checks.items()}, "ok": self.ok}


# ------------------------------------------------------------------ colour science
_M = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722],
               [0.0193, 0.1192, 0.9505]])
_WHITE = _M.sum(axis=1)


def lab(rgb: np.ndarray) -> np.ndarray:
    """CIELAB (D65) of linear sRGB reflectance (..., 3)."""
    xyz = np.asarray(rgb, np.float64) @ _M.T / _WHITE
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.stack([116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]),
                     200 * (f[..., 1] - f[..., 2])], axis=-1)


def delta_e76(a: np.ndarray, b: np.ndarray) -> float:
    """CIE76 colour difference of two linear sRGB colours."""
    return float(np.linalg.norm(lab(a) - lab(b)))


def hue_deg(rgb: np.ndarray) -> float:
    """Hue angle (HSV, degrees) of a linear sRGB colour: 120 is green, 60 yellow, 240 blue."""
    return colorsys.rgb_to_hsv(*(float(x) for x in rgb))[0] * 360.0


# ------------------------------------------------------------------ tiles
def _twin(a: str, b: str, **diff: tuple[float, float]) -> Palette:
    hg = default_palette().get("French Ultramarine")  # its colour, RGB and spectral

    def one(name: str, i: int) -> Pigment:
        pr = {"beta": 2.0, "gamma": 0.0, "delta": 0.5, **{k: v[i] for k, v in diff.items()}}
        return dataclasses.replace(hg, name=name, beta=pr["beta"], gamma=pr["gamma"],
                                   delta=pr["delta"])

    return Palette([one(a, 0), one(b, 1)])


def _layer(c: NumpyCanvas, fp: np.ndarray, pigs: dict[str, float], water: float = 0.5) -> None:
    paint(c, fp, water, pigs)
    run_until_dry(c, 6000)
    c.dry()


def edge_darkening() -> Effect:
    c = NumpyCanvas(96, 64, seed=1)
    fp = rect(64, 96, 12, 52, 10, 86)
    _layer(c, fp, {"French Ultramarine": 0.25}, water=0.6)
    q = c.live_state.q[0]
    band = edge_band(q)
    rough = edge_roughness(q, slice(20, 76))
    return Effect("edge darkening", {"band_width_cells": band.width, "band_ratio": band.ratio,
                                     "edge_roughness_cells": rough},
                  {"band 3-6 cells": 3 <= band.width <= 6, "band >= 1.4x": band.ratio >= 1.4,
                   "ragged edge": rough > 0.4}, c.render(), (c,))


def _drop(wait_s: float, wash: float) -> tuple[NumpyCanvas, np.ndarray]:
    c = NumpyCanvas(64, 64, seed=2)
    paint(c, rect(64, 64, 2, 62, 2, 62), wash)
    for _ in range(int(wait_s * 30)):
        c.step()
    fp = disc(64, 64, 32, 32, 6)
    paint(c, fp, 0.6, {"French Ultramarine": 0.8})
    run_until_dry(c, 6000)
    c.dry()
    return c, fp


def wet_in_wet(params: SimParams | None = None) -> Effect:
    """A stroke (an r = 5 stamp moving one cell per step, 40 steps) into a 2 s old wash
    (``params`` replace the watercolor profile's, for comparisons)."""
    c = NumpyCanvas(96, 64, seed=2, params=params)
    paint(c, rect(64, 96, 2, 62, 2, 94), 0.6)
    for _ in range(60):
        c.step()
    covered = np.zeros((64, 96), F32)
    for k in range(40):
        stamp = disc(64, 96, 32, 28 + k, 5)
        paint(c, stamp * (covered == 0), 0.6, {"French Ultramarine": 0.8})
        covered = np.maximum(covered, stamp)
        c.step()
    run_until_dry(c, 6000)
    c.dry()
    sp = spread(c.live_state.q[0], covered)
    return Effect("wet-in-wet", {"spread_area_ratio": sp.area_ratio, "feather": sp.feather},
                  {"spread >= 2x": sp.area_ratio >= 2.0, "feather >= 1.3": sp.feather >= 1.3},
                  c.render(), (c,))


def backrun() -> Effect:
    c, fp = _drop(16.0, 0.4)
    q = c.live_state.q[0]
    sp = spread(q, fp)
    fringe = edge_band(q, threshold=1.2, interior_from=3).ring_ratio[0]
    return Effect("backrun", {"feather": sp.feather, "fringe_ratio": fringe,
                              "spread_area_ratio": sp.area_ratio},
                  {"feather >= 1.3": sp.feather >= 1.3, "dark fringe": fringe > 1.2},
                  c.render(), (c,))


def granulation() -> Effect:
    c = NumpyCanvas(64, 64, seed=5)
    fp = rect(64, 64, 8, 56, 8, 56)
    _layer(c, fp, {"French Ultramarine": 0.3}, water=0.6)
    st = c.live_state
    inner = distance_inside(fp) >= 4
    r = float(np.corrcoef(st.q[0][inner], st.h[inner])[0, 1])
    # -0.5 on the first two-octave paper; the broadband one (issue 21 item 7) has relief
    # at scales a wash does not follow cell by cell: the visible measure is paper_texture's
    return Effect("granulation", {"corr_deposit_paper_height": r},
                  {"pigment in the valleys": r < -0.3}, c.render(), (c,))


def lab_hue_deg(rgb: np.ndarray) -> float:
    """CIELAB hue angle h_ab (degrees) of a linear sRGB colour (yellow ~ 100, green ~ 136)."""
    c = lab(rgb)
    return float(np.degrees(np.arctan2(c[2], c[1])) % 360.0)


def glazing(render_bands: int = 12) -> Effect:
    """Hansa Yellow (0.3 load) glazed over a dried Cerulean Blue wash (0.7) against both
    mixed in one layer; ``render_bands`` 3 renders with Curtis's RGB K, S. (French
    Ultramarine, fitted to PB29's violet-leaning hue, glazes olive: see brush_glazing.)"""
    fp = rect(40, 40, 6, 34, 6, 34)
    inner = distance_inside(fp) >= 4
    prm = SimParams(render_bands=render_bands)
    glaze = NumpyCanvas(40, 40, seed=6, paper="hot-press", params=prm)
    _layer(glaze, fp, {"Cerulean Blue": 0.7})
    glaze.new_layer()
    _layer(glaze, fp, {"Hansa Yellow": 0.3})
    mixed = NumpyCanvas(40, 40, seed=6, paper="hot-press", params=prm)
    _layer(mixed, fp, {"Cerulean Blue": 0.7, "Hansa Yellow": 0.3})
    g = glaze.render()
    m = mixed.render()
    gm = g[inner].mean(axis=0)
    de = delta_e76(gm, m[inner].mean(axis=0))
    hue = hue_deg(gm)
    return Effect("glazing", {"delta_e76_glaze_vs_mix": de, "glaze_hue_deg": hue,
                              "glaze_hue_srgb_deg": hue_deg(linear_to_srgb(gm)),
                              "glaze_hue_lab_deg": lab_hue_deg(gm)},
                  {"dE76 >= 5": de >= 5.0, "reads green (90-160)": 90.0 <= hue <= 160.0},
                  np.concatenate([g, m], axis=1), (glaze, mixed))


def staining_lifting() -> Effect:
    shares = {}
    images = []
    canvases: list[NumpyCanvas] = []
    for name in ("Cerulean Blue", "Phthalo Green"):
        c = NumpyCanvas(40, 40, seed=4)
        _layer(c, disc(40, 40, 20, 20, 12), {name: 0.2})
        st = c.live_state
        brush = disc(40, 40, 20, 20, 7)
        inside = float(st.q[0][brush > 0].sum(dtype=np.float64))
        taken = 0.0
        for _ in range(2):
            paint(c, brush, 0.3)
            for _ in range(15):
                c.step()
            taken += pickup(st, brush).pigment.get(name, 0.0)
        run_until_dry(c, 6000)
        c.dry()
        shares[name] = taken / inside
        images.append(c.render())
        canvases.append(c)
    lift, stain = shares["Cerulean Blue"], shares["Phthalo Green"]
    return Effect("staining vs lifting", {"lifted_cerulean": lift, "lifted_phthalo": stain},
                  {"non-staining >= 30 %": lift >= 0.3, "staining <= 10 %": stain <= 0.1},
                  np.concatenate(images, axis=1), tuple(canvases))


def density() -> Effect:
    pal = _twin("Heavy", "Light", delta=(0.9, 0.2))
    c = NumpyCanvas(48, 48, seed=4, palette=pal)
    paint(c, rect(48, 48, 8, 40, 8, 24), 0.6, {"Heavy": 0.3})
    paint(c, rect(48, 48, 8, 40, 24, 40), 0.6, {"Light": 0.3})
    for _ in range(60):
        c.step()
    st = c.live_state
    settled = [float(st.q[k].sum() / (st.q[k].sum() + st.p[k].sum())) for k in range(2)]
    return Effect("density", {"settled_heavy_2s": settled[0], "settled_light_2s": settled[1]},
                  {"heavy settles faster": settled[0] > 2.0 * settled[1]}, c.render(), (c,))


def wet_window() -> Effect:
    def wet_s(dryer: HairDryer | None) -> tuple[float, NumpyCanvas]:
        prm = SimParams()
        c = NumpyCanvas(48, 48, seed=2, params=prm)
        paint(c, rect(48, 48, 0, 48, 0, 48), 0.6, {"Cerulean Blue": 0.1})
        st = c.live_state
        n = 0
        while (st.w > 0).any() and n < 6000:
            if dryer is not None:
                blow(st, dryer, prm.dt)
            c.step()
            n += 1
        c.dry()
        return n * prm.dt, c

    still, c = wet_s(None)
    blown, _ = wet_s(HairDryer(cx=24, cy=24, radius=60))
    return Effect("wet window", {"wet_seconds": still, "with_hair_dryer_seconds": blown},
                  {"wet >= 30 s": still >= 30.0, "dryer speeds up": blown < 0.5 * still},
                  c.render(), (c,))


def gouache_over_dark() -> Effect:
    fp = rect(40, 40, 6, 34, 6, 34)
    c = NumpyCanvas(40, 40, seed=3, profile="gouache")
    _layer(c, fp, {"Black": 0.8})
    dark = c.render()[20, 20].copy()
    c.new_layer()
    _layer(c, rect(40, 40, 6, 34, 14, 26), {"Titanium White": 0.6}, water=0.4)
    cover = c.render()[20, 20]
    paper = c.render()[2, 2]
    lum = [float(lab(x)[0]) for x in (dark, cover, paper)]
    hide = (lum[1] - lum[0]) / max(lum[2] - lum[0], 1e-6)
    return Effect("gouache over dark", {"hiding_share": hide, "L_dark": lum[0],
                                        "L_gouache": lum[1]},
                  {"covers the dark": hide >= 0.8}, c.render(), (c,))


def ink_bleed(params: SimParams | None = None) -> Effect:
    """A stroke of Sumi ink on the ink profile's absorbent, fibrous paper (``params``
    replace the profile's, for comparisons)."""
    c = NumpyCanvas(64, 48, profile="ink", seed=3, params=params)
    fp = rect(48, 64, 20, 28, 8, 56)
    _layer(c, fp, {"Sumi Ink": 0.4}, water=0.6)
    sp = spread(c.live_state.q[0], fp)
    return Effect("ink bleed", {"spread_area_ratio": sp.area_ratio, "feather": sp.feather},
                  {"bleeds": sp.area_ratio >= 1.3, "feathered": sp.feather >= 1.3}, c.render(),
                  (c,))


def _scripted_stroke(profile: str, pigment: str, load: float, water: float, duration: float,
                     pressure: float, paper: str | None = None, width: int = 120,
                     height: int = 48) -> NumpyCanvas:
    """One horizontal stroke of the deformable round brush (the brush issue's tuft, its
    handle tilted 30 degrees along the motion), played by the session player like a pen,
    then dried."""
    s = Script(width, height, profile=profile, seed=7, rate_hz=200.0)
    s.brush(size=28, water=water, pigment={pigment: load}, kind="round3d")
    s.line((0.1, 0.5), (0.9, 0.5), duration, pressure=pressure, tilt=(30.0, 0.0))
    c = (NumpyCanvas(width, height, profile=profile, seed=7) if paper is None
         else NumpyCanvas(width, height, profile=profile, seed=7, paper=paper))
    SessionPlayer(c, width, height, profile).play(s.records)
    run_until_dry(c, 6000)
    c.dry()
    return c


def _painted(c: NumpyCanvas, deposit: float = 1e-3) -> np.ndarray:
    st = c.live_state
    return np.asarray((st.q.sum(axis=0) + st.p.sum(axis=0)) > deposit)


def dry_brush() -> Effect:
    """A quick, light stroke of a nearly dry, pigment-rich brush over rough paper: the
    tuft touches only the paper's hills and leaves bare paper between its marks; the same
    brush loaded with water and drawn slowly fills its whole trail."""
    dry = _scripted_stroke("watercolor", "French Ultramarine", 1.0, 0.2, 0.15, 0.6, "rough")
    wet = _scripted_stroke("watercolor", "French Ultramarine", 1.0, 0.9, 0.8, 0.7, "rough")
    bare_dry, bare_wet = bare_share(_painted(dry)), bare_share(_painted(wet))
    return Effect("dry-brush", {"bare_share_dry": bare_dry, "bare_share_wet": bare_wet},
                  {"flying white >= 20 %": bare_dry >= 0.2,
                   "a wet brush fills it (dry >= 3x bare)": bare_dry >= 3.0 * bare_wet},
                  np.concatenate([dry.render(), wet.render()], axis=0), (dry,))


def ink_flying_white() -> Effect:
    """Oriental ink: a loaded stroke is black; a fast, dry one shows the "flying white"
    (fei bai) of the paper through the bristle marks."""
    dry = _scripted_stroke("ink", "Sumi Ink", 1.0, 0.2, 0.15, 0.6)
    wet = _scripted_stroke("ink", "Sumi Ink", 1.0, 0.9, 0.8, 0.8)
    lum = lab(wet.render())[..., 0]
    painted = _painted(wet)
    dark = float(np.percentile(lum[painted], 10)) if painted.any() else 100.0
    bare = bare_share(_painted(dry))
    return Effect("ink flying white", {"L_loaded_p10": dark, "bare_share_dry": bare},
                  {"black (L* <= 30)": dark <= 30.0, "flying white >= 20 %": bare >= 0.2},
                  np.concatenate([dry.render(), wet.render()], axis=0), (dry, wet))


def wet_on_dry_edge() -> Effect:
    """The same band painted on dry paper and into a wet wash: wet-on-dry keeps a hard
    edge (the water stops where the paper is dry), wet-in-wet softens it. Widths are the
    10-90 % rise of the deposit across the band's long edges, averaged over its middle."""
    widths = []
    canvases = []
    for wash in (0.0, 0.6):
        c = NumpyCanvas(64, 48, seed=8)
        if wash:
            paint(c, rect(48, 64, 0, 48, 0, 64), wash)
            for _ in range(30):
                c.step()
        paint(c, rect(48, 64, 16, 32, 8, 56), 0.5, {"French Ultramarine": 0.4})
        run_until_dry(c, 6000)
        c.dry()
        q = c.live_state.q[0][:, 20:44].mean(axis=1)
        widths.append(0.5 * (edge_width(q[:24]) + edge_width(q[24:][::-1])))
        canvases.append(c)
    hard, soft = widths
    return Effect("wet-on-dry edge", {"edge_width_dry_cells": hard,
                                      "edge_width_wet_cells": soft},
                  {"hard edge <= 2 cells": hard <= 2.0,
                   "wet-in-wet >= 3x softer": soft >= 3 * hard},
                  np.concatenate([c.render() for c in canvases], axis=1), tuple(canvases))


def flow_patterns() -> Effect:
    """A wash at the top of a tilted sheet: the water runs downhill and carries the
    pigment with it in uneven runs; on a flat sheet the same wash stays where it was laid.
    Numbers: how far the deposit's centre moved down [cells], and how ragged the runs'
    lower front is (standard deviation of its row over the columns [cells])."""
    shift = []
    fronts = []
    canvases = []
    for tilt in (0.0, 8.0):
        c = NumpyCanvas(64, 64, seed=9)
        st = c.live_state
        st.params = st.params.replace(tilt=tilt, tilt_direction=90.0)
        fp = rect(64, 64, 6, 22, 6, 58)
        paint(c, fp, 0.8, {"Indian Red": 0.25})
        run_until_dry(c, 6000)
        c.dry()
        q = c.live_state.q.sum(axis=0)
        rows = np.arange(64, dtype=np.float64)[:, None]
        shift.append(float((q * rows).sum() / q.sum()) - 13.5)
        below = q[:, 10:54] > 1e-3
        low = 63 - np.argmax(below[::-1], axis=0)
        fronts.append(float(low.std()))
        canvases.append(c)
    return Effect("flow patterns", {"centre_shift_tilted_cells": shift[1],
                                    "centre_shift_flat_cells": shift[0],
                                    "front_roughness_cells": fronts[1]},
                  {"runs downhill": shift[1] >= shift[0] + 3.0,
                   "uneven runs": fronts[1] >= 1.0},
                  np.concatenate([c.render() for c in canvases], axis=1), tuple(canvases))


# ------------------------------------------------------------------ through the brush
# Issue 21: every number below comes from pen samples played through the brush by the
# session player, at a painter's speed (a wash stroke crosses the sheet in about half a
# second), pressure (0.6-0.8) and waits (the paper dries on its own before a second pass).
# No rectangle or mask is written into a canvas.

PEN_HZ = 120.0
"""Pen report rate of the scripted painter [samples/s] (a tablet reports 100-200)."""

LUMA = np.array([0.2126, 0.7152, 0.0722])
"""Rec. 709 weights, applied to sRGB-encoded values (as the issue measured the scans)."""

DARK_PIGMENTS = ("French Ultramarine", "Burnt Umber", "Sepia", "Sumi Ink")
PALE_PIGMENTS = ("Hansa Yellow", "Cadmium Yellow", "Titanium White", "Interference Lilac")
"""Whites, yellows and the interference white: no full-strength value floor."""

REAL_MASSTONE_HUE = {
    # HSV hue [deg] of the displayed sRGB of each pigment's full-strength watercolour
    # stroke: French Ultramarine's from the issue (a violet-leaning blue, 240-250); the
    # others approximate painted-swatch hues, not measurements (docs/canvas-model.md).
    "French Ultramarine": 245.0, "Cerulean Blue": 196.0, "Phthalo Green": 165.0,
    "Hookers Green": 110.0, "Quinacridone Rose": 336.0, "Cadmium Red": 8.0,
    "Indian Red": 12.0, "Burnt Umber": 25.0, "Sepia": 28.0, "Brilliant Orange": 28.0,
    "Hansa Yellow": 55.0, "Cadmium Yellow": 48.0,
}


def luma(rgb_linear: np.ndarray) -> np.ndarray:
    """Rec. 709 luma of the sRGB-encoded colour, in [0, 1]."""
    return np.asarray(linear_to_srgb(rgb_linear) @ LUMA)


def darkness_map(c: NumpyCanvas) -> np.ndarray:
    """1 - luma/luma_paper per cell; the paper's luma is the mean over unpainted cells."""
    st = c.live_state
    lum = luma(c.render())
    bare = (st.q.sum(axis=0) + st.p.sum(axis=0)) <= 1e-5
    paper = (float(lum[bare].mean()) if bare.any()
             else float(luma(to_linear_rgb(st.r_composed)).max()))
    return 1.0 - lum / paper


def _played(script: Script, paper: str | None = None, seed: int = 7) -> NumpyCanvas:
    """Play ``script`` through the brush on a fresh canvas (on the paper its header chose,
    as ``station paint`` does, else ``paper``, else the profile's), let it dry on its own,
    then fix the layer (the paper is dry: ``dry`` only deposits what is left)."""
    h = script.header
    paper = h.extra.get("paper", paper)
    c = (NumpyCanvas(h.width, h.height, profile=h.profile, seed=seed) if paper is None
         else NumpyCanvas(h.width, h.height, profile=h.profile, seed=seed, paper=paper))
    SessionPlayer(c, h.width, h.height, h.profile).play(script.records)
    run_until_dry(c, 6000)
    c.dry()
    return c


def _row_mask(c: NumpyCanvas, y: int, half: int, x0: int, x1: int) -> np.ndarray:
    """Cells of the stroke along row ``y``: within ``half`` rows of its path, between the
    columns ``x0:x1`` (the caps left out), where the stroke left pigment."""
    st = c.live_state
    dep = st.q.sum(axis=0) + st.p.sum(axis=0)
    m = np.zeros(dep.shape, bool)
    m[max(0, y - half):y + half + 1, x0:x1] = True
    inside = dep[m]
    return m & (dep > 0.05 * float(np.percentile(inside, 90))) if inside.size else m


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


def flat_wash(pigment: str, amount: float, paper: str | None = None,
              seed: int = 13) -> NumpyCanvas:
    """A flat wash as a painter lays one: a size-24 brush, loaded (water 1), pulled across
    the sheet in 0.5 s, row under row 10 cells apart so each stroke takes up the bead the
    last one left, then the sheet dries on its own."""
    s = Script(WASH, WASH, seed=seed, rate_hz=PEN_HZ,
               extra={"paper": paper} if paper is not None else None)
    s.brush(size=24, water=1.0, pigment={pigment: amount})
    for k in range(9):
        y = (8 + 10 * k) / WASH
        a, b = ((0.05, y), (0.95, y)) if k % 2 == 0 else ((0.95, y), (0.05, y))
        s.line(a, b, 0.5, pressure=0.7)
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


def spectral_peak(img: np.ndarray) -> tuple[float, float]:
    """The strongest peak of the radial power spectrum: its power over the geometric mean
    of its neighbours half an octave away on either side (a bump above the local power-law
    trend; white or 1/f noise ~ 1.1), and its wavelength [cells]."""
    f, p = radial_spectrum(img)
    r = p[2:-2] / np.sqrt(p[:-4] * p[4:])
    i = int(np.argmax(r))
    return float(r[i]), float(1.0 / f[2 + i])


def paper_texture() -> Effect:
    """Item 7: a flat wash of a granulating pigment (French Ultramarine) and of a staining,
    non-granulating one (Quinacridone Rose), both brushed on cold-press: the texture's
    spectrum (no peak), the granulating wash's luminance spread at 1:1; the same Ultramarine
    wash on hot-press and on rough paper (papers are data, chosen per canvas)."""
    numbers: dict[str, float] = {}
    checks: dict[str, bool] = {}
    canvases = []
    inner = (slice(16, WASH - 16), slice(12, WASH - 12))
    for key, pig, amount, paper in (("ultramarine", "French Ultramarine", 0.7, None),
                                    ("rose", "Quinacridone Rose", 0.5, None),
                                    ("ultramarine_hot_press", "French Ultramarine", 0.7,
                                     "hot-press"),
                                    ("ultramarine_rough", "French Ultramarine", 0.7, "rough")):
        c = flat_wash(pig, amount, paper)
        canvases.append(c)
        lum = luma(c.render())[inner]
        dark = float(darkness_map(c)[inner].mean())
        peak, wavelength = spectral_peak(lum)
        numbers.update({f"{key}_darkness": dark, f"{key}_luma_std_8bit": float(lum.std()) * 255,
                        f"{key}_spectrum_peak": peak, f"{key}_peak_wavelength_cells": wavelength})
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


def brush_edges() -> Effect:
    """Item 3: one wet-on-dry stroke of a size-32 round brush (Ultramarine 0.6, water 0.8),
    92 cells in 0.7 s, pressure tapering off as the pen lifts while moving; dried on its own.
    Numbers: the rim (rings from the deposit's edge over the interior), the edge position's
    std along the stroke (sub-cell), and the end's length over the stroke's half-width (a
    semicircle: 1)."""
    w, h = 120, 56
    s = Script(w, h, seed=21, rate_hz=PEN_HZ)
    s.brush(size=32, water=0.8, pigment={"French Ultramarine": 0.6})
    s.line((0.12, 0.5), (0.88, 0.5), 0.7, pressure=taper(0.75, start=0.4, end=0.05))
    c = _played(s)
    q = c.live_state.q.sum(axis=0)
    band = edge_band(q, threshold=1.4, interior_from=6)
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
    return Effect("edges (brush)", {"rim_width_cells": band.width, "rim_ratio": band.ratio,
                                    "rim_ring1": band.ring_ratio[0] if band.ring_ratio else 0.0,
                                    "edge_position_std_cells": std,
                                    "end_length_over_half_width": cap},
                  {"rim 2-5 cells": 2 <= band.width <= 5, "rim >= 1.4x": band.ratio >= 1.4,
                   "edge follows the tooth (std >= 0.3)": std >= 0.3,
                   "tapered end (> 1.5 half-widths)": cap > 1.5},
                  c.render(), (c,))


def _wash_then(first: Script, seed: int, until_damp: bool
               ) -> tuple[NumpyCanvas, SessionPlayer]:
    h = first.header
    c = NumpyCanvas(h.width, h.height, profile=h.profile, seed=seed)
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
    (cy, cx): along each of ``n`` rays the last cell still inside."""
    radii = []
    for a in np.linspace(0, 2 * np.pi, n, endpoint=False):
        r = 0.0
        for t in np.arange(0.5, max(region.shape), 0.5):
            y, x = int(cy + t * np.sin(a)), int(cx + t * np.cos(a))
            if not (0 <= y < region.shape[0] and 0 <= x < region.shape[1]) or not region[y, x]:
                break
            r = t
        radii.append(r)
    rr = np.array(radii)
    return float(rr.mean()), float(rr.std() / max(rr.mean(), 1e-9))


def blooms() -> Effect:
    """Item 4: (a) clear water dabbed (size 12, 0.3 s) into a brushed Ultramarine wash once
    its standing water is gone but the paper is still wet: the bloom's front over the wash's
    darkness, its radius CV; (b) a dab of Ultramarine (amount 1) into a fully wet clear
    wash: its spread over the brush radius, its peak darkness over the same dab on dry
    paper."""
    n = 80
    wash = Script(n, n, seed=22, rate_hz=PEN_HZ)
    wash.brush(size=24, water=1.0, pigment={"French Ultramarine": 0.4})
    for k in range(7):
        y = (8 + 11 * k) / n
        a, b = ((0.05, y), (0.95, y)) if k % 2 == 0 else ((0.95, y), (0.05, y))
        wash.line(a, b, 0.45, pressure=0.7)
        wash.wait(0.2)
    c1, p1 = _wash_then(wash, 22, until_damp=True)
    drop = _later(p1, n, n, 22)
    drop.brush(size=12, water=1.0, pigment={})
    drop.dab((0.5, 0.5), 0.3, pressure=0.7)
    p1.play(drop.records)
    run_until_dry(c1, 6000)
    c1.dry()
    d1 = darkness_map(c1)
    wash_dark = float(np.median(d1[8:n - 8, 8:n - 8]))
    pale = ndimage.binary_fill_holes(d1 < 0.85 * wash_dark)
    lab_, _ = ndimage.label(pale)
    centre = lab_[n // 2, n // 2]
    bloom = lab_ == centre if centre else np.zeros_like(pale)
    rim = ndimage.binary_dilation(bloom, iterations=3) & ~bloom
    front = float(np.percentile(d1[rim], 75)) / max(wash_dark, 1e-6) if rim.any() else 0.0
    radius, cv = _radius_cv(bloom, n / 2, n / 2) if bloom.any() else (0.0, 0.0)

    def dab(wet: bool) -> NumpyCanvas:
        s = Script(n, n, seed=23, rate_hz=PEN_HZ)
        if wet:
            s.brush(size=24, water=1.0, pigment={})
            for k in range(7):
                y = (8 + 11 * k) / n
                a, b = ((0.05, y), (0.95, y)) if k % 2 == 0 else ((0.95, y), (0.05, y))
                s.line(a, b, 0.45, pressure=0.7)
        s.brush(size=12, water=0.8, pigment={"French Ultramarine": 1.0})
        s.dab((0.5, 0.5), 0.3, pressure=0.7)
        return _played(s, seed=23)

    wet, dry = dab(True), dab(False)
    dw, dd = darkness_map(wet), darkness_map(dry)
    r_brush = BrushModel().radius(12, 0.7)
    spread_r = float(np.sqrt((dw > 0.25 * dw.max()).sum() / np.pi)) if dw.max() > 0 else 0.0
    peak_share = float(np.percentile(dw, 99.5) / max(np.percentile(dd, 99.5), 1e-6))
    return Effect("blooms (brush)", {"bloom_front_ratio": front, "bloom_radius_cells": radius,
                                     "bloom_radius_cv": cv,
                                     "drop_spread_over_brush_radius": spread_r / r_brush,
                                     "drop_peak_over_dry": peak_share},
                  {"bloom front >= 1.3x": front >= 1.3, "irregular (CV >= 0.15)": cv >= 0.15,
                   "drop spreads >= 2.5 r": spread_r >= 2.5 * r_brush,
                   "drop stays visible (>= 0.5x dry)": peak_share >= 0.5},
                  np.concatenate([c1.render(), wet.render(), dry.render()], axis=1),
                  (c1, wet, dry))


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


def step_artefacts() -> Effect:
    """Item 8: a wide (size 40) stroke pulled fast, 20 cells of pen travel per simulation
    step (600 cells/s at 30 steps/s), wet (water 0.9) and dry (0.15): the deposit summed
    across the stroke, per column; the share of its along-stroke variation at the step
    length (Fourier amplitude at 1/20 cycles per cell over the mean)."""
    w, h = 240, 56
    out = {}
    canvases = []
    for key, water in (("wet", 0.9), ("dry", 0.15)):
        s = Script(w, h, seed=25, rate_hz=PEN_HZ)
        s.brush(size=40, water=water, pigment={"Burnt Umber": 0.6})
        s.line((0.05, 0.5), (0.95, 0.5), 0.9 * w / 600.0, pressure=0.7)
        c = _played(s, seed=25)
        canvases.append(c)
        st = c.live_state
        prof = (st.q.sum(axis=0) + st.p.sum(axis=0)).sum(axis=0)[40:200].astype(np.float64)
        spec = np.abs(np.fft.rfft(prof - prof.mean())) / len(prof) * 2
        k = int(round(len(prof) / 20.0))
        out[f"step_component_{key}"] = float(spec[k - 1:k + 2].max() / max(prof.mean(), 1e-9))
    return Effect("step artefacts (brush)", out,
                  {"wet <= 1 %": out["step_component_wet"] <= 0.01,
                   "dry <= 1 %": out["step_component_dry"] <= 0.01},
                  np.concatenate([c.render() for c in canvases], axis=0), tuple(canvases))


BRUSH_TILES: tuple[Callable[[], Effect], ...] = (
    value_range, brush_glazing, paper_texture, brush_edges, blooms, round_dry_brush,
    step_artefacts)
"""The tiles painted through the brush (issue 21): the measure."""


PHYSICS_TILES: tuple[Callable[[], Effect], ...] = (
    edge_darkening, wet_in_wet, backrun, granulation, glazing, staining_lifting, density,
    wet_window, gouache_over_dark, ink_bleed, wet_on_dry_edge, flow_patterns)
"""Tiles that write rectangles of water and pigment into the canvas (the dissertation's
figure 6.1 list): the "physics" row, kept to show the model's physics alone."""

TILES: tuple[Callable[[], Effect], ...] = (*BRUSH_TILES, dry_brush, ink_flying_white,
                                           *PHYSICS_TILES)
"""The tiles of the sheet, in order: through the brush first (dry-brush and the ink's flying
white by the deformable brush), then the physics row."""


def run_effects(names: list[str] | None = None) -> list[Effect]:
    """Paint and measure the tiles (all, or those whose function names are given)."""
    out = []
    for t in TILES:
        if names is not None and t.__name__ not in names:
            continue
        e = t()
        if t in PHYSICS_TILES:
            e.row = "physics"
            e.name = f"physics: {e.name}"
        out.append(e)
    return out
