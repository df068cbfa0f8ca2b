"""The effects sheet's "physics" row: tiles that write rectangles of water and pigment
into the canvas (the dissertation's figure 6.1 list), and the deformable brushes' own
tiles (dry-brush, the ink's flying white)."""

from __future__ import annotations

import dataclasses

import numpy as np

from station.backends.numpy_canvas import NumpyCanvas
from station.canvas.palette import Palette, Pigment, default_palette
from station.canvas.params import SimParams
from station.canvas.removal import HairDryer, blow, pickup
from station.pictures.effects_core import (
    F32,
    Effect,
    delta_e76,
    hue_deg,
    lab,
    lab_hue_deg,
)
from station.pictures.measure import bare_share, edge_band, edge_roughness, edge_width, spread
from station.pictures.scenarios import disc, distance_inside, paint, rect, run_until_dry
from station.render.km import linear_to_srgb
from station.sim.player import SessionPlayer
from station.sim.script import Script


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


GRANULATION_SEEDS = (5, 6, 7)
"""Papers the granulation tile is painted on. On the broadband cold-press one paper's
correlation ranges -0.22 to -0.52 (the wash's own flow pattern over the paper's 8-11 cell
relief); the mean of three is the measure."""


def granulation(seeds: tuple[int, ...] = GRANULATION_SEEDS) -> Effect:
    """A granulating wash (Ultramarine 0.3, water 0.6) laid as a rectangle and dried on
    each of ``seeds``' papers: the correlation of the deposit with the paper's height over
    the cells 4 or more inside (negative: pigment in the valleys), each and their mean."""
    rs = []
    canvases = []
    for seed in seeds:
        c = NumpyCanvas(64, 64, seed=seed)
        fp = rect(64, 64, 8, 56, 8, 56)
        _layer(c, fp, {"French Ultramarine": 0.3}, water=0.6)
        st = c.live_state
        inner = distance_inside(fp) >= 4
        rs.append(float(np.corrcoef(st.q[0][inner], st.h[inner])[0, 1]))
        canvases.append(c)
    # -0.5 on the first two-octave paper; the broadband one (issue 21 item 7) has relief
    # at scales a wash does not follow cell by cell: the visible measure is paper_texture's
    r = float(np.mean(rs))
    numbers = {"corr_deposit_paper_height": r}
    numbers.update({f"corr_paper_{seed}": v for seed, v in zip(seeds, rs, strict=True)})
    return Effect("granulation", numbers, {"pigment in the valleys": r < -0.3},
                  canvases[0].render(), (canvases[0],))


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
