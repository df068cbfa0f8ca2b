"""``station bench render``: cost of the spectral Kubelka–Munk render against the RGB one.

One painted canvas (default 800×600: a dried French Ultramarine layer under a wet layer
of three pigments over the whole sheet, so every cell runs the full formulas) rendered
with 12 spectral bands and with Curtis's 3 RGB channels, by the NumPy reference
(``render.render_state``) and by the compiled cpu path the kiosk uses for dirty tiles
(``render.km_fast.km_layer_fast``). Each figure is the best of ``--repeat`` runs; the
ratios spectral / RGB are measured in the same run, so they compare under the same load.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np

from station.backends.numpy_canvas import NumpyCanvas
from station.canvas.params import SimParams
from station.canvas.state import CanvasState
from station.errors import BadInput
from station.render.km import region_amount, render_bands, render_state
from station.render.km_fast import km_layer_fast


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("render", help="spectral vs RGB Kubelka-Munk render time (JSON)")
    p.add_argument("--json", action="store_true", help="print JSON (the default output too)")
    p.add_argument("--size", default="800x600", metavar="WxH", help="canvas (default 800x600)")
    p.add_argument("--repeat", type=int, default=3, help="runs per figure, best kept (1..50)")
    p.set_defaults(func=run)


def _state(width: int, height: int, bands: int) -> CanvasState:
    c = NumpyCanvas(width, height, seed=1, params=SimParams(render_bands=bands), tiling=False)
    st = c.live_state
    rng = np.random.default_rng(0)
    blue = st.slot_of("French Ultramarine")
    st.q[blue] = rng.uniform(0.1, 0.5, (height, width)).astype(np.float32)
    st.r_composed[...] = render_bands(st, "km")
    st.q[...] = 0
    st.slots = []
    for name in ("Hansa Yellow", "Quinacridone Rose", "Burnt Umber"):
        k = st.slot_of(name)
        st.p[k] = rng.uniform(0.0, 0.3, (height, width)).astype(np.float32)
        st.q[k] = rng.uniform(0.0, 0.2, (height, width)).astype(np.float32)
    return st


def _best_ms(fn: Callable[[], object], repeat: int) -> float:
    fn()  # warm-up (numba compiles on first call)
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best * 1000.0


def run(args: argparse.Namespace) -> int:
    try:
        w, h = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        raise BadInput(f"--size {args.size!r}: expected WxH") from None
    if not (16 <= w <= 4096 and 16 <= h <= 4096):
        raise BadInput(f"--size {args.size}: each side must lie in 16..4096")
    if not 1 <= args.repeat <= 50:
        raise BadInput(f"--repeat {args.repeat} must lie in 1..50")
    out: dict[str, Any] = {"size": [w, h], "repeat": args.repeat,
                           "loadavg_1min": round(os.getloadavg()[0], 2)}
    for bands, name in ((3, "rgb"), (12, "spectral")):
        st = _state(w, h, bands)
        amount, pigs = region_amount(st, slice(0, h), slice(0, w))
        out[f"numpy_{name}_ms"] = round(_best_ms(partial(render_state, st, "km"),
                                                 args.repeat), 2)
        out[f"cpu_{name}_ms"] = round(_best_ms(
            partial(km_layer_fast, amount, pigs, st.r_composed), args.repeat), 2)
    out["numpy_ratio_spectral_over_rgb"] = round(out["numpy_spectral_ms"] / out["numpy_rgb_ms"], 3)
    out["cpu_ratio_spectral_over_rgb"] = round(out["cpu_spectral_ms"] / out["cpu_rgb_ms"], 3)
    print(json.dumps(out, indent=1))
    return 0
