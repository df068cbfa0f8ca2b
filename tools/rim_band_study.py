"""Why the brush rim narrows to one cell when the wet-wash drop's levers are on (issue 21
items 3 and 4, a study).

The watercolor profile's dried wet-on-dry brush stroke (``effects_brush.brush_edges``)
has a rim 2 cells wide on main: rings from the deposit's edge 1.65, 1.43, 1.25 x the
interior (the floor: 1.4 over 2-5 cells). The levers that feather a drop of colour into a
fully wet wash (s11-wetdrop3: the gated fibre channel, the fibre dispersion, the pigment's
own diffusion 0.005 in standing water) make it one dark line: 1.81, 1.22.

This study runs the sheet's own brushed tiles on the numpy reference with the levers
(``--levers``), any profile parameter (``--set name=value``), and two rules that are not
part of the model, patched into the reference for the run only (no numba, no GLSL):

``--front-nu SCALE``: the pigment's own diffusion stays ``nu_p`` near the edge of the wet
    area: the standing-water gate is multiplied by ``1 - smoothstep(pull / SCALE)``,
    ``pull = flow_outward (1 - M')`` (pass 3's flow-outward pull, ``M'`` the blurred
    wet-area mask). The same front factor as ``fibre_gate_pull`` gives the channel.
``--dry-outside T``: ``--front-nu``'s factor only at fronts over dry paper: times
    ``min(2 D, 1)``, ``D`` the wet-area blur of the cells whose capillary water is under
    ``T`` of their capacity (a brush stroke drying on dry paper: D ~ 0.5 at its edge; a
    bloom's front inside a damp wash: D ~ 0).
``--band-evap K``: extra evaporation ``K (1 - M') w e`` over the band where the wet
    area's mask is blurred (Curtis 1997, 4.3.3: evaporation raised near the edge), on
    top of ``edge_evap``'s outermost ring.

It prints one JSON line per run: the rim's rings (``edge_band`` as the sheet measures),
the wet-wash drop (spread over the brush radius, peak over dry, feather, radius CV), the
damp bloom's front (``bloom_front``) and the brushed glaze's dE76, each only if asked.

    .venv/bin/python tools/rim_band_study.py --levers [--front-nu 0.2] [--band-evap 10]
        [--set flow_outward=0.45 --set wet_blur=4] [--measure rim,drop,bloom,glaze]

Findings (drop12, numpy, deterministic; /work/coord/NOTES-drop12.md): the band's second
ring follows the low standing diffusion's steepening (ring2/ring1 0.87 on main, 0.67 with
the levers) and the rim's excess pigment (raised by ``flow_outward``, lowered by the
channel and the dispersion). Stronger ``flow_outward`` alone gives the band back (0.7, wet_blur
4: rings 2.26, 1.50) but the brushed glaze's dE76 falls 5.35 -> 3.04 (its yellow runs out
to the rim). ``--front-nu 0.04`` gives the shape back (0.87) and the glaze (6.19), but the
damp bloom's front falls 1.43 -> 1.28; with ``--dry-outside 0.5`` the bloom keeps 1.43 and,
at ``flow_outward`` 0.55, wet_blur 4: rim 1.73, 1.50, 1.32 (2 cells), drop feather 1.45 / CV
0.19, bloom 1.46 / 5 lobes, glaze 5.33.

Session 13 (drop13, ``--measure gran``: test_canvas_spectral's deep flat wash, valleys vs
hills dE76, floor 2): recipe D costs it (2.90 -> 1.58) through ``standing_depth`` 0.005,
which holds the pigment's low diffusion through the thin film a wash dries in, where the
pigment settles by the paper's height. The profile's levers and front now (``--set`` needs
none): ``standing_depth`` 0.05 and ``standing_nu_p`` 0.002 (the low diffusion only in deep
standing water, where the drop spreads) and ``flow_outward`` 0.48: gran 2.18, drop 1.425 /
0.190, rim 1.64 1.43 1.27 (2 cells), bloom 1.34 / 3 lobes, glaze 5.80 (rows 3.5 s apart:
turn 1.347, tests/test_wet_area_rows.py). Knobs from there: ``standing_depth`` 0.03 / 0.07 /
0.1: gran 1.91 / 2.25 / 2.38, drop feather 1.39 / 1.35 / 1.29 (flow 0.55); the low diffusion
only where the water moves (smoothstep(|v| / v0), v0 0.02-0.5) does not separate them (gran
1.60-1.85 while the feather falls to 1.13); ``flow_outward`` 0.45 / 0.5 / 0.55: rows' turn
1.31 / 1.36 / 1.40, rim ring 2 1.40 / 1.45 / 1.49.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys

import numpy as np

from station.backends.numpy_canvas import NumpyCanvas
from station.brush.stamp import BrushModel
from station.canvas import passes, profiles, reference
from station.canvas.params import SimParams
from station.canvas.stencils import blurred_wet, gaussian_taps
from station.pictures import effects as fx
from station.pictures import effects_bloom, effects_brush
from station.pictures.effects_core import darkness_map, new_canvas, use_backend
from station.pictures.measure import edge_band
from station.pictures.scenarios import distance_inside, paint, rect, run_until_dry
from station.sim.player import SessionPlayer

F32 = np.float32
LEVERS: dict[str, float] = {"fibre_permeability": 1.0, "fibre_dispersivity": 9.0,
                            "fibre_gate_depth": 0.15, "fibre_gate_pull": 0.04,
                            "standing_depth": 0.005, "standing_nu_p": 0.005}
"""s11-wetdrop3's settings that feather the wet-wash drop (feather 1.45, radius CV 0.19)."""


