"""The kiosk visitor's wet sky in zig-zag rows, as a study (issue 21 item 8, the sky bands).

``tools/kiosk_screenshots.py`` paints the sky as one mouse drag through six rows 31 cells
apart (0.07-0.33 of the 600-cell height), 8 s for the lot (about 550 cells/s along each
736-cell row), with the kiosk's defaults (watercolor, brush size 72, water 1, Ultramarine
and Cerulean at strength 0.8). The dried sky showed a darker line at every row boundary.

This paints the same drag into an 800 x 240 strip (the rows' real length and timing: the
gap between two rows at a column is what lets a row's edge dry) on any backend, dries it and
prints :func:`station.pictures.effects_brush.sky_banding` as JSON.

    .venv/bin/python tools/sky_rows_study.py [--backend cpu] [--seed 0] [--png out.png]
        [--set name=value ...]
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from station.backends.factory import create_backend
from station.canvas.profiles import get_profile
from station.pictures.effects_brush import sky_banding, sky_rows_script
from station.pictures.scenarios import run_until_dry
from station.render.km import linear_to_srgb
from station.sim.player import SessionPlayer


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--backend", default="cpu")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--png", default="")
    ap.add_argument("--set", action="append", default=[], help="a SimParams field=value")
    a = ap.parse_args()
    prm = get_profile("watercolor").params
    if a.set:
        prm = prm.replace(**{k: float(v) for k, v in (s.split("=") for s in a.set)})
    s = sky_rows_script(a.seed)
    h = s.header
    c = create_backend(a.backend, h.width, h.height, "watercolor", a.seed, params=prm)
    SessionPlayer(c, h.width, h.height, "watercolor").play(s.records)
    run_until_dry(c, 20000)
    c.dry()
    rgb = np.asarray(c.render(), np.float64)
    print(json.dumps({k: round(v, 4) for k, v in sky_banding(rgb, c).items()}), flush=True)
    if a.png:
        from PIL import Image  # only when a picture is asked for

        srgb = linear_to_srgb(np.clip(rgb, 0.0, 1.0))
        Image.fromarray((np.clip(srgb, 0, 1) * 255 + 0.5).astype(np.uint8)).save(a.png)


if __name__ == "__main__":
    main()
