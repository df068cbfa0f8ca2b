"""Damp-paper rules against the brushed blooms (issue 21 item 4, session 15; a study).

Runs the sheet's clear-water bloom (``effects_bloom.drop_into_damp_wash``, seed 22, ~5 s
quiet) or the kiosk visitor's drop (``effects_bloom.kiosk_drop``, ~30-70 s) on the numpy
reference with one of the damp-paper rules tried in session 15 patched in for the run
(not part of the model: no numba, no GLSL), and prints ``bloom_front`` with how far the
touch's water reached (``_touch_spread``) as JSON. ``--stall`` instead follows the
sheet's drop for 4 s and prints, at its front, the film's depth, the damp cells the
contact line reaches and the share of them it lets in: why the bloom stops.

    .venv/bin/python tools/bloom_damp_study.py [--scene sheet|kiosk] [--rule NAME]
        [--lo 0.9] [--n 3] [--floor 0.1] [--set field=value ...] [--png out.png] [--stall]

Rules (``--rule``), each replacing ``stencils.damp_factor`` (the share of the advancing
height left on damp paper, ``s = min(wc / c, 1)``) or a pass:

- ``main``: the model as it is: ``max(1 - damp_ease 4 s' (1 - s'), 0)`` (free over s
  0.685-0.965) and, since this study, the profile's ``damp_exposure`` (``--set
  damp_exposure=0`` for the model the other rules were measured against).
- ``graded``: easier the damper, never free: ``floor + (1 - floor) (1 - s')^n`` above
  ``lo`` (Curtis's "damper cells first").
- ``full``: harder the fuller: ``((s - lo) / (1 - lo))^n`` (no suction in a full
  capillary layer, over a wide band: the bloom's own capillary halo then pins the front
  where it fills the paper ahead, a Stefan-like rule).
- ``wick``: today's factor but at least ``floor`` on damp paper, lowered along the fibres
  (``1 - fibre[axis]``) there only.
- ``gate``: pass 3's fibre channel in thin water instead of standing water (the gate
  ``1 - smoothstep(w / fibre_gate_depth)``: a film deeper than the fibres levels freely).
- ``absorb``: pass 9's absorption times ``(1 - s)^n`` (damp paper takes a film up slowly).
- ``exposure``: today's reach, but a damp cell joins only where it is more exposed than
  beside a straight front: ``1 - M'`` at least ``--x`` (0.6; a straight front's next cell
  ~0.55), ``M'`` the cells wet by their own water blurred by ``--sigma`` (4, the flow
  outward's ``wet_blur``). A cheap stand-in for the pressure of the wash's paint that the
  fresh water displaces (a Laplacian field outside the front: bloom11's
  ``tools/bloom_front_study.py --front laplace``, 60 Jacobi sweeps a step): the front runs
  on at its convex parts, bays wait (a dielectric-breakdown rule with a threshold).

Findings (session 15, numpy, deterministic; /work/coord/NOTES-bloom15.md): of the damp-
factor and pass rules none branches (front_branching 0.92-1.00 on the sheet, 1.04-1.08
on the kiosk, main 0.96 / 1.15). The blooms are the touch's footprint: the sheet's touch
leaves 7.2 cells wet, its water spreads to 11.6 in ~3 s and stalls, the pale bloom ends
at 8.6; the kiosk's 17 -> 25 -> 20.6. At the stall the contact line lets 90 % of the
damp cells ahead in, but the film there is 0.01-0.03 deep and feeds them more slowly
than their paper absorbs (``alpha dt`` a step until their capacity is full), so they
stay without water.
``exposure`` is the one that branches: x 0.6 with ``--fresh 1.01`` (the touch a new wet
phase in its window) branching 1.11, CV 0.20, front 1.35, 4 lobes; with ``--set
flow_outward=1.5`` 1.15 / 0.28 / 1.72 and ``flow_outward=2.5``, x 0.58 1.22 / 0.23 /
1.69 (lobed blooms with a crust on each lobe's end; the lobes favour the grid's axes, a
cross on some seeds; x 0.56 does nothing, 0.65 shrinks the bloom). Not ported
(flow_outward that strong costs the rims and the glaze; see the note).
``full`` (lo 0.8-0.9, n 1.5-4) breaks the sheet's crust into arcs (CV 0.19-0.26, front
1.25-1.40), the kiosk's drop stays round; ``absorb`` n 0.5 lets the water spread to 14
cells, the bloom to 10.4, round (CV 0.11); n >= 2 keeps the wash itself from drying.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
from collections.abc import Iterator
from typing import Any

import numpy as np

import station.canvas.passes as passes
import station.canvas.profiles as profiles
import station.canvas.reference as reference
import station.canvas.stencils as stencils
import station.sim.player as player
from station.canvas.params import SimParams
from station.pictures import effects_bloom
from station.pictures.effects_core import darkness_map

F32 = np.float32


def _sat(wc: np.ndarray, h: np.ndarray, prm: SimParams) -> np.ndarray:
    return np.minimum(wc / stencils.capacity(h, prm), F32(1.0))


def _damp_rule(rule: str, lo: float, n: float, floor: float) -> Any:
    def graded(wc: np.ndarray, h: np.ndarray, prm: SimParams) -> np.ndarray:
        s = _sat(wc, h, prm)
        sp = np.clip((s - F32(lo)) / F32(1.0 - lo), 0.0, 1.0)
        f = F32(floor) + F32(1.0 - floor) * (F32(1.0) - sp) ** F32(n)
        return np.where(s > F32(lo), f, F32(1.0)).astype(F32)

    def full(wc: np.ndarray, h: np.ndarray, prm: SimParams) -> np.ndarray:
        s = _sat(wc, h, prm)
        t = np.clip((s - F32(lo)) / F32(1.0 - lo), 0.0, 1.0).astype(F32)
        return np.where(s > F32(prm.damp_sat), t ** F32(n), F32(1.0)).astype(F32)

    return {"graded": graded, "full": full}.get(rule)


def _wick_mask(floor: float) -> Any:
    def wet_mask(w: np.ndarray, wc: np.ndarray, mask: np.ndarray, prm: SimParams,
                 h: np.ndarray, fibre: np.ndarray | None = None) -> np.ndarray:
        own = stencils.own_wet(w, wc, mask, prm)
        damp = _sat(wc, h, prm) > F32(prm.damp_sat)
        df = stencils.damp_factor(wc, h, prm)
        thr = F32(prm.advance_height) * stencils.advance_term(wc, h, prm) * np.where(
            damp, np.maximum(df, F32(floor)), df)
        fx = fibre[0] if fibre is not None else np.zeros_like(w)
        fy = fibre[1] if fibre is not None else np.zeros_like(w)
        thx = np.where(damp, thr * (F32(1.0) - fx), thr)
        thy = np.where(damp, thr * (F32(1.0) - fy), thr)
        nx, ny = stencils.axis_neighbours(w)
        line = stencils.front_curvature(w, wc, h, prm, thr, (nx > thx) | (ny > thy))
        out: np.ndarray = own | stencils.pinned(own, line & (mask == 0), wc, h, prm)
        return out

    return wet_mask


def _exposure_mask(x: float, sigma: float) -> Any:
    base = stencils.wet_mask

    def wet_mask(w: np.ndarray, wc: np.ndarray, mask: np.ndarray, prm: SimParams,
                 h: np.ndarray, fibre: np.ndarray | None = None) -> np.ndarray:
        out = base(w, wc, mask, prm, h, fibre)
        own = stencils.own_wet(w, wc, mask, prm)
        damp = (_sat(wc, h, prm) > F32(prm.damp_sat)) & ~own
        exposure = F32(1.0) - stencils.blurred_wet(own, stencils.gaussian_taps(sigma))
        kept: np.ndarray = out & ~(damp & (exposure < F32(x)))
        return kept

    return wet_mask


def _thin_gate(base: Any) -> Any:
    def fibre_gate(state: Any, w: np.ndarray, h: np.ndarray,
                   pr: np.ndarray) -> np.ndarray | None:
        g = base(state, w, h, pr)
        if g is None or not state.fibre.any():
            return g
        out: np.ndarray = (F32(1.0) - passes.standing_gate(w, state.params.fibre_gate()))
        return out.astype(F32)

    return fibre_gate


def _slow_absorb(n: float) -> Any:
    def capillary(w: np.ndarray, wc: np.ndarray, h: np.ndarray, mask: np.ndarray,
                  evaporated: np.ndarray, prm: SimParams,
                  dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        c = stencils.capacity(h, prm)
        opn = mask == 0
        g = (F32(1.0) - np.minimum(wc / c, F32(1.0))) ** F32(n)
        d = np.minimum(np.minimum(F32(prm.alpha * dt) * g, w), np.maximum(c - wc, F32(0.0)))
        d = np.where((w > 0) & opn, d, F32(0.0)).astype(F32)
        # the rest of pass 9 as the reference has it, on what was absorbed
        w2, wc2, e2 = passes.capillary(w - d, wc + d, h, mask, evaporated,
                                       prm.replace(alpha=0.0), dt)
        return w2, wc2, e2

    return capillary


@contextlib.contextmanager
def patched(a: argparse.Namespace) -> Iterator[None]:
    """The reference's damp-paper rule ``a.rule`` for the block (as unittest.mock.patch
    would), with ``a.set`` replacing watercolor's parameters."""
    olds: list[tuple[Any, str, Any]] = []

    def swap(mod: Any, name: str, new: Any) -> None:
        olds.append((mod, name, getattr(mod, name)))
        setattr(mod, name, new)

    df = _damp_rule(a.rule, a.lo, a.n, a.floor)
    if df is not None:
        swap(stencils, "damp_factor", df)
    elif a.rule == "wick":
        swap(reference, "wet_mask", _wick_mask(a.floor))
    elif a.rule == "gate":
        swap(reference, "fibre_gate", _thin_gate(reference.fibre_gate))
    elif a.rule == "absorb":
        swap(reference, "capillary", _slow_absorb(a.n))
    elif a.rule == "exposure":
        swap(reference, "wet_mask", _exposure_mask(a.x, a.sigma))
    if a.fresh > 0:
        swap(player, "FRESH_SAT", a.fresh)
    prof = profiles.PROFILES["watercolor"]
    if a.set:
        over = {k: float(v) for k, v in (s.split("=") for s in a.set)}
        profiles.PROFILES["watercolor"] = dataclasses.replace(
            prof, params=prof.params.replace(**over))
    try:
        yield
    finally:
        profiles.PROFILES["watercolor"] = prof
        for mod, name, old in reversed(olds):
            setattr(mod, name, old)