class _Patch:
    """The two study rules, patched into ``station.canvas.reference`` for the run.

    ``flow_pressure`` (pass 3) keeps its region's blurred wet-area mask M'; pass 5's
    ``blocking`` and pass 7's ``evaporate`` read it (every region runs its passes in
    order, so the mask is always the one of the region being stepped)."""

    def __init__(self, front_nu: float, band_evap: float, dry_outside: float = 0.0) -> None:
        self.front_nu, self.band_evap, self.dry_outside = front_nu, band_evap, dry_outside
        self.mb: np.ndarray | None = None
        self.wc: np.ndarray | None = None
        self._fp, self._bl, self._ev, self._ow = (reference.flow_pressure, reference.blocking,
                                                  reference.evaporate, reference.own_wet)

    def install(self) -> None:
        reference.own_wet = self.own_wet  # type: ignore[assignment]
        reference.flow_pressure = self.flow_pressure  # type: ignore[assignment]
        reference.blocking = self.blocking  # type: ignore[assignment]
        reference.evaporate = self.evaporate  # type: ignore[assignment]

    def own_wet(self, w: np.ndarray, wc: np.ndarray, mask: np.ndarray,
                prm: SimParams) -> np.ndarray:
        self.wc = wc  # the region's capillary water, for the dry-outside factor
        return self._ow(w, wc, mask, prm)

    def flow_pressure(self, w: np.ndarray, own: np.ndarray, wet: np.ndarray, h: np.ndarray,
                      prm: SimParams) -> np.ndarray:
        taps = gaussian_taps(prm.wet_blur)
        self.mb = blurred_wet(own, taps) if len(taps) else None
        return self._fp(w, own, wet, h, prm)

    def blocking(self, h: np.ndarray, block: np.ndarray, block_time: np.ndarray,
                 sim_time: float, prm: SimParams, fibre: np.ndarray | None = None,
                 speed: np.ndarray | None = None,
                 standing: np.ndarray | None = None) -> np.ndarray:
        if self.front_nu > 0 and standing is not None and self.mb is not None:
            pull = (F32(prm.flow_outward) * (F32(1.0) - self.mb)).astype(F32)
            front = passes.standing_gate(pull, 1.0 / self.front_nu)
            if self.dry_outside > 0 and self.wc is not None:
                # only at fronts over dry paper: the share of paper nearby (the wet mask's
                # blur) whose capillary water is under dry_outside of its capacity, x2
                cap = F32(prm.c_min) + h * F32(prm.c_max - prm.c_min)
                dry = blurred_wet(self.wc < F32(self.dry_outside) * cap,
                                  gaussian_taps(prm.wet_blur))
                front = front * np.minimum(F32(2.0) * dry, F32(1.0))
            standing = standing * (F32(1.0) - front)
        return self._bl(h, block, block_time, sim_time, prm, fibre, speed, standing)

    def evaporate(self, w: np.ndarray, evaporated: np.ndarray, prm: SimParams,
                  dt: float) -> tuple[np.ndarray, np.ndarray]:
        w2, e2 = self._ev(w, evaporated, prm, dt)
        if self.band_evap > 0 and self.mb is not None:
            e = F32(prm.evap_shallow() * dt)
            extra = F32(self.band_evap) * (F32(1.0) - self.mb) * w * e
            extra = np.where(w2 > 0, np.minimum(extra, w2), F32(0.0)).astype(F32)
            w2, e2 = w2 - extra, e2 + extra
        return w2, e2


