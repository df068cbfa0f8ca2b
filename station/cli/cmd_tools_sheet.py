"""``station tools-sheet -o tools.png``: the tools of issue 14 painted by a bundled session."""

from __future__ import annotations

import argparse
from pathlib import Path

from station.durable import atomic_write
from station.pictures.tools_sheet import paint_sheet, session_lines
from station.render.png import encode_png


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("tools-sheet", help="paint the sheet of artistic tools",
                       description="Replays the bundled session "
                                   "station/data/tools/tools-sheet.jsonl (masking fluid, "
                                   "tissue, eraser, diffusion controller, mixing well, tilt) "
                                   "and writes the labelled picture.")
    p.add_argument("-o", "--output", default="tools-sheet.png", metavar="OUT.png")
    p.add_argument("--session", default=None, metavar="LOG.jsonl",
                   help="replay this log instead of the bundled one")
    p.add_argument("--write-session", default=None, metavar="LOG.jsonl",
                   help="write the sheet's session log here and exit (regenerates the data)")
    p.add_argument("--backend", default="auto", choices=("auto", "numpy", "cpu"))
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.write_session:
        atomic_write(args.write_session, ("\n".join(session_lines()) + "\n").encode())
        return 0
    img = paint_sheet(args.session, args.backend)
    atomic_write(Path(args.output), encode_png(img))
    print(args.output)
    return 0
