"""``station bench sim``: simulation speed of the canvas backends (issue 3 §9).

For each backend (by default every one that can run here: ``numpy``, ``cpu`` with
numba, ``gl`` when an OpenGL 4.3 context can be made), canvas size and scenario it measures
steps per second and cell-steps per second:

* ``wash``: the whole canvas wet (water and two pigments everywhere, a gentle
  velocity field), every tile active;
* ``stroke``: one live stroke on a dry canvas with dirty tiles on: a round
  footprint moving across the canvas, adding water and pigment every step.

Beside the speed it reports the copy bandwidth of the device each backend runs
on, measured in the same run, and, from the backend's own honest count of bytes
per cell-step (every field each pass must read and write, neighbours of a
stencil counted once), the fraction of that bandwidth the simulation achieves:
``bytes_per_cell_step · cell_steps_per_s / copy bandwidth``.  ``numpy`` and
``cpu`` run on the CPU: ``numpy.copyto`` of a 256 MiB array (read + write
counted).  ``gl`` runs on the GL device: the better of ``glCopyBufferSubData``
between two :data:`GL_COPY_BYTES` buffers and a compute shader copying one rgba32f
image into another, four per ``glFinish`` (read + write counted; both in
``bandwidth["gl_probes_gb_s"]``, and each GL result's ``shader_copy_fraction`` is
its traffic over the image copy's, the most any shader moves there, and ``bound_factor``
its inverse: how many times slower the step is than if it moved its bytes at that copy's
speed, issue 26 item 4 asks for <= 2; on a CPU rasterizer ``bound_factor_cpu`` is the
same by CPU time, the step's against the copy's ``image_cpu`` probe, which a machine
shared with other work disturbs far less than the wall clock); ``--passes`` adds a GL step's profile
(:func:`profile_passes`: milliseconds, share, bytes, GB/s and that fraction per program);
where no context can be made the fraction is ``null`` and
``bandwidth["gl_error"]`` says why.  ``bytes_per_cell_step`` lists each
backend's own count once more at the top level.  For the stroke scenario
cell-steps count the cells actually simulated (active tiles and their halo),
reported as ``active_cells``.

``realtime`` (issue 26 item 3; by default when ``--sizes`` is not given, or with
``--realtime``): a fully wet 1920x1080 and 3840x2160 canvas on the fastest CPU
backend, steps/s and the real-time factor (steps/s ÷ 30, the station's step
rate; ≥ 1 keeps real time).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from station.backends import choice
from station.backends.factory import (
    available_backends,
    create_backend,
    fastest_cpu_backend,
)
from station.bench import _sim_baseline as sim_baseline
from station.bench import _sim_driver as sim_driver
from station.errors import BadInput, StationError
from station.progress import Progress

DEFAULT_SIZES = ("512x512", "800x600", "1024x1024", "2048x2048")
REALTIME_SIZES = ((1920, 1080), (3840, 2160))
STEP_RATE = 30.0
"""Simulation steps per second of a station in real time (a step is 1/30 s)."""
SCENARIOS = ("wash", "stroke")
BACKENDS = ("gl", "numpy", "cpu")
"""Without ``--backends`` every one available here is measured
(:func:`station.backends.factory.available_backends`), the one ``auto`` picks included."""


def parse_size(text: str) -> tuple[int, int]:
    """``"800x600"`` → ``(800, 600)`` (width, height); bad text raises BadInput."""
    try:
        w_s, h_s = text.lower().split("x")
        w, h = int(w_s), int(h_s)
    except ValueError as exc:
        raise BadInput(f"size {text!r} is not WIDTHxHEIGHT", "--sizes") from exc
    if not (8 <= w <= 16384 and 8 <= h <= 16384):
        raise BadInput(f"size {text!r} outside 8..16384", "--sizes")
    return w, h


def memory_bandwidth_gb_s(nbytes: int = 256 << 20, repeats: int = 5) -> float:
    """Copy bandwidth of this machine in GB/s (read + write), best of ``repeats``."""
    src = np.ones(nbytes // 4, dtype=np.float32)
    dst = np.empty_like(src)
    np.copyto(dst, src)  # fault the pages in before timing
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        np.copyto(dst, src)
        best = min(best, time.perf_counter() - t0)
    return 2.0 * src.nbytes / best / 1e9


GL_COPY_BYTES = 128 << 20
GL_COPIES_PER_TIMING = 4

# The image-copy probe: one rgba32f texel per invocation, the storage and access the GL
# backend's passes use (image2D load/store), so the bound is one its shaders can reach.
_IMAGE_COPY = """#version 430
layout(local_size_x = %d, local_size_y = %d) in;
layout(rgba32f, binding = 0) uniform readonly image2D src;
layout(rgba32f, binding = 1) uniform writeonly image2D dst;
void main() {
    ivec2 c = ivec2(gl_GlobalInvocationID.xy);
    imageStore(dst, c, imageLoad(src, c));
}
"""


def gl_copy_bandwidth_gb_s(nbytes: int = GL_COPY_BYTES, repeats: int = 5) -> float:
    """Copy bandwidth of the GL device in GB/s (read + write), best of ``repeats``:
    a GPU's own memory on a real card, system memory through llvmpipe.  The better of
    two probes (:func:`gl_copy_probes`).  :class:`StationError` or ImportError when no
    GL context can be made."""
    probes = gl_copy_probes(nbytes, repeats)
    return max(probes["buffer"], probes["image"])


def gl_copy_probes(nbytes: int = GL_COPY_BYTES, repeats: int = 5) -> dict[str, float]:
    """Two copy probes of the GL device, GB/s (read + write), best of ``repeats``:

    * ``buffer``: ``glCopyBufferSubData`` between two buffers. llvmpipe does a memcpy;
      a discrete card may hand it to a DMA copy engine, far below its memory's speed
      (176 GB/s on an H100 whose HBM moves 3 TB/s);
    * ``image``: a compute shader copying one rgba32f image into another, the access
      the backend's own passes make; on a GPU this is what its cores reach;
    * ``image_cpu``: the same copy in GB per CPU-second of this process (a CPU
      rasterizer's cost; on a GPU it says nothing about the GPU).
    """
    # in the function: moderngl only when GL is measured
    from station.glkit.context import create_context

    ctx = create_context()
    out: dict[str, float] = {}
    try:
        src = ctx.buffer(reserve=nbytes)
        dst = ctx.buffer(reserve=nbytes)
        out["buffer"] = _best_gb_s(ctx, nbytes, repeats, lambda: ctx.copy_buffer(dst, src))
        src.release()
        dst.release()
        width = 4096
        height = max(16, nbytes // (16 * width))  # 16 bytes a texel
        a = ctx.texture((width, height), 4, dtype="f4")
        b = ctx.texture((width, height), 4, dtype="f4")
        a.bind_to_image(0, read=True, write=False)
        b.bind_to_image(1, read=False, write=True)
        best = best_cpu = 0.0
        # the work-group shape matters on llvmpipe (a row of 256 copies ~2x a 16x16 tile
        # there): the bound is the best shape's
        for lx, ly in ((16, 16), (64, 1), (256, 1)):
            prog = ctx.compute_shader(_IMAGE_COPY % (lx, ly))

            def copy(prog: Any = prog, lx: int = lx, ly: int = ly) -> None:
                prog.run(width // lx, -(-height // ly), 1)
                ctx.memory_barrier()  # each copy done before the next reads (as the passes)

            wall, cpu = _best_rates(ctx, width * height * 16, repeats, copy)
            best, best_cpu = max(best, wall), max(best_cpu, cpu)
            prog.release()
        out["image"] = best
        out["image_cpu"] = best_cpu
        a.release()
        b.release()
    finally:
        ctx.release()
    return out


def _best_gb_s(ctx: Any, nbytes: int, repeats: int, copy: Callable[[], None]) -> float:
    return _best_rates(ctx, nbytes, repeats, copy)[0]


def _best_rates(ctx: Any, nbytes: int, repeats: int, copy: Callable[[], None]
                ) -> tuple[float, float]:
    """GB/s (read + write) of the best of ``repeats`` batches of copies by the wall
    clock, and GB per CPU-second of this process (all threads: what a CPU rasterizer
    spends, which a machine shared with other work disturbs least)."""
    copy()  # allocate, compile and touch before timing
    ctx.finish()
    best = best_cpu = math.inf
    for _ in range(repeats):
        # a batch per glFinish: on a GPU one copy takes ~0.1 ms, near the round trip
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(GL_COPIES_PER_TIMING):
            copy()
        ctx.finish()
        best = min(best, (time.perf_counter() - t0) / GL_COPIES_PER_TIMING)
        best_cpu = min(best_cpu, (time.process_time() - c0) / GL_COPIES_PER_TIMING)
    return 2.0 * nbytes / best / 1e9, 2.0 * nbytes / max(best_cpu, 1e-9) / 1e9


def _cpu_rasterizer(renderer: str) -> bool:
    """Whether the GL renderer runs its shaders on the CPU (its CPU time is its cost)."""
    return any(k in renderer.lower() for k in ("llvmpipe", "softpipe", "swrast"))


@dataclass
class Result:
    """One measured configuration."""

    backend: str
    size: str
    scenario: str
    steps: int
    seconds: float
    cells_per_step: float
    bytes_per_cell_step: float
    renderer: str
    cpu_seconds: float = 0.0
    """This process's CPU time over the timed steps (all threads: llvmpipe's too)."""
    passes: dict[str, Any] | None = None
    """GL with ``--passes``: the step's time per program (see :func:`profile_passes`)."""

    def as_dict(self, bandwidth_gb_s: float | None) -> dict[str, Any]:
        """``bandwidth_gb_s``: the copy bandwidth of the device this backend ran on
        (``None``: unknown, and so is the fraction)."""
        steps_per_s = self.steps / self.seconds
        cell_steps = steps_per_s * self.cells_per_step
        traffic = cell_steps * self.bytes_per_cell_step / 1e9
        return {
            "backend": self.backend,
            "size": self.size,
            "scenario": self.scenario,
            "steps": self.steps,
            "seconds": round(self.seconds, 4),
            "steps_per_s": round(steps_per_s, 3),
            "cell_steps_per_s": round(cell_steps, 1),
            "active_cells": round(self.cells_per_step, 1),
            "bytes_per_cell_step": self.bytes_per_cell_step,
            "memory_traffic_gb_s": round(traffic, 4),
            "bandwidth_gb_s": None if bandwidth_gb_s is None else round(bandwidth_gb_s, 3),
            "bandwidth_fraction": (None if bandwidth_gb_s is None
                                   else round(traffic / bandwidth_gb_s, 4)),
            "renderer": self.renderer,
            "cpu_seconds": round(self.cpu_seconds, 4),
            **({"passes": self.passes} if self.passes is not None else {}),
        }