def measure(what: set[str]) -> dict[str, object]:
    """The sheet's own tiles under the current watercolor profile."""
    out: dict[str, object] = {}
    if "rim" in what:
        c = effects_brush.brush_edges().canvases[0]
        b = edge_band(c.live_state.q.sum(axis=0), threshold=1.4, interior_from=6)
        out["rim"] = {"width": b.width, "rings": [round(float(x), 3) for x in b.ring_ratio[:5]]}
    if "drop" in what:
        dw = darkness_map(effects_bloom.drop_into_wet_wash(True))
        dd = darkness_map(effects_bloom.drop_into_wet_wash(False))
        r = BrushModel().radius(12, 0.7)
        fr = effects_bloom.drop_front(dw)
        out["drop"] = {"spread_r": float(np.sqrt((dw > 0.25 * dw.max()).sum() / np.pi)) / r,
                       "peak_over_dry": float(np.percentile(dw, 99.5)
                                              / max(np.percentile(dd, 99.5), 1e-6)),
                       "feather": fr["feather"], "cv": fr["cv"]}
    if "bloom" in what:
        cl = effects_bloom.bloom_front(darkness_map(effects_bloom.drop_into_damp_wash({})))
        out["bloom"] = {"front": cl["front_ratio"], "cv": cl["cv"], "lobes": cl["lobes"]}
    if "glaze" in what:
        out["glaze_de76"] = effects_brush.brush_glazing().numbers["delta_e76_glaze_vs_mix"]
    if "gran" in what:  # test_canvas_spectral's deep flat wash: valleys vs hills dE76 (>= 2)
        c = NumpyCanvas(48, 48, seed=5)
        fp = rect(48, 48, 6, 42, 6, 42)
        paint(c, fp, 0.6, {"French Ultramarine": 0.3})
        run_until_dry(c, 6000)
        c.dry()
        img, h = c.render(), c.live_state.h
        inner = distance_inside(fp) >= 4
        hv = h[inner]
        valley, hill = hv < np.quantile(hv, 0.25), hv > np.quantile(hv, 0.75)
        out["gran_de76"] = float(fx.delta_e76(img[inner][valley].mean(axis=0),
                                              img[inner][hill].mean(axis=0)))
    if "sky" in what:  # the kiosk visitor's zig-zag sky (tools/sky_rows_study.py)
        sk = effects_brush.sky_rows_script(0)
        hd = sk.header
        c = new_canvas(hd.width, hd.height, profile="watercolor", seed=0)
        SessionPlayer(c, hd.width, hd.height, "watercolor").play(sk.records)
        run_until_dry(c, 20000)
        c.dry()
        out["sky"] = effects_brush.sky_banding(np.asarray(c.render(), np.float64), c)
    if "rows" in what:  # tests/test_wet_area_rows.py's rows 3.5 s apart
        import importlib
        import pathlib

        sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tests"))
        rows_test = importlib.import_module("test_wet_area_rows")

        d, _ = rows_test._paint(3.5)
        prof = d[:, rows_test.W // 4:3 * rows_test.W // 4].mean(axis=1)
        out["rows"] = {"line": rows_test._line(prof), "turn": rows_test._turn(d)}
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--levers", action="store_true", help="s11-wetdrop3's drop settings")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--front-nu", type=float, default=0.0)
    ap.add_argument("--band-evap", type=float, default=0.0)
    ap.add_argument("--dry-outside", type=float, default=0.0,
                    help="--front-nu only where the paper nearby is dry (capillary water "
                         "under this share of its capacity; 0: at every front)")
    ap.add_argument("--measure", default="rim,drop,bloom,glaze")
    ap.add_argument("--backend", default="numpy",
                    help="the sheet's tiles on numpy or cpu (cpu: without the patched rules)")
    a = ap.parse_args(argv)
    use_backend(a.backend)
    change: dict[str, float] = dict(LEVERS) if a.levers else {}
    for item in a.set:
        name, _, value = item.partition("=")
        if not hasattr(SimParams, name) or not value:
            print(f"--set {item!r}: not a SimParams field=value", file=sys.stderr)
            return 2
        change[name] = float(value)
    prof = profiles.get_profile("watercolor")
    profiles.PROFILES["watercolor"] = dataclasses.replace(
        prof, params=prof.params.replace(**change))
    _Patch(a.front_nu, a.band_evap, a.dry_outside).install()
    res = measure(set(a.measure.split(",")))
    print(json.dumps({"params": change, "front_nu": a.front_nu, "band_evap": a.band_evap,
                      "dry_outside": a.dry_outside, **res}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
