"""Fill numba's on-disk cache with the cpu step's kernels, in parallel processes.

A fresh checkout compiles the step's kernels on its first cpu step: about 140 s of CPU
on one core (session 13, measured with numba's compile events on a 40x32 wash: five
parallel kernels are 95 % of it, ``limit_diffuse_fused`` alone 40 %).  numba compiles
one function at a time, so a first ``station demo`` waits for all of it on one core,
and ``make test``'s two workers each compiled all of it at once (both cores busy with
the same work for minutes).  Here the parallel kernels are split in two shares, each
compiled by its own process, which runs one small wash step with the other share's
kernels skipped (every parallel kernel writes its outputs and returns nothing, so a
skipped one only leaves zeros, of the right types, for the next).  A kernel compiled
here is compiled for the types a real step passes it, so every later process loads it
from the cache.  The serial span kernels run in both (the step's control flow reads
their output); they are small.

``python -m station.backends.cpu.warm`` (``make test`` and ``make demo`` run it first);
``--jobs 1`` compiles both shares in this process.  Nothing is compiled twice when the
cache is already warm: each share then only loads.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from types import ModuleType
from typing import NoReturn

import numpy as np
from numba.core.registry import CPUDispatcher

from station.backends.cpu import fused as F
from station.backends.cpu import kernels as K
from station.backends.cpu.canvas import CpuCanvas

# The first share: about half of the compile time (limit_diffuse_fused ~40 %, prep ~8 %);
# every other parallel kernel is the second's, new ones included.
FIRST = ("limit_diffuse_fused", "prep")
SHARES = 2


def parallel_kernels() -> dict[str, tuple[ModuleType, CPUDispatcher]]:
    """The step's parallel kernels by name, with the module the step calls them from."""
    out: dict[str, tuple[ModuleType, CPUDispatcher]] = {}
    for mod in (K, F):
        for name, obj in vars(mod).items():
            if isinstance(obj, CPUDispatcher) and obj.targetoptions.get("parallel"):
                out[name] = (mod, obj)
    return out


def share_of(name: str) -> int:
    return 0 if name in FIRST else 1


def _skipper(name: str) -> object:
    """What stands for the other share's kernel ``name`` while a share runs its step."""
    def skip(*_args: object) -> None:
        return None
    return skip


def _one_step() -> None:
    """A small wash, stepped twice (the first step and a step of a wet canvas)."""
    canvas = CpuCanvas(40, 32, "watercolor", 0)
    dw = np.zeros((32, 40), np.float32)
    dw[6:26, 6:34] = 0.6
    canvas.add_sources(dw, {"French Ultramarine": 0.5 * dw})
    canvas.step()
    canvas.step()


def compile_share(share: int) -> list[str]:
    """Compile (or load) one share's kernels; the names that now have a compiled version."""
    kernels = parallel_kernels()
    mine = {n for n in kernels if share_of(n) == share}
    try:
        for name, (mod, _disp) in kernels.items():
            if name not in mine:
                setattr(mod, name, _skipper(name))
        _one_step()
    finally:
        for name, (mod, disp) in kernels.items():
            setattr(mod, name, disp)
    return sorted(n for n in mine if kernels[n][1].signatures)


class _OneLine(argparse.ArgumentParser):
    """Bad flags: exit 2 with one line (as ``station``'s own parser; not imported from
    the CLI, which sits above the backends)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: {message}\n")


def main(argv: list[str] | None = None) -> int:
    ap = _OneLine(prog="python -m station.backends.cpu.warm",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=min(SHARES, os.cpu_count() or 1),
                    help="processes compiling at once (default: 2, or 1 on one core)")
    ap.add_argument("--share", type=int, choices=range(SHARES), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.jobs < 1:
        ap.error(f"--jobs {args.jobs}: at least 1")
    t0 = time.monotonic()
    if args.share is not None:
        compile_share(args.share)
        return 0
    if args.jobs == 1:
        for k in range(SHARES):
            compile_share(k)
    else:
        procs = [subprocess.Popen([sys.executable, "-m", "station.backends.cpu.warm",
                                   "--share", str(k)]) for k in range(SHARES)]
        codes = [p.wait() for p in procs]
        if any(codes):
            print(f"cpu kernels: a compiling process failed (exit codes {codes})",
                  file=sys.stderr)
            return 1
    print(f"cpu kernels compiled or loaded into numba's cache in "
          f"{time.monotonic() - t0:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
