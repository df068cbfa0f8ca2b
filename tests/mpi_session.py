"""A painting session run the same way by one process and by an MPI job (test helper).

``python tests/mpi_session.py OUT.npz BASE [SCRIPT]`` under ``mpiexec -n N`` paints
:data:`SESSIONS` ``[SCRIPT]`` on a :class:`DistributedCanvas` and writes the gathered
state (and the rendered picture as ``OUT.npz.rgb.npy``) on rank 0.
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import sys
from pathlib import Path
from typing import Any

import numpy as np

from station.canvas.profiles import get_profile
from station.canvas.state import CanvasState

WIDTH, HEIGHT = 96, 128
PARAMS = dataclasses.replace(get_profile("watercolor").params, tile_size=16)
INK_PARAMS = dataclasses.replace(get_profile("ink").params, tile_size=16)
"""The ink profile paints on rough paper whose fibres steer the wet front (fibre_wick 1)."""

# rows 32, 64, 96 are the strip borders of 4 ranks (16-row tiles); 64 of 2 ranks
SESSIONS: dict[str, list[tuple[Any, ...]]] = {
    "full": [
        ("src", 32, 30, 9, "French Ultramarine", 0.6), ("step", 4),
        ("src", 36, 40, 9, "French Ultramarine", 0.6), ("step", 4),
        ("src", 62, 60, 11, "Burnt Umber", 0.8), ("step", 6),
        ("bounds", [0, 48, 64, 80, 128]),  # rebalance in the middle of the wet stroke
        ("src", 66, 64, 11, "Burnt Umber", 0.8), ("step", 6),
        ("rebalance",), ("step", 6),
        ("dry",), ("step", 2),
        ("src", 95, 20, 8, "Cadmium Yellow", 0.5), ("step", 5),
        ("layer",),
        ("src", 64, 48, 12, "Phthalo Green", 0.7), ("step", 6),
        ("saveload",),
        ("src", 70, 50, 12, "Phthalo Green", 0.7), ("step", 8),
        ("src", 30, 80, 6, "Cadmium Red", 0.9), ("step", 10),
    ],
    "stroke": [  # one stroke down across every border, no rebalancing
        *[op for i in range(12) for op in (("src", 8 + 10 * i, 20 + 5 * i, 7,
                                           "French Ultramarine", 0.5), ("step", 2))],
        ("step", 10),
    ],
    "wet-rebalance": [  # the same stroke, bounds moved at three moments while wet
        *[op for i in range(12) for op in (("src", 8 + 10 * i, 20 + 5 * i, 7,
                                           "French Ultramarine", 0.5), ("step", 2),
                                          *((("bounds", [0, 16, 32, 48, 128]),) if i == 3 else
                                            (("bounds", [0, 72, 88, 104, 128]),) if i == 7 else
                                            (("rebalance",),) if i == 9 else ()))],
        ("step", 10),
    ],
}


def disc(radius: int, amount: float) -> np.ndarray:
    yy, xx = np.mgrid[-radius:radius + 1, -radius:radius + 1]
    d = np.sqrt(yy * yy + xx * xx) / radius
    return (np.clip(1.0 - d, 0.0, 1.0) * amount).astype(np.float32)


def play(canvas: Any, ops: list[tuple[Any, ...]], tmp: str, die_at: int = 0) -> None:
    """Apply ``ops`` to ``canvas`` (a NumpyCanvas or a DistributedCanvas); at step
    ``die_at`` (> 0) this process is killed, at step ``-die_at`` it raises."""
    steps = 0
    for op in ops:
        kind = op[0]
        if kind == "src":
            _, y, x, r, pig, amt = op
            a = disc(r, amt)
            yy, xx = np.mgrid[-r:r + 1, -r:r + 1].astype(np.float32)
            canvas.add_sources(dw=a * 0.8, dp={pig: a * 0.3}, dvx=a * 20.0, dvy=-xx * a,
                               y0=y - r, x0=x - r)
            del yy
        elif kind == "step":
            for _ in range(op[1]):
                canvas.step()
                steps += 1
                if steps == die_at:
                    os.kill(os.getpid(), signal.SIGKILL)
                if steps == -die_at:
                    raise RuntimeError("a bug on one rank only")
        elif kind == "profile":
            canvas.set_profile(op[1])
        elif kind == "dry":
            canvas.dry()
        elif kind == "layer":
            canvas.new_layer()
        elif kind == "bounds" and hasattr(canvas, "set_bounds"):
            size = canvas.size
            b = op[1] if size == 4 else [0, op[1][2], HEIGHT] if size == 2 else [0, HEIGHT]
            canvas.set_bounds(b)
        elif kind == "rebalance" and hasattr(canvas, "rebalance"):
            canvas.rebalance(force=True)
        elif kind == "saveload":
            path = str(Path(tmp) / "mid.npz")
            if hasattr(canvas, "gather_state"):
                canvas.save(path)
                canvas.comm.Barrier()
                canvas.load(path)
            else:
                canvas.state().save(path)
                canvas.load_state(CanvasState.load(path))


def render_delta(canvas: Any, out: str) -> int:
    """Paint a wash, render, then a dab in one corner: the second picture sends only
    the changed tiles. Writes both pictures and the cells each rank sent."""
    ops = delta_ops()
    play(canvas, ops[0], str(Path(out).parent))
    first = canvas.render()
    sent = [canvas.comm.allreduce(canvas.render_cells_last)]
    play(canvas, ops[1], str(Path(out).parent))
    second = canvas.render()
    sent.append(canvas.comm.allreduce(canvas.render_cells_last))
    if canvas.is_root:
        np.save(out + ".first.npy", first)
        np.save(out + ".second.npy", second)
        Path(out + ".sent.json").write_text(json.dumps(sent))
    return 0


def delta_ops() -> tuple[list[tuple[Any, ...]], list[tuple[Any, ...]]]:
    """A stroke down the canvas, dried; then one dab in the top-left corner."""
    before = [("src", 20 + 12 * i, 60, 8, "Burnt Umber", 0.6) for i in range(8)]
    return ([*before, ("step", 6), ("dry",)],
            [("src", 10, 10, 5, "French Ultramarine", 0.6), ("step", 3)])


def main(argv: list[str]) -> int:
    from station.backends.distributed.canvas import DistributedCanvas

    out, base = argv[0], argv[1]
    script = argv[2] if len(argv) > 2 else "full"
    # SCRIPT:blocking / SCRIPT:auto: the halo schedule (default: overlap, so that every
    # session exercises the border bands; auto is blocking on one machine)
    script, _, schedule = script.partition(":")
    die = json.loads(argv[3]) if len(argv) > 3 else None
    ink = script.endswith("-ink")  # SCRIPT-ink: the same session on the ink profile
    script = script.removesuffix("-ink")
    canvas = DistributedCanvas(WIDTH, HEIGHT, "ink" if ink else "watercolor", seed=3,
                               base=base, params=INK_PARAMS if ink else PARAMS,
                               rebalance_every=0, schedule=schedule or "overlap")
    die_at = die["step"] if die is not None and die["rank"] == canvas.rank else 0
    if script == "render-delta":
        return render_delta(canvas, out)
    play(canvas, SESSIONS[script], str(Path(out).parent), die_at)
    rgb = canvas.render()
    stats = canvas.stats()
    sched = {"bands": canvas.comm.allreduce(canvas.band_steps),
             "late": canvas.comm.allreduce(canvas.late_steps)}
    full = canvas.gather_state()
    if full is not None:
        Path(out + ".sched.json").write_text(json.dumps(sched))
        full.save(out)
        np.save(out + ".rgb.npy", rgb)
        Path(out + ".stats.json").write_text(json.dumps(stats))
    return 0


if __name__ == "__main__":
    from station.backends.distributed.guard import abort_job_on_error

    with abort_job_on_error():
        sys.exit(main(sys.argv[1:]))