class _Probe:
    """Backend-neutral access to what the benchmark needs beyond the protocol.

    GL: ``take_cells()`` (the GPU tile list's running count of simulated cells, read
    once per measurement) and ``sync()``; NumPy: ``cells_last_step()`` after every
    step.  Both report their own honest ``bytes_per_cell_step()`` (see
    ``station/backends/gl/traffic.py``, ``numpy_canvas.floats_per_cell_step`` and
    ``station/backends/cpu/traffic.py``).  The ``cpu`` backend is stepped like NumPy.
    """

    def __init__(self, canvas: Any) -> None:  # reads each backend's own counters
        self.canvas = canvas
        self.is_gl = hasattr(canvas, "take_cells")

    def sync(self) -> None:
        if hasattr(self.canvas, "sync"):
            self.canvas.sync()

    def cells_after_step(self) -> int:
        """NumPy: cells the step just simulated (the GPU counts on its own)."""
        if self.is_gl:
            return 0
        if hasattr(self.canvas, "cells_last_step"):
            return int(self.canvas.cells_last_step())
        st = self.canvas.live_state
        return int(st.width * st.height)

    def take_cells(self) -> int:
        return int(self.canvas.take_cells()) if self.is_gl else 0

    def bytes_per_cell_step(self) -> int:
        return int(self.canvas.bytes_per_cell_step())

    def close(self) -> None:
        if hasattr(self.canvas, "close"):
            self.canvas.close()


