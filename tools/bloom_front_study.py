"""Does a bloom front driven by a Laplacian field branch? (issue 21 items 4 and 9, a study)

The model's blooms are round: the fresh water's mound is levelled (``height_gain`` 100: no
pressure drop from the drop to its edge) and its contact line advances where a neighbour's
water stands above a threshold, which a levelled mound meets on a contour (bloom10's notes).
Fingering (Saffman-Taylor, dielectric breakdown) needs the opposite: a front that moves by
the flux a field outside it carries, so a tip, which sees the steepest gradient, runs ahead.

This study runs the sheet's bloom (``effects_bloom.drop_into_damp_wash``, seed 22) or the
kiosk visitor's drop (``effects_bloom.kiosk_drop``) on the numpy reference with that rule in
place of the damp-paper advance, and prints the committed measure (``bloom_front``) as JSON.
It patches the reference for the run only; it is not part of the model (no numba, no GLSL).

The rule (``--front laplace``): the wash's pore water ahead of the fresh water is displaced
through the damp paper; its pressure ``phi`` solves the screened Laplace equation
``lap(phi) = phi / ell^2`` on damp cells (saturation above ``damp_sat``) that are not wet,
with ``phi = 1`` on the fresh water and 0 on drier paper (``jacobi`` Jacobi sweeps per step,
warm-started from the last step's field). A damp dry cell next to the fresh water collects
``K * w_n * g`` per second, ``w_n`` its wettest 4-neighbour's water and ``g`` the
face's gradient ``(1 - phi)`` over its mean along the front (``--norm-sigma``: along the
front nearby), raised to ``eta`` (the dielectric-breakdown exponent) and blurred by a
Gaussian of ``blur`` cells (the meniscus: a one-cell needle cannot run ahead of its
neighbours); it joins once it has collected its paper's capacity. The fresh water is a
new wet phase everywhere (``FRESH_SAT`` above 1).

    .venv/bin/python tools/bloom_front_study.py [--scene kiosk|sheet] [--front main|laplace]
        [--touch SECONDS] [--eta 4] [--seed N] [--sweeps 60] [--norm-sigma 0]
        [--png out.png]

Findings (bloom11, numpy, deterministic; /work/coord/NOTES-bloom11.md): the kiosk drop
measures branching 1.29 with the rule (main 1.04), 1.30 with 6 sweeps and a 10-cell local
normalisation, 1.33-1.35 with a 1.6-3 s touch (main 1.14-1.20), but its front falls to
1.13-1.15x (main 1.22); the sheet's bloom grows only from 5 to 8 cells and stays round.
"""

from __future__ import annotations

import argparse
import contextlib
import json
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import numpy as np

import station.canvas.reference as reference
import station.canvas.stencils as stencils
import station.sim.player as player
from station.canvas.params import SimParams
from station.canvas.state import CanvasState
from station.pictures import effects_bloom
from station.pictures.effects_core import darkness_map


@dataclass
class LaplacianFront:
    """The study's damp-paper advance (module docstring); fields hold the canvas-wide
    pressure ``phi`` [1] and collected volume ``got`` [height] between steps."""

    mobility: float = 3.0  # K [1/s]
    screen: float = 40.0  # ell [cells]
    jacobi: int = 60
    eta: float = 4.0
    blur: float = 1.0  # [cells]
    norm_sigma: float = 0.0  # [cells] 0: the mean gradient along the whole front
    phi: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), np.float32))
    got: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), np.float32))
    region: tuple[slice, slice] = (slice(0), slice(0))
    dt: float = 1.0 / 30.0

    def wet_mask(self, base: Callable[..., np.ndarray], w: np.ndarray, wc: np.ndarray,
                 mask: np.ndarray, prm: SimParams, h: np.ndarray,
                 fibre: np.ndarray | None = None) -> np.ndarray:
        old = base(w, wc, mask, prm, h, fibre)
        own = stencils.own_wet(w, wc, mask, prm)
        phi, got = self.phi[self.region], self.got[self.region]
        c = stencils.capacity(h, prm)
        damp = (np.minimum(wc / c, 1.0) > prm.damp_sat) & (mask == 0) & ~own
        if not own.any():
            got[...] = 0.0
            return old
        keep = 1.0 / (4.0 + 1.0 / self.screen ** 2)
        ph = np.where(own, 1.0, np.where(damp, phi, 0.0)).astype(np.float32)
        for _ in range(self.jacobi):
            p = np.pad(ph, 1)
            nb = (p[1:-1, 2:] + p[1:-1, :-2] + p[2:, 1:-1] + p[:-2, 1:-1]) * keep
            ph = np.where(own, 1.0, np.where(damp, nb, 0.0)).astype(np.float32)
        phi[...] = ph
        pw = np.pad(np.where(own, w, 0.0), 1)
        drive = np.maximum(np.maximum(pw[1:-1, 2:], pw[1:-1, :-2]),
                           np.maximum(pw[2:, 1:-1], pw[:-2, 1:-1]))
        front = damp & (drive > 0)
        if not front.any():
            got[...] = 0.0
            return (old & ~damp) | own
        g = 1.0 - ph
        if self.norm_sigma > 0:  # over its Gaussian-weighted mean along the front nearby
            tn = stencils.gaussian_taps(self.norm_sigma)
            near = stencils.blurred_wet(np.where(front, g, 0.0).astype(np.float32), tn)
            g = g / np.maximum(near / np.maximum(stencils.blurred_wet(front, tn), 1e-6), 1e-6)
        else:
            g = g / max(float(g[front].mean()), 1e-6)
        gg = np.where(front, g ** self.eta, 0.0).astype(np.float32)
        taps = stencils.gaussian_taps(self.blur)
        gg = stencils.blurred_wet(gg, taps) / np.maximum(stencils.blurred_wet(front, taps), 1e-3)
        got[...] = np.where(front, got + self.mobility * drive * gg * self.dt, 0.0)
        out: np.ndarray = (old & ~damp) | own | (front & (got > c))
        return out


