"""Where a wash step of the ``cpu`` backend spends its time and its bytes (issue 26).

Times every fused sweep of ``station.backends.cpu.step`` on a fully wet canvas
(``station bench sim``'s wash) and sets beside each one the traffic that
``station/backends/cpu/traffic.py`` counts for it: the achieved GB/s per sweep
against the machine's copy bandwidth (measured in the same run) says which sweeps
are bound by memory and which by arithmetic.  Prints JSON.

    .venv/bin/python tools/profile_wash.py [--size 1024x1024] [--steps 20]

On a shared machine the means move with the load; the fastest step and each sweep's
fastest call (``min_ms``) are the figures closest to a quiet machine.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections import defaultdict
from typing import Any

from station.backends.cpu import fused as F
from station.backends.cpu import kernels as K
from station.backends.cpu.traffic import bytes_per_sweep
from station.backends.factory import create_backend
from station.bench._sim_driver import wash
from station.bench.sim import memory_bandwidth_gb_s

SWEEPS = {"prep": "prep", "advect_jacobi1": "advect_jacobi1",
          "jacobi_blocked": "jacobi_blocked", "limit_diffuse_fused": "limit_diffuse",
          "advect_fused": "advect", "evap_cap_fused": "evap_capillary",
          "standing_front": "standing_front"}
"""The sweeps of a step (the fused ones live in ``station.backends.cpu.fused``) and the
first word of their label in ``traffic.bytes_per_sweep`` (the front factor's sweep runs
only with several Jacobi iterations; with one it is part of advect_jacobi1's rows)."""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="1024x1024")
    ap.add_argument("--steps", type=int, default=20)
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    canvas: Any = create_backend("cpu", w, h, "watercolor", 1, tiling=False)
    wash(canvas, w, h)
    for _ in range(3):
        canvas.step()
    spent: dict[str, float] = defaultdict(float)
    fastest: dict[str, float] = defaultdict(lambda: float("inf"))
    home = {name: (F if hasattr(F, name) else K) for name in SWEEPS}
    originals = {name: getattr(home[name], name) for name in SWEEPS}

    def timed(name: str) -> Any:
        fn = originals[name]

        def call(*a: Any) -> Any:
            t0 = time.perf_counter()
            r = fn(*a)
            dt = time.perf_counter() - t0
            spent[name] += dt
            fastest[name] = min(fastest[name], dt)
            return r
        return call

    for name in SWEEPS:
        setattr(home[name], name, timed(name))
    load0 = os.getloadavg()
    t0 = time.perf_counter()
    step_min = float("inf")
    for _ in range(args.steps):
        t1 = time.perf_counter()
        canvas.step()
        step_min = min(step_min, time.perf_counter() - t1)
    total = time.perf_counter() - t0
    for name, fn in originals.items():
        setattr(home[name], name, fn)
    bw = memory_bandwidth_gb_s()
    st = canvas.live_state
    finv, fdry = st.params.standing_front()
    front = (1 if fdry > 0 else 0) if finv > 0 else -1  # as gl.traffic.front_mode
    per_sweep = bytes_per_sweep(max(len(st.slots), 1), int(st.params.jacobi_iters),
                                st.params.wet_hold > 0, front)
    cells = w * h * args.steps
    rows = []
    by_label = {label: name for name, label in SWEEPS.items()}
    for label, nbytes in per_sweep.items():
        name = by_label[label.split()[0]]
        s = spent[name]
        gbs = nbytes * cells / s / 1e9 if s > 0 else 0.0
        rows.append({"sweep": name, "counted": label, "bytes_per_cell": nbytes,
                     "ms_per_step": round(1e3 * s / args.steps, 3),
                     "min_ms": round(1e3 * fastest[name], 3) if s > 0 else 0.0,
                     "time_share": round(s / total, 3), "gb_s": round(gbs, 2),
                     "fraction_of_copy": round(gbs / bw, 3)})
    print(json.dumps({"size": args.size, "steps": args.steps,
                      "load_average": [round(x, 2) for x in load0],
                      "copy_bandwidth_gb_s": round(bw, 2),
                      "bytes_per_cell_step": sum(per_sweep.values()),
                      "step_ms": round(1e3 * total / args.steps, 2),
                      "fastest_step_ms": round(1e3 * step_min, 2),
                      "outside_sweeps_ms": round(1e3 * (total - sum(spent.values()))
                                                 / args.steps, 3),
                      "sweeps": rows}, indent=2))


if __name__ == "__main__":
    main()
