"""``station paint INPUT -o OUT.png``: paint a session log (or device trace) headless."""

from __future__ import annotations

import argparse
import contextlib
import json
import sys

from station.backends.distributed.guard import abort_job_on_error
from station.sim.paint import paint, parse_size

BACKENDS = ("auto", "cpu", "numpy", "gl")
BACKEND_HELP = ("canvas backend: numpy (reference), cpu (numba), gl (moderngl/EGL), or auto "
                "(the default: the fastest here, see docs/painting.md)")


def add_canvas_options(p: argparse.ArgumentParser, backend_default: str = "auto") -> None:
    """Options shared by ``paint``, ``demo`` and ``sim``."""
    p.add_argument("--size", metavar="WxH", help="canvas size in cells (default: the session's)")
    p.add_argument("--backend", choices=BACKENDS, default=backend_default,
                   help=BACKEND_HELP)
    p.add_argument("--rate", type=float, metavar="HZ",
                   help="simulation steps per second of painting time (default: 1/dt of "
                        "the profile, or the session header's sim.rate)")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("paint", help="paint a session log headless and write a PNG",
                       description="Replay a session log (.jsonl) — or a device trace "
                                   "(.hid/.evemu/.yaml) once the drivers read them — through "
                                   "the round brush and the canvas simulation, and write "
                                   "the final image.")
    p.add_argument("input", help="session log (.jsonl) or device trace")
    p.add_argument("-o", "--output", required=True, metavar="OUT.png", help="PNG to write")
    add_canvas_options(p)
    p.add_argument("--profile", help="paint profile: watercolor, gouache, ink "
                                     "(default: the session's)")
    p.add_argument("--stats", metavar="S.json", help="write mass bookkeeping as JSON")
    p.add_argument("--state", metavar="S.npz", help="write the full canvas state")
    p.add_argument("--bits", type=int, choices=(8, 16), default=8, help="PNG bit depth")
    p.add_argument("--scale", type=int, default=1, metavar="K",
                   help="render K pixels per simulation cell (1..4): smooth edges, paper "
                        "detail below the cell")
    p.add_argument("--resume", metavar="S.npz",
                   help="paint on a saved canvas state (from --state) instead of blank paper")
    p.add_argument("--settle", type=float, default=0.0, metavar="SECONDS",
                   help="painting time to simulate after the last record (default 0; "
                        "at most a day, like a whole session)")
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    p.add_argument("--mapping", choices=("fit", "stretch"), default="fit",
                   help="device traces: fit keeps the tablet's aspect ratio (letterboxed, "
                        "centred; the default), stretch fills the canvas")
    p.add_argument("--distributed", action="store_true",
                   help="one canvas over all ranks of an MPI job: mpiexec -n N station paint "
                        "... --distributed (needs the mpi extra; see docs/distributed.md)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    size = parse_size(args.size) if args.size else None
    guard: contextlib.AbstractContextManager[object] = contextlib.nullcontext()
    if args.distributed:
        guard = abort_job_on_error()
    with guard:
        result = paint(args.input, args.output, size=size, profile=args.profile,
                       backend=args.backend, stats_path=args.stats,
                       state_path=args.state, bits=args.bits, rate=args.rate,
                       settle=args.settle, resume=args.resume, mapping=args.mapping,
                       render_scale=args.scale, distributed=args.distributed)
    if args.json and result.root:
        json.dump({"width": result.width, "height": result.height, "profile": result.profile,
                   "backend": result.backend, "renderer": result.renderer,
                   "steps": result.steps, "painting_seconds": result.painting_seconds,
                   "wall_seconds": result.wall_seconds, "written": result.written,
                   **result.counters}, sys.stdout, indent=2)
        sys.stdout.write("\n")
    return 0