_pigments = sim_driver.pigments
_wash = sim_driver.wash
_StrokePath = sim_driver.StrokePath


PROFILE_STEPS = 3
"""Steps of a ``--passes`` profile (after the timed run, on the same canvas)."""


def profile_passes(canvas: Any, stroke: sim_driver.StrokePath | None,
                   steps: int = PROFILE_STEPS) -> dict[str, Any]:
    """Where a GL step's time goes: each program's wall time (a ``glFinish`` around every
    dispatch, so nothing overlaps) over ``steps`` steps, its share of the passes' time, its
    own honest bytes per cell (``station/backends/gl/traffic.py``) and the traffic that
    makes, in GB/s.  The passes' bandwidths against a copy probe show which pass is far
    from its bound; ``step_ms`` (profiled) is above an unprofiled step by the finishes."""
    canvas.sync()
    canvas.take_cells()
    canvas.profile_passes(True)
    t0 = time.perf_counter()
    for _ in range(steps):
        if stroke:
            stroke.advance()
        canvas.step()
    canvas.sync()
    elapsed = time.perf_counter() - t0
    times = canvas.take_pass_times()
    canvas.profile_passes(False)
    cells = canvas.take_cells() / steps
    per_cell = canvas.bytes_per_cell_by_pass()
    total = sum(times.values())
    out: dict[str, Any] = {}
    for name, sec in sorted(times.items(), key=lambda kv: -kv[1]):
        ms = 1e3 * sec / steps
        nbytes = per_cell.get(name)
        out[name] = {"ms": round(ms, 3), "share": round(sec / total, 4),
                     "bytes_per_cell": nbytes,
                     "gb_s": (None if nbytes is None or ms <= 0
                              else round(nbytes * cells / (ms * 1e6), 4))}
    return {"steps": steps, "step_ms": round(1e3 * elapsed / steps, 3),
            "active_cells": round(cells, 1), "programs": out}


