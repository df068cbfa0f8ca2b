"""``station bench peer``: the station beside Open-Watercolor-Sim, the closest public
peer (issue 26 item 2), measured in one run.

The peer is a Taichi watercolor simulation (github.com/ShuoqiChen/Open-Watercolor-Sim,
Apache-2.0; measured at commit a5b7cad).  It is not a dependency: install it beside
the station to compare::

    pip install taichi==1.7.4 pillow     # from the registry, into any Python >= 3.9
                                         # (the peer imports PIL)
    git clone https://github.com/ShuoqiChen/Open-Watercolor-Sim
    station bench peer --peer-src Open-Watercolor-Sim/src [--peer-python PY]

(``--peer-python``: an interpreter with taichi, if not the station's own.)  Both sides
run in fresh child processes, interleaved (station, peer, peer, station, …: the order
alternates pair by pair so a drift in the machine's load falls on both), on
``--threads`` CPU threads each (numba's ``NUMBA_NUM_THREADS``; Taichi's
``cpu_max_num_threads``), each scenario on a fresh canvas after a warm-up (numba's
cache, Taichi's JIT), after which both sides freeze what start-up made out of the
garbage collector's sight (as the kiosk does: a full collection of the station's
import-time objects takes 20-50 ms, a fifth of a 512x512 stroke's 50 timed steps, and
where one falls depends only on how many objects each side made before):

* ``wash``: the whole square canvas wet (the station: ``bench sim``'s wash; the peer:
  ``paint_mask`` of ones for water and pigment), then ``--steps`` timed steps;
* ``stroke``: one stroke of 40 round stamps (radius 12) across the canvas, then
  ``--steps`` timed steps (the station with dirty tiles, as it paints live).

Reported per scenario and size: each side's steps/s in every pair, the ratio
(station ÷ peer) per pair and its median; also the ratio of simulated seconds per
second (the station's step is 1/30 s, the peer's 1/60 s: the same steps/s is twice the
simulated time).  The load average before and after is part of the JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path
from typing import Any

from station.errors import BadInput, StationError

PEER_REPO = "https://github.com/ShuoqiChen/Open-Watercolor-Sim"
INSTALL = (f"pip install taichi==1.7.4 pillow; git clone {PEER_REPO}; "
           "station bench peer --peer-src Open-Watercolor-Sim/src")
STATION_DT = 1.0 / 30.0
PEER_DT = 1.0 / 60.0
CHILD_TIMEOUT_S = 900.0

_SETTLE = r"""
import gc

def settle():
    # what start-up and the warm-up made lives as long as the process: frozen out of the
    # collector's sight, as the kiosk does at start-up (KioskApp._take_over_full_collections),
    # so a full collection of the import's objects (20-50 ms in the station's process)
    # does not land in either side's timed steps
    gc.collect()
    gc.freeze()
"""

_STATION_CHILD = _SETTLE + r"""
import json, sys, time
import numpy as np
from station.backends.factory import create_backend
from station.bench._sim_driver import wash
sizes, steps = json.loads(sys.argv[1]), int(sys.argv[2])

def stroke(canvas, n):
    r = 12.0
    for k in range(40):
        x = 2 * r + (n - 4 * r) * k / 39.0
        y = n / 2 + n / 6 * np.sin(x / 60.0)
        x0, x1, y0, y1 = int(x - r - 1), int(x + r + 2), int(y - r - 1), int(y + r + 2)
        yy, xx = np.mgrid[y0:y1, x0:x1]
        disc = ((xx + 0.5 - x) ** 2 + (yy + 0.5 - y) ** 2 <= r * r).astype(np.float32)
        canvas.add_sources(dw=0.3 * disc, dp={"French Ultramarine": 0.02 * disc},
                           dvx=12.0 * disc, dvy=0.0 * disc, y0=y0, x0=x0)

out = {}
for n in sizes:
    for scenario in ("wash", "stroke"):
        canvas = create_backend("cpu", n, n, "watercolor", 1, tiling=(scenario == "stroke"))
        wash(canvas, n, n) if scenario == "wash" else stroke(canvas, n)
        for _ in range(3):
            canvas.step()
        settle()
        canvas = create_backend("cpu", n, n, "watercolor", 1, tiling=(scenario == "stroke"))
        wash(canvas, n, n) if scenario == "wash" else stroke(canvas, n)
        t0 = time.perf_counter()
        for _ in range(steps):
            canvas.step()
        out[f"{scenario}@{n}"] = steps / (time.perf_counter() - t0)
