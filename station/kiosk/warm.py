"""Compile (or load from numba's cache) every kernel a visitor's first minute at the
kiosk runs, before the window takes the pen.

numba compiles a kernel on its first call, holding the interpreter lock: a kiosk fresh
from ``make`` (whose warm-up, :mod:`station.backends.cpu.warm`, fills the cache with the
canvas step's kernels only) compiled the display's kernels (the sub-cell fields, the
changed-texel box, the compiled Kubelka-Munk) during the first visitor's first stroke, and
each deformable brush's kernels at the first pick of that brush: the pen's samples waited
4.3-4.7 s (``station bench latency``'s first run from an empty cache, read-to-handled p95
4.2 s).  Even from a warm cache, loading the step's kernels took ~0.3 s of the first
step.  :func:`warm` runs all of them once on a small canvas, with the same argument types
as the kiosk passes (array layouts included: a region cut from a canvas is not
contiguous, the whole of a small canvas is), so the kiosk calls it before its first
frame and ``make`` runs it (``python -m station.kiosk.warm``) after the step's warm-up.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import NoReturn

import numpy as np

from station.backends.factory import create_backend
from station.brush.stamp import brush_kinds
from station.canvas.profiles import get_profile
from station.canvas.state import CanvasState
from station.kiosk import display, subcell
from station.render.km import region_amount
from station.render.km_fast import km_layer_fast
from station.sim.player import SessionPlayer
from station.sim.script import Script

F32 = np.float32
WIDTH, HEIGHT = 48, 40
"""The warm-up canvas [cells]: room for a stroke of every brush kind, one row each."""


def _session(kinds: tuple[str, ...], pigments: tuple[str, str]) -> Script:
    """One short stroke of each brush kind (the deformable ones' solver, footprints and
    reservoir; the round brush's stamps and bead), a stroke into the wet paint, a wait
    while it flows and a ``dry``; ``pigments``: two of the profile's palette."""
    s = Script(WIDTH, HEIGHT, seed=1)
    rows = max(1, len(kinds))
    for i, kind in enumerate(kinds):
        y = (i + 0.5) / rows
        s.brush(size=6, water=0.8, pigment={pigments[0]: 0.6}, kind=kind)
        s.line((0.15, y), (0.85, y), 0.2, pressure=0.7)
    s.brush(size=8, water=1.0, pigment={pigments[1]: 0.5})
    s.line((0.5, 0.1), (0.5, 0.9), 0.2, pressure=0.7)
    s.wait(0.2)
    s.dry()
    s.line((0.2, 0.2), (0.8, 0.8), 0.2, pressure=0.7)
    s.wait(0.1)
    return s


def _display(st: CanvasState) -> None:
    """The display's kernels (:meth:`display.CpuDisplay._render_cells`' and ``_upload``'s
    calls) on a region inside the canvas (non-contiguous views) and on the whole canvas
    (contiguous)."""
    paper = st.paper_reflectance()
    for ry, rx in ((slice(3, HEIGHT - 3), slice(2, WIDTH - 5)),
                   (slice(0, HEIGHT), slice(0, WIDTH))):
        amount, pigments = region_amount(st, ry, rx, None)
        rgb = np.zeros((ry.stop - ry.start, rx.stop - rx.start, 3), F32)
        rgb[...] = km_layer_fast(amount, pigments, st.r_composed[ry, rx])
        painted = subcell.painted_cells(amount, st.r_composed[ry, rx], paper[ry, rx])
        h, w = painted.shape
        inner = (slice(subcell.HALO, h - subcell.HALO), slice(subcell.HALO, w - subcell.HALO))
        ext = subcell.fields(rgb, painted, inner)
        _hi, lo = subcell.step_fields(rgb, paper[ry, rx], painted, ext[..., :3], inner)
        for data in (ext, lo):
            h, w = data.shape[:2]
            # the uploaded cells' part of the texture's mirror, and all of it
            for view in (np.zeros((h + 2, w + 2, 4), F32)[1:-1, 1:-1],
                         np.zeros((h, w, 4), F32)):
                display._changed_box(data, view, F32(display.SHOWN_COLOUR_TOL),
                                     F32(display.SHOWN_LEVEL_TOL), np.zeros(4, np.int64))


def warm(backend: str = "cpu", profile: str = "watercolor", display: bool = True) -> float:
    """Run the kiosk's kernels once (compiled now if the cache lacks them): a session of
    every brush kind on a ``backend`` canvas (``cpu``: the step's kernels too; ``numpy``:
    the brushes' only) and, with ``display`` and a Kubelka-Munk profile, the cpu display's.
    The seconds it took."""
    t0 = time.perf_counter()
    canvas = create_backend(backend, WIDTH, HEIGHT, profile=profile, seed=1)
    player = SessionPlayer(canvas, WIDTH, HEIGHT, profile)
    prof = get_profile(profile)
    # the profile's own paint (a user's profile need not hold the built-in palette)
    names = [prof.brush.pigment, *(n for n in prof.pigments if n != prof.brush.pigment)]
    player.play(_session(brush_kinds(), (names[0], names[min(1, len(names) - 1)])).records)
    if display and prof.renderer == "km":
        _display(canvas.state())
    return time.perf_counter() - t0


class _OneLine(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: {message}\n")


def main(argv: list[str] | None = None) -> int:
    ap = _OneLine(prog="python -m station.kiosk.warm", description=__doc__.split("\n\n")[0])
    ap.add_argument("--backend", default="cpu", choices=("cpu", "numpy"))
    args = ap.parse_args(argv)
    took = warm(args.backend)
    print(f"kiosk kernels compiled or loaded into numba's cache in {took:.0f} s",
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