def measure(backend: str, width: int, height: int, scenario: str, seconds: float,
            min_steps: int = 3, warmup: int = 10, passes: bool = False) -> Result:
    """Run one configuration for about ``seconds`` (after ``warmup`` steps); ``passes``:
    then profile a GL step pass by pass (:func:`profile_passes`)."""
    canvas = create_backend(backend, width, height, "watercolor", 1,
                            tiling=(scenario == "stroke"))
    probe = _Probe(canvas)
    stroke = None
    if scenario == "wash":
        _wash(canvas, width, height)
    else:
        stroke = _StrokePath(canvas, width, height)
    # warm-up: compile shaders, fault memory in, let the stroke build its trail of tiles
    for _ in range(warmup):
        if stroke:
            stroke.advance()
        canvas.step()
    probe.sync()
    probe.take_cells()
    steps, cells = 0, 0
    t0 = time.perf_counter()
    c0 = time.process_time()
    while True:
        if stroke:
            stroke.advance()
        canvas.step()
        cells += probe.cells_after_step()
        steps += 1
        if steps >= min_steps and (steps % 4 == 0 or not probe.is_gl):
            probe.sync()
            if time.perf_counter() - t0 >= seconds:
                break
    probe.sync()
    elapsed = time.perf_counter() - t0
    cpu = time.process_time() - c0
    cells += probe.take_cells()
    result = Result(backend, f"{width}x{height}", scenario, steps, elapsed, cells / steps,
                    float(probe.bytes_per_cell_step()), str(canvas.renderer), cpu)
    if passes and probe.is_gl:
        result.passes = profile_passes(canvas, stroke)
    probe.close()
    return result


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("sim", help="canvas simulation speed of the backends (JSON)")
    p.add_argument("--json", action="store_true", help="print JSON (the default output too)")
    p.add_argument("--sizes", default=",".join(DEFAULT_SIZES),
                   help="comma-separated WIDTHxHEIGHT list (default: %(default)s)")
    p.add_argument("--backends", default=None,
                   help="gl,numpy,cpu or some of them (default: every one available here)")
    p.add_argument("--scenarios", default=",".join(SCENARIOS), help="wash,stroke or one")
    p.add_argument("--seconds", type=float, default=3.0,
                   help="measuring time per configuration (default %(default)s s)")
    p.add_argument("--realtime", action=argparse.BooleanOptionalAction, default=None,
                   help="measure the fully wet 1920x1080 and 3840x2160 canvas on the cpu "
                        "backend (default: when --sizes is not given)")
    p.add_argument("--passes", action="store_true",
                   help="gl: after each run, profile a few steps pass by pass (time, share, "
                        "bytes and GB/s per program)")
    p.add_argument("--quick", action="store_true",
                   help="800x600 only, 1 s per configuration")
    p.add_argument("--baseline", metavar="REV", default=None,
                   help="instead: compare this tree with git commit REV in one run (one "
                        "backend, default cpu; one size, default 800x600): alternating "
                        "fixed-step runs, steps/s and the wash's cost ratio (issue 10)")
    p.add_argument("--rounds", type=int, default=5,
                   help="--baseline: alternating rounds per scenario (default %(default)s)")
    p.set_defaults(func=run)