print(json.dumps(out))
"""

_PEER_CHILD = _SETTLE + r"""
import contextlib, io, json, sys, time
import numpy as np
import taichi as ti
sizes, steps, threads = json.loads(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
with contextlib.redirect_stdout(io.StringIO()):
    ti.init(arch=ti.cpu, cpu_max_num_threads=threads, offline_cache=True)
    import open_watercolor_sim.brush.watercolor_engine as we
    we._GLOBAL_TAICHI_INITIALIZED = True  # keep our thread count

def wet(e, n):
    ones = np.ones((n, n), np.float32)
    e.paint_mask(ones, ones)

def stroke(e, n):
    r = 12
    for k in range(40):
        x = 2 * r + (n - 4 * r) * k / 39.0
        y = n / 2 + n / 6 * np.sin(x / 60.0)
        e.paint_brush(x, y, r, 0, 0.3)

out = {}
for n in sizes:
    with contextlib.redirect_stdout(io.StringIO()):
        e = we.WatercolorEngine(res=n, arch="cpu")
    for scenario in ("wash", "stroke"):
        for timed in (False, True):  # the first pass compiles (Taichi's JIT)
            if timed:
                settle()
            e.clear()
            wet(e, n) if scenario == "wash" else stroke(e, n)
            ti.sync()
            t0 = time.perf_counter()
            for _ in range(steps if timed else 3):
                e.step()
            ti.sync()
            if timed:
                out[f"{scenario}@{n}"] = steps / (time.perf_counter() - t0)
print(json.dumps(out))
"""


def _run_child(argv: list[str], env: dict[str, str], what: str) -> dict[str, float]:
    try:
        proc = subprocess.run(argv, capture_output=True, text=True, env=env,
                              timeout=CHILD_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        raise StationError(f"bench peer: the {what} run took over {CHILD_TIMEOUT_S:g} s"
                           ) from None
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["no message"])[-1]
        raise StationError(f"bench peer: the {what} run failed: {last}")
    lines = proc.stdout.strip().splitlines()
    try:
        data = json.loads(lines[-1])
    except (IndexError, ValueError):
        raise StationError(f"bench peer: the {what} run printed no figures") from None
    return {str(k): float(v) for k, v in data.items()}


def peer_problem(python: str, src: Path | None) -> str | None:
    """Why the peer cannot run here (``None``: it can)."""
    if src is None:
        return "no peer source given (--peer-src or $OPEN_WATERCOLOR_SIM_SRC)"
    if not (src / "open_watercolor_sim" / "brush" / "watercolor_engine.py").is_file():
        return f"{src}: not the peer's src/ (no open_watercolor_sim/brush/watercolor_engine.py)"
    proc = subprocess.run([python, "-c", "import taichi"], capture_output=True, text=True,
                          check=False)
    if proc.returncode != 0:
        return f"{python}: cannot import taichi"
    return None


def compare(sizes: list[int], pairs: int, steps: int, threads: int, python: str,
            src: Path) -> dict[str, Any]:
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads))
    peer_env = dict(env, PYTHONPATH=str(src), TI_LOG_LEVEL="error")
    load_before = [round(x, 2) for x in os.getloadavg()]
    runs: dict[str, list[dict[str, float]]] = {"station": [], "peer": []}
    station_argv = [sys.executable, "-c", _STATION_CHILD, json.dumps(sizes), str(steps)]
    peer_argv = [python, "-c", _PEER_CHILD, json.dumps(sizes), str(steps), str(threads)]
    for p in range(pairs):
        order = ("station", "peer") if p % 2 == 0 else ("peer", "station")
        for side in order:
            if side == "station":
                runs["station"].append(_run_child(station_argv, env, "station"))
            else:
                runs["peer"].append(_run_child(peer_argv, peer_env, "peer"))
    results = []
    for key in runs["station"][0]:
        scenario, n = key.split("@")
        st = [r[key] for r in runs["station"]]
        pe = [r[key] for r in runs["peer"]]
        ratios = [a / b for a, b in zip(st, pe, strict=True)]
        med = statistics.median(ratios)
        results.append({"scenario": scenario, "size": f"{n}x{n}",
                        "station_steps_per_s": [round(v, 2) for v in st],
                        "peer_steps_per_s": [round(v, 2) for v in pe],
                        "ratios": [round(v, 3) for v in ratios],
                        "median_ratio": round(med, 3),
                        "median_sim_time_ratio": round(med * STATION_DT / PEER_DT, 3),
                        "goal_ratio": 2.0})
    return {"peer": {"repo": PEER_REPO, "src": str(src), "python": python},
            "threads": threads, "pairs": pairs, "steps": steps,
            "load_average_before": load_before,
            "load_average_after": [round(x, 2) for x in os.getloadavg()],
            "results": results}


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("peer", help="the station beside Open-Watercolor-Sim (Taichi), "
                                    "interleaved (JSON)")
    p.add_argument("--json", action="store_true", help="print JSON (the default output too)")
    p.add_argument("--peer-src", type=Path, default=None,
                   help="the peer's src/ directory (default $OPEN_WATERCOLOR_SIM_SRC)")
    p.add_argument("--peer-python", default=sys.executable,
                   help="a Python with taichi installed (default: this one)")
    p.add_argument("--sizes", default="512,1024", help="square canvas sides (default %(default)s)")
    p.add_argument("--pairs", type=int, default=3, help="interleaved pairs (default %(default)s)")
    p.add_argument("--steps", type=int, default=50, help="timed steps (default %(default)s)")
    p.add_argument("--threads", type=int, default=2, help="CPU threads each (default %(default)s)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    try:
        sizes = [int(s) for s in args.sizes.split(",") if s]
    except ValueError:
        raise BadInput(f"{args.sizes!r} is not a list of sides", "--sizes") from None
    if not sizes or any(not 64 <= n <= 8192 for n in sizes):
        raise BadInput(f"{args.sizes!r}: sides in [64, 8192]", "--sizes")
    if not 1 <= args.pairs <= 20:
        raise BadInput(f"{args.pairs} outside [1, 20]", "--pairs")
    if not 1 <= args.steps <= 10000:
        raise BadInput(f"{args.steps} outside [1, 10000]", "--steps")
    if not 1 <= args.threads <= 256:
        raise BadInput(f"{args.threads} outside [1, 256]", "--threads")
    src_text = args.peer_src or os.environ.get("OPEN_WATERCOLOR_SIM_SRC")
    src = Path(src_text) if src_text else None
    problem = peer_problem(args.peer_python, src)
    if problem is not None or src is None:
        print(json.dumps({"error": problem, "how_to_install": INSTALL}, indent=2))
        print(f"bench peer: {problem}; to install the peer: {INSTALL}", file=sys.stderr)
        return 1
    print(json.dumps(compare(sizes, args.pairs, args.steps, args.threads, args.peer_python,
                             src), indent=2))
    return 0