def stall() -> list[dict[str, float]]:
    """The sheet's drop followed for 4 s: at 0.3-4 s the cells with water, the film's
    depth along the front, the damp cells next to it and the share the contact line lets
    in (``wet_mask``), in the middle half of the tile."""
    c, p = effects_bloom.damp_wash(22)
    st = c.live_state
    drop = effects_bloom._later(p, effects_bloom.N, effects_bloom.N, 22)
    drop.brush(size=effects_bloom.DROP_SIZE, water=1.0, pigment={})
    drop.dab((0.5, 0.5), effects_bloom.DROP_S, pressure=0.7)
    p.play(drop.records)
    box = (slice(18, 62), slice(18, 62))
    rows = []
    for k in range(1, 121):
        c.step()
        if k not in (10, 30, 60, 90, 120):
            continue
        w = st.w[box]
        wet = w > 0
        pw = np.pad(w, 1)
        nb = np.maximum.reduce([pw[1:-1, 2:], pw[1:-1, :-2], pw[2:, 1:-1], pw[:-2, 1:-1]])
        ahead = ~wet & (nb > 0)
        pd = np.pad(~wet, 1, constant_values=True)
        edge = wet & (pd[1:-1, 2:] | pd[1:-1, :-2] | pd[2:, 1:-1] | pd[:-2, 1:-1])
        reached = reference.wet_mask(st.w, st.wc, st.mask, st.params, st.h, st.fibre)[box]
        rows.append({"t": round(k * st.params.dt, 2), "cells_with_water": int(wet.sum()),
                     "film_at_front": round(float(np.median(w[edge])), 4),
                     "damp_cells_ahead": int(ahead.sum()),
                     "share_let_in": round(float(reached[ahead].mean()), 3)})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", choices=("sheet", "kiosk"), default="sheet")
    ap.add_argument("--rule", choices=("main", "graded", "full", "wick", "gate", "absorb",
                                       "exposure"), default="main")
    ap.add_argument("--x", type=float, default=0.6, help="exposure: the least exposure")
    ap.add_argument("--sigma", type=float, default=4.0, help="exposure: blur [cells]")
    ap.add_argument("--fresh", type=float, default=0.0,
                    help="the bead's FRESH_SAT (0: as it is; 1.01: a touch into a damp wash "
                         "drops the faded wet-area memory in its whole window)")
    ap.add_argument("--lo", type=float, default=0.9)
    ap.add_argument("--n", type=float, default=3.0)
    ap.add_argument("--floor", type=float, default=0.1)
    ap.add_argument("--set", action="append", default=[], help="a SimParams field=value")
    ap.add_argument("--png", default="")
    ap.add_argument("--stall", action="store_true")
    a = ap.parse_args()
    with patched(a):
        if a.stall:
            for row in stall():
                print(json.dumps(row), flush=True)
            return
        if a.scene == "kiosk":
            canvas, numbers = effects_bloom.kiosk_drop(0)
        else:
            reach: dict[str, float] = {}
            canvas = effects_bloom.drop_into_damp_wash({}, 22, report=reach)
            numbers = {**effects_bloom.bloom_front(darkness_map(canvas)), **reach}
    print(json.dumps({"scene": a.scene, "rule": a.rule,
                      **{k: round(float(v), 4) for k, v in numbers.items()}}), flush=True)
    if a.png:
        from PIL import Image  # only when a picture is asked for

        from station.render.km import linear_to_srgb

        rgb = np.clip(np.asarray(canvas.render(), np.float64), 0.0, 1.0)
        srgb = (np.clip(linear_to_srgb(rgb), 0, 1) * 255 + 0.5).astype(np.uint8)
        Image.fromarray(srgb).resize((srgb.shape[1] * 4, srgb.shape[0] * 4),
                                     Image.Resampling.NEAREST).save(a.png)


if __name__ == "__main__":
    main()