def run_baseline(args: argparse.Namespace) -> int:
    """``--baseline REV``: :func:`station.bench._sim_baseline.compare`, printed as JSON."""
    backends = [b for b in (args.backends or "cpu").split(",") if b]
    sizes = [s for s in args.sizes.split(",") if s]
    if args.sizes == ",".join(DEFAULT_SIZES) or args.quick:
        sizes = ["800x600"]
    if len(backends) != 1 or backends[0] not in BACKENDS:
        raise BadInput(f"{args.backends!r}: --baseline compares one backend (gl, numpy, cpu)",
                       "--backends")
    if len(sizes) != 1:
        raise BadInput(f"{args.sizes!r}: --baseline compares one size", "--sizes")
    w, h = parse_size(sizes[0])
    scenarios = [s for s in args.scenarios.split(",") if s]
    for s in scenarios:
        if s not in SCENARIOS:
            raise BadInput(f"unknown scenario {s!r} (wash, stroke)", "--scenarios")
    if not 1 <= args.rounds <= 50:
        raise BadInput(f"{args.rounds} outside [1, 50]", "--rounds")
    load_before = [round(x, 2) for x in os.getloadavg()]
    bar = Progress(len(scenarios) * args.rounds * 2, "bench sim --baseline", unit="run")

    def note(text: str) -> None:
        bar.note(text)
        bar.update()

    try:
        out = sim_baseline.compare(args.baseline, backends[0], w, h, scenarios, args.rounds,
                                   note)
    finally:
        bar.close()
    out["load_average_before"] = load_before
    print(json.dumps(out, indent=2))
    return 0


def _cached_auto() -> str | None:
    """What ``--backend auto`` picks here if it has measured already (None if not): the
    bench does not start the probe itself (on a GPU machine's first run, a minute or two
    of numba compiles in its child), and ``station doctor`` measures and shows it."""
    cached = choice.load()
    return cached.backend if cached is not None else None


