"""What cheaper storage and fewer Jacobi sweeps would cost the picture (issue 26 item 1).

Runs the same painting on the ``cpu`` backend several ways and compares each with the
exact run: a full wet wash (``station bench sim``'s) over a stroke of pigment, then a
few hundred steps while it dries.  Variants:

* ``jacobi=N``: ``SimParams.jacobi_iters`` = N instead of the profile's (each sweep of
  the implicit diffusions is arithmetic the temporally blocked sweep pays for);
* ``f16:FIELD``: the state field rounded to float16 after every step (what storing it
  in half precision between steps would do; within a step the sweeps still work in
  float32);
* ``u8:h``: the paper height stored in 8 bits (it is static: one rounding).

For each: the largest and mean difference of the rendered picture (0-255 levels of
8-bit sRGB), the relative difference of the water and pigment totals, and the time per
step of the whole run (load average stated).  Prints JSON.

    .venv/bin/python tools/precision_study.py [--size 256x256] [--steps 200]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from station.backends.factory import create_backend
from station.bench._sim_driver import StrokePath, wash
from station.canvas.profiles import get_profile

F16_FIELDS = ("w", "wc", "vx", "vy", "p", "q", "evaporated")


def _run(w: int, h: int, steps: int, jacobi: int | None,
         hook: Callable[[Any], None] | None, prep: Callable[[Any], None] | None
         ) -> tuple[np.ndarray, float, float, float]:
    kw: dict[str, Any] = {}
    if jacobi is not None:
        base = get_profile("watercolor").params
        kw["params"] = dataclasses.replace(base, jacobi_iters=jacobi)
    canvas: Any = create_backend("cpu", w, h, "watercolor", 1, tiling=False, **kw)
    if prep is not None:
        prep(canvas.live_state)
    wash(canvas, w, h)
    stroke = StrokePath(canvas, w, h)
    t0 = time.perf_counter()
    for k in range(steps):
        if k < 30:
            stroke.advance()
        canvas.step()
        if hook is not None:
            hook(canvas.live_state)
    dt = (time.perf_counter() - t0) / steps
    st = canvas.live_state
    water = float(st.w.sum(dtype=np.float64) + st.wc.sum(dtype=np.float64))
    pigment = float(st.p.sum(dtype=np.float64) + st.q.sum(dtype=np.float64))
    return np.asarray(canvas.render()), water, pigment, dt


def _f16(name: str) -> Callable[[Any], None]:
    def hook(st: Any) -> None:
        a = getattr(st, name)
        a[...] = a.astype(np.float16).astype(np.float32)
    return hook


def _u8_h(st: Any) -> None:
    st.h[...] = np.round(st.h * 255.0) / 255.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="256x256")
    ap.add_argument("--steps", type=int, default=200)
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    load0 = [round(x, 2) for x in os.getloadavg()]
    _run(w, h, 5, None, None, None)  # numba's cache loaded before anything is timed
    ref, water0, pig0, t_ref = _run(w, h, args.steps, None, None, None)
    variants: list[tuple[str, int | None, Callable[[Any], None] | None,
                         Callable[[Any], None] | None]] = [
        ("jacobi=3", 3, None, None), ("jacobi=2", 2, None, None), ("jacobi=1", 1, None, None),
        ("u8:h", None, None, _u8_h)]
    variants += [(f"f16:{f}", None, _f16(f), None) for f in F16_FIELDS]
    rows = []
    for name, jac, hook, prep in variants:
        img, water, pig, t = _run(w, h, args.steps, jac, hook, prep)
        d = np.abs(img.astype(np.float64) - ref.astype(np.float64))
        if img.dtype != np.uint8:
            d = d * 255.0
        rows.append({"variant": name, "max_levels": round(float(d.max()), 3),
                     "mean_levels": round(float(d.mean()), 4),
                     "water_rel": float(f"{(water - water0) / water0:.3g}"),
                     "pigment_rel": float(f"{(pig - pig0) / pig0:.3g}"),
                     "step_ms": round(1e3 * t, 3), "time_ratio": round(t / t_ref, 3)})
    print(json.dumps({"size": args.size, "steps": args.steps, "load_average": load0,
                      "reference_step_ms": round(1e3 * t_ref, 3), "variants": rows},
                     indent=2))


if __name__ == "__main__":
    main()