@contextlib.contextmanager
def laplacian_front(rule: LaplacianFront) -> Iterator[None]:
    """The reference's wet mask replaced by ``rule``'s on damp paper, for the block."""
    base_mask, base_region = stencils.wet_mask, reference.step_region
    base_fresh = vars(player)["FRESH_SAT"]

    def step_region(state: CanvasState, sl: tuple[slice, slice], dt: float,
                    stop_after: str | None = None) -> None:
        if rule.phi.shape != state.w.shape:
            rule.phi = np.zeros(state.w.shape, np.float32)
            rule.got = np.zeros(state.w.shape, np.float32)
        rule.region, rule.dt = sl, dt
        base_region(state, sl, dt, stop_after)

    def wet_mask(w: np.ndarray, wc: np.ndarray, mask: np.ndarray, prm: SimParams,
                 h: np.ndarray, fibre: np.ndarray | None = None) -> np.ndarray:
        return rule.wet_mask(base_mask, w, wc, mask, prm, h, fibre)

    # the study swaps module attributes for the run (as unittest.mock.patch would)
    patches = {(reference, "step_region"): step_region, (reference, "wet_mask"): wet_mask,
               (player, "FRESH_SAT"): 1.01}  # the fresh water is a new wet phase
    olds = {(reference, "step_region"): base_region, (reference, "wet_mask"): base_mask,
            (player, "FRESH_SAT"): base_fresh}
    for (mod, name), new in patches.items():
        setattr(mod, name, new)
    try:
        yield
    finally:
        for (mod, name), old in olds.items():
            setattr(mod, name, old)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", choices=("kiosk", "sheet"), default="kiosk")
    ap.add_argument("--front", choices=("main", "laplace"), default="laplace")
    ap.add_argument("--touch", type=float, default=0.0,
                    help="the drop's touch [s] (0: the scene's own; on the sheet a circling touch)")
    ap.add_argument("--eta", type=float, default=4.0)
    ap.add_argument("--seed", type=int, default=-1, help="paper seed (-1: the scene's own)")
    ap.add_argument("--sweeps", type=int, default=60, help="Jacobi sweeps per step")
    ap.add_argument("--norm-sigma", type=float, default=0.0,
                    help="normalise the gradient by its mean along the front within this "
                         "Gaussian [cells] (0: along the whole front)")
    ap.add_argument("--png", default="")
    a = ap.parse_args()
    rule = LaplacianFront(eta=a.eta, jacobi=a.sweeps, norm_sigma=a.norm_sigma)
    ctx = laplacian_front(rule) if a.front == "laplace" else contextlib.nullcontext()
    with ctx:
        if a.scene == "kiosk":
            canvas, numbers = effects_bloom.kiosk_drop(max(a.seed, 0), touch=a.touch or 0.4)
        else:
            seed = 22 if a.seed < 0 else a.seed
            canvas = effects_bloom.drop_into_damp_wash({}, seed, touch=a.touch)
            numbers = effects_bloom.bloom_front(darkness_map(canvas))
    print(json.dumps({"scene": a.scene, "front": a.front, "touch": a.touch, "seed": a.seed,
                      **{k: round(float(v), 4) for k, v in numbers.items()}}), flush=True)
    if a.png:
        from PIL import Image  # only when a picture is asked for

        rgb = np.clip(np.asarray(canvas.render(), float) * 255.0, 0, 255).astype(np.uint8)
        Image.fromarray(rgb).save(a.png)


if __name__ == "__main__":
    main()
