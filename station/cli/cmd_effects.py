"""``station effects [-o effects.png] [--json] [--only NAMES]``: the effects sheet.

Paints each watercolour effect of issue 10 on a small canvas (NumPy reference), measures
it, and writes a sheet of tiles, each labelled with its numbers and whether they meet
the issue's thresholds; ``--json`` prints the numbers. Exit 0 even when a threshold is
missed (the sheet reports the model as it is); bad flags are exit 2.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from station.errors import BadInput
from station.pictures import effects as fx
from station.pictures.effects_core import use_backend
from station.render.km import to_srgb8
from station.render.png import write_png
from station.render.upscale import MAX_SCALE


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("effects", help="paint and measure the watercolour effects sheet",
                       description="Paints through the brush, from pen samples at a "
                                   "painter's speed, pressure and waits (the measure): the "
                                   "value range and masstone hues, glazing vs a wet mix, "
                                   "flat washes on three papers, edges, blooms, dry-brush "
                                   "and step artefacts; then the rectangle tiles as a "
                                   "labelled physics row. Measures each and writes a "
                                   "labelled sheet drawn at --scale pixels per cell (about "
                                   "five minutes on one core).")
    p.add_argument("-o", "--output", default="effects.png", metavar="OUT.png",
                   help="sheet to write (default effects.png)")
    p.add_argument("--json", action="store_true", help="print the numbers as JSON on stdout")
    p.add_argument("--only", metavar="NAMES",
                   help="comma-separated tile functions (e.g. density,ink_bleed)")
    p.add_argument("--scale", type=int, default=3, metavar="K",
                   help="pixels per cell of every tile in the sheet (1..8, default 3)")
    p.add_argument("--backend", choices=("numpy", "cpu"), default="numpy",
                   help="what the brush tiles paint on: numpy (the reference, default) or "
                        "cpu (numba: the same bits, a fraction of the time)")
    p.set_defaults(func=run)


def _sheet(effects: list, scale: int) -> np.ndarray:
    """The tiles side by side in rows, each over a caption (8-bit sRGB, (H, W, 3))."""
    from PIL import Image, ImageDraw

    pad = 8
    cap = 14 * 4
    # the sub-cell renderer draws up to MAX_SCALE pixels per cell; larger scales enlarge
    # its picture
    k = min(scale, MAX_SCALE)
    extra = scale // k
    tiles = [np.repeat(np.repeat(to_srgb8(np.clip(e.picture(k), 0.0, 1.0)), extra, 0), extra, 1)
             for e in effects]
    # rows filled left to right up to about four typical tiles' width
    limit = max(max(t.shape[1] for t in tiles), 4 * int(np.median([t.shape[1] for t in tiles])))
    places: list[tuple[int, int]] = []
    x = y = row_h = 0
    for t in tiles:
        if x and x + t.shape[1] > limit:
            x, y, row_h = 0, y + row_h + cap + pad, 0
        places.append((x, y))
        x += t.shape[1] + pad
        row_h = max(row_h, t.shape[0])
    width = max(px + t.shape[1] for (px, _), t in zip(places, tiles, strict=True)) + 2 * pad
    height = y + row_h + cap + 2 * pad
    sheet = Image.new("RGB", (width, height), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    for (px, py), e, t in zip(places, effects, tiles, strict=True):
        x, y = pad + px, pad + py
        sheet.paste(Image.fromarray(t), (x, y))
        lines = [f"{e.name}: {'ok' if e.ok else 'MISSED'}"]
        lines += [f"{k} {v:.3g}" for k, v in e.numbers.items()]
        draw.multiline_text((x, y + t.shape[0] + 2), "\n".join(lines[:4]),
                            fill=(0, 0, 0) if e.ok else (170, 0, 0), spacing=1)
    return np.asarray(sheet)


def run(args: argparse.Namespace) -> int:
    names = None
    if args.only:
        names = [n.strip() for n in args.only.split(",") if n.strip()]
        known = {t.__name__ for t in fx.TILES}
        unknown = [n for n in names if n not in known]
        if unknown or not names:
            raise BadInput(f"--only: unknown tile {', '.join(unknown) or '(none)'} "
                           f"(known: {', '.join(sorted(known))})")
    if not 1 <= args.scale <= 8:
        raise BadInput(f"--scale {args.scale} must lie in 1..8")
    out = Path(args.output)
    if out.is_dir() or not out.parent.exists():
        raise BadInput(f"-o {args.output}: not a writable file name")
    use_backend(args.backend)
    effects = fx.run_effects(names)
    write_png(out, _sheet(effects, args.scale))
    if args.json:
        json.dump({e.name: e.to_json() for e in effects}, sys.stdout, indent=1)
        sys.stdout.write("\n")
    missed = [e.name for e in effects if not e.ok]
    sys.stderr.write(f"station effects: {len(effects)} tiles -> {out}; "
                     f"{'all thresholds met' if not missed else 'missed: ' + ', '.join(missed)}\n")
    return 0
