"""``station demo [-o painting.png]``: paint the bundled demo landscape headless."""

from __future__ import annotations

import argparse
import sys

from station.cli.cmd_paint import BACKEND_HELP, BACKENDS
from station.pictures.demo import DEMO_FILE
from station.sim.paint import paint, parse_size


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="paint the bundled demo landscape and write a PNG",
                       description="Replays the bundled demo session (a small watercolor "
                                   "landscape scripted with the station's own pen input: "
                                   "wet-in-wet sky, glazed hills, granulation, dark edges, "
                                   "ink) headless and writes a PNG.")
    p.add_argument("-o", "--output", default="painting.png", metavar="OUT.png",
                   help="PNG to write (default painting.png)")
    p.add_argument("--size", metavar="WxH", help="canvas size (default: the demo's, 400x300)")
    p.add_argument("--backend", choices=BACKENDS, default="auto", help=BACKEND_HELP)
    p.add_argument("--bits", type=int, choices=(8, 16), default=8, help="PNG bit depth")
    p.add_argument("--scale", type=int, default=1, metavar="K",
                   help="render K pixels per simulation cell (1..4): smooth edges, paper "
                        "detail below the cell")
    p.add_argument("--stats", metavar="S.json", help="write mass bookkeeping as JSON")
    p.add_argument("--state", metavar="S.npz", help="write the full canvas state")
    p.add_argument("--session", action="store_true",
                   help="print the demo session log on stdout instead of painting")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.session:
        sys.stdout.write(DEMO_FILE.read_text(encoding="utf-8"))
        return 0
    size = parse_size(args.size) if args.size else None
    result = paint(str(DEMO_FILE), args.output, size=size, backend=args.backend,
                   stats_path=args.stats, state_path=args.state, bits=args.bits,
                   render_scale=args.scale)
    sys.stderr.write(f"station demo: {result.width}x{result.height} on {result.backend} "
                     f"({result.renderer}): {result.steps} steps, "
                     f"{result.painting_seconds:.1f} s painting time in "
                     f"{result.wall_seconds:.1f} s -> {args.output}\n")
    return 0
