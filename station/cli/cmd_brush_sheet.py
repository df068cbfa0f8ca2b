"""``station brush-sheet -o strokes.png``: sample strokes and side views of the deformable brush."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from station.brush.geometry import BrushShape, get_shape, register_shape
from station.errors import BadInput
from station.pictures.brush_sheet import brush_sheet
from station.render.png import encode_png


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("brush-sheet", help="paint a sheet of sample strokes of the brushes",
                       description="Paints sample strokes (press-and-lift, S-curve, "
                                   "side-pressure, dry-brush, running dry) with the "
                                   "deformable brushes and side views of the tuft at "
                                   "rising pressure, like the dissertation's figs. 7.7/7.8.")
    p.add_argument("-o", "--output", default="strokes.png", metavar="OUT.png")
    p.add_argument("--kinds", default="round3d,flat,calligraphy",
                   help="comma-separated brush kinds, one row each (default %(default)s)")
    p.add_argument("--shape", action="append", default=[], metavar="SHAPE.json",
                   help="a brush shape file (schema: station/data/brushes/schema.json) "
                        "painted as one more row; may be repeated")
    p.add_argument("--width", type=int, default=720, help="sheet width in cells")
    p.add_argument("--backend", default="auto", choices=("auto", "numpy", "cpu"))
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    kinds = [k for k in args.kinds.split(",") if k]
    for path in args.shape:
        shape = BrushShape.load(path)
        try:
            register_shape(shape)
        except BadInput as exc:
            raise BadInput(str(exc), path) from None
        kinds.append(shape.name)
    if not kinds:
        raise BadInput("give at least one brush kind", "--kinds")
    for k in kinds:
        get_shape(k, "--kinds")
    if not 200 <= args.width <= 4096:
        raise BadInput(f"sheet width {args.width} outside [200, 4096]", "--width")
    out = Path(args.output)
    if not out.resolve().parent.is_dir():
        raise BadInput(f"directory {str(out.resolve().parent)!r} does not exist", "-o")
    img = brush_sheet(kinds, args.width, backend=args.backend)
    out.write_bytes(encode_png(img))
    sys.stderr.write(f"station brush-sheet: {img.shape[1]}x{img.shape[0]} -> {out}\n")
    return 0