def run(args: argparse.Namespace) -> int:
    if args.baseline is not None:
        return run_baseline(args)
    sizes = ["800x600"] if args.quick else [s for s in args.sizes.split(",") if s]
    seconds = 1.0 if args.quick else args.seconds
    if not seconds > 0:
        raise BadInput("must be > 0", "--seconds")
    dims = [parse_size(s) for s in sizes]
    if args.backends is None:
        backends = available_backends()
    else:
        backends = [b for b in args.backends.split(",") if b]
    scenarios = [s for s in args.scenarios.split(",") if s]
    for b in backends:
        if b not in BACKENDS:
            raise BadInput(f"unknown backend {b!r} (gl, numpy, cpu)", "--backends")
    for s in scenarios:
        if s not in SCENARIOS:
            raise BadInput(f"unknown scenario {s!r} (wash, stroke)", "--scenarios")
    bandwidth = memory_bandwidth_gb_s()
    device_bw: dict[str, float | None] = {"numpy": bandwidth, "cpu": bandwidth}
    bw_out: dict[str, Any] = {"cpu_gb_s": round(bandwidth, 3)}
    gl_probes: dict[str, float] = {}
    if "gl" in backends:
        try:
            gl_probes = gl_copy_probes()
        except (StationError, ImportError) as exc:
            device_bw["gl"] = None
            bw_out["gl_gb_s"] = None
            bw_out["gl_error"] = " ".join(str(exc).split())[:300]
        else:
            gl_bw = max(gl_probes["buffer"], gl_probes["image"])
            device_bw["gl"] = gl_bw
            bw_out["gl_gb_s"] = round(gl_bw, 3)
            bw_out["gl_probes_gb_s"] = {k: round(v, 3) for k, v in gl_probes.items()}
    per_cell: dict[str, float] = {}
    results: list[dict[str, Any]] = []
    renderer = "numpy"
    bar = Progress(len(backends) * len(dims) * len(scenarios), "bench sim", unit="run")
    for backend in backends:
        for w, h in dims:
            for scenario in scenarios:
                bar.note(f"{backend} {w}x{h} {scenario}")
                try:
                    r = measure(backend, w, h, scenario, seconds, passes=args.passes)
                except (StationError, ImportError) as exc:
                    results.append({"backend": backend, "size": f"{w}x{h}",
                                    "scenario": scenario, "error": str(exc)})
                    bar.update()
                    continue
                if backend == "gl":
                    renderer = r.renderer
                per_cell.setdefault(backend, r.bytes_per_cell_step)
                results.append(r.as_dict(device_bw.get(backend)))
                if backend == "gl" and gl_probes.get("image"):
                    # the bound a shader can reach on this device (llvmpipe's image copy
                    # runs far below its memcpy): what "its own bound" means for GL passes
                    frac = results[-1]["memory_traffic_gb_s"] / gl_probes["image"]
                    results[-1]["shader_copy_fraction"] = round(frac, 4)
                    # issue 26 item 4: within 2x of that bound means a bound_factor <= 2
                    results[-1]["bound_factor"] = round(1.0 / frac, 3) if frac > 0 else None
                    if (gl_probes.get("image_cpu") and r.cpu_seconds > 0
                            and _cpu_rasterizer(r.renderer)):
                        # the same by CPU time, the step's against the image copy's: on a
                        # CPU rasterizer sharing its cores the wall clock swings with how
                        # many cores it got, its CPU time far less
                        traffic_cpu = (r.steps * r.cells_per_step * r.bytes_per_cell_step
                                       / r.cpu_seconds / 1e9)
                        results[-1]["bound_factor_cpu"] = round(
                            gl_probes["image_cpu"] / traffic_cpu, 3)
                    for prog in (r.passes or {}).get("programs", {}).values():
                        prog["shader_copy_fraction"] = (
                            None if prog["gb_s"] is None
                            else round(prog["gb_s"] / gl_probes["image"], 4))
                bar.write(f"bench sim: {backend} {w}x{h} {scenario}: "
                          f"{results[-1]['steps_per_s']} steps/s")
                bar.update()
    realtime: list[dict[str, Any]] = []
    want_rt = args.realtime if args.realtime is not None else (
        args.sizes == ",".join(DEFAULT_SIZES) and not args.quick)
    if want_rt:
        rt_backend = fastest_cpu_backend()
        for w, h in REALTIME_SIZES:
            bar.write(f"bench sim: realtime {rt_backend} {w}x{h} wash")
            r = measure(rt_backend, w, h, "wash", seconds, warmup=3)
            d = r.as_dict(device_bw.get(rt_backend))
            d["realtime_factor"] = round(d["steps_per_s"] / STEP_RATE, 3)
            d["goal_steps_per_s"] = STEP_RATE
            realtime.append(d)
    bar.close()
    out = {"renderer": renderer, "memory_bandwidth_gb_s": round(bandwidth, 3),
           "bandwidth": bw_out, "bytes_per_cell_step": per_cell,
           "load_average": [round(x, 2) for x in os.getloadavg()],
           "auto": _cached_auto(), "results": results, "realtime": realtime}
    print(json.dumps(out, indent=2))
    return 0
