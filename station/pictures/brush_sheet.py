"""A sheet of sample strokes (dissertation figs. 7.7/7.8) and side views of the tuft.

Every stroke is a scripted pen (the same :class:`~station.sim.script.Script`
the demo uses) played through the session player onto a canvas backend, so
the sheet shows what painting with the brush gives, not a drawing of it.
Rows: one per brush kind; columns: press-and-lift, S-curve, side-pressure
(handle tilted across the motion), dry-brush (fast and light on rough paper)
and a long stroke that runs the brush dry.  Under them, side views of the
deformed tuft at rising pressure (bristles seen along ``y``, the canvas line
in grey).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from station.backends.factory import create_backend
from station.brush.deformable import DeformableBrush
from station.brush.footprint import rasterise
from station.brush.stamp import BrushModel, BrushSettings
from station.events import PenSample
from station.render.km import to_srgb8
from station.sim.player import SessionPlayer
from station.sim.script import Script, swell, taper

COLUMNS = ("press-and-lift", "S-curve", "side-pressure", "dry-brush", "running dry")
INK = "Sumi Ink"
RUN_DRY_WATER = 0.3
"""The running-dry column's water load (a full brush is 1)."""
TWIST = (90.0, 0.0, 0.0, 90.0, 90.0)
"""Barrel rotation per column (Art Pen): a flat brush is held with its width
across the main direction of the stroke; round brushes do not care."""


def _twist(s: Script, start: int, degrees: float) -> None:
    """Give the pen samples recorded since ``start`` the barrel rotation ``degrees``."""
    s.records[start:] = [replace(r, rotation=degrees) if isinstance(r, PenSample) else r
                         for r in s.records[start:]]


def strokes_script(width: int, height: int, kinds: Sequence[str], size: float) -> Script:
    """The sample strokes, one row per kind, in a canvas of ``width × height`` cells."""
    s = Script(width, height, profile="ink", seed=11, rate_hz=120.0)
    rows = len(kinds)
    cw = 1.0 / len(COLUMNS)
    for r, kind in enumerate(kinds):
        yc = (r + 0.5) / rows
        dy = 0.3 / rows
        x = [c * cw for c in range(len(COLUMNS))]
        s.brush(size=size, water=0.9, pigment={INK: 0.7}, kind=kind)
        at = len(s.records)
        s.line((x[0] + 0.03, yc + dy * 0.4), (x[0] + cw - 0.03, yc - dy * 0.4), 0.6,
               pressure=taper(1.0, start=0.05, end=0.05, attack=0.35, release=0.35))
        _twist(s, at, TWIST[0])
        s.brush(size=size, water=0.9, pigment={INK: 0.7}, kind=kind)
        s.curve([(x[1] + 0.03, yc + dy), (x[1] + cw * 0.35, yc - dy),
                 (x[1] + cw * 0.65, yc + dy), (x[1] + cw - 0.03, yc - dy)], 0.8,
                pressure=swell(0.35, 0.8, 1.5))
        s.brush(size=size, water=0.9, pigment={INK: 0.7}, kind=kind)
        s.line((x[2] + cw * 0.5, yc - dy * 1.2), (x[2] + cw * 0.5, yc + dy * 1.2), 0.6,
               pressure=0.85, tilt=(45.0, 0.0))
        s.brush(size=size, water=0.3, pigment={INK: 0.9}, kind=kind)
        at = len(s.records)
        s.line((x[3] + 0.03, yc + dy * 0.3), (x[3] + cw - 0.03, yc - dy * 0.3), 0.15,
               pressure=0.55, tilt=(35.0, 0.0))
        _twist(s, at, TWIST[3])
        # a tuft holds ink by its volume: a loaded 22-cell brush lays a stroke of ~200
        # widths, so the zigzag starts where the tuft's ink has split into locks
        # (below film_fill) and runs through the break-up
        s.brush(size=size, water=RUN_DRY_WATER, pigment={INK: 0.6}, kind=kind)
        at = len(s.records)
        s.curve([(x[4] + 0.03, yc - dy * 1.2), (x[4] + cw - 0.03, yc - dy * 1.2),
                 (x[4] + 0.03, yc - dy * 0.4), (x[4] + cw - 0.03, yc + dy * 0.4),
                 (x[4] + 0.03, yc + dy * 1.2), (x[4] + cw - 0.03, yc + dy * 1.2)], 3.0,
                pressure=0.7, tilt=(20.0, 0.0))
        _twist(s, at, TWIST[4])
    s.wait(0.5)
    return s


def paint_strokes(width: int, height: int, kinds: Sequence[str], size: float,
                  backend: str = "auto") -> np.ndarray:
    """Linear RGB (H, W, 3) of the strokes played on ``backend``."""
    script = strokes_script(width, height, kinds, size)
    be = create_backend(backend, width, height, "ink", 11)
    player = SessionPlayer(be, width, height, "ink")
    player.play(script.records)
    player.settle(0.3)
    return np.asarray(be.render(), np.float32)


def side_views(kind: str, pressures: Sequence[float], cell: int = 64, size: float = 40.0
               ) -> np.ndarray:
    """Grey views (H, W) of the tuft from the side at each pressure, left to right."""
    paper = np.ones((8, 8), np.float32)
    h = cell * 2
    out = np.ones((h, cell * 2 * len(pressures)), np.float32)
    for i, p in enumerate(pressures):
        brush = DeformableBrush(8, 8, BrushSettings(kind=kind, size=size), BrushModel(), paper)
        brush.width = brush.height = 8
        pts = None
        for k in range(12):  # press in gradually, moving a little to the right
            q = p * min(1.0, (k + 1) / 8)
            pts = brush.frame(2.0 + 0.4 * k, 4.0, q)
        assert pts is not None
        # view along y: picture x = world x, picture y = down from the top (z up)
        centre = pts[:, 0, 0].mean()
        view = pts.copy()
        view[..., 0] = view[..., 0] - centre + cell
        # what lies below the plane is the tuft pressed into the paper's tooth:
        # drawn squashed onto the canvas line
        view[..., 1] = h * 0.8 - np.maximum(view[..., 2], 0.0)
        view[..., 2] = -1.0  # everything "touches": a plain silhouette
        segs = np.stack([view[:, :-1], view[:, 1:]], axis=2).reshape(-1, 2, 3)
        maps = rasterise(segs, 0.6, (0, 0, h, 2 * cell))
        tile = 1.0 - 0.85 * maps.cover
        tile[int(h * 0.8), :] = np.minimum(tile[int(h * 0.8), :], 0.55)  # the canvas
        out[:, i * 2 * cell:(i + 1) * 2 * cell] = tile
    return out


def brush_sheet(kinds: Sequence[str] = ("round3d", "flat", "calligraphy"),
                width: int = 720, size: float = 22.0, backend: str = "auto") -> np.ndarray:
    """The whole sheet as sRGB uint8 (H, W, 3)."""
    row_h = int(round(width / len(COLUMNS) * 0.8))
    strokes = paint_strokes(width, row_h * len(kinds), kinds, size, backend)
    pressures = (0.0, 0.25, 0.5, 0.75, 1.0)
    views = []
    for kind in kinds[:2]:
        v = side_views(kind, pressures)
        scale = width / v.shape[1]
        ys = (np.arange(int(v.shape[0] * scale)) / scale).astype(int)
        xs = np.minimum((np.arange(width) / scale).astype(int), v.shape[1] - 1)
        views.append(v[ys][:, xs])
    grey = np.concatenate(views, axis=0)
    side = np.repeat(grey[..., None], 3, axis=2)
    sheet = np.concatenate([strokes, np.full((4, width, 3), 0.6, np.float32), side], axis=0)
    for r in range(1, len(kinds)):  # thin separators between the rows of strokes
        sheet[r * row_h, :, :] = np.minimum(sheet[r * row_h, :, :], 0.85)
    for c in range(1, len(COLUMNS)):
        x = int(round(c * width / len(COLUMNS)))
        sheet[: strokes.shape[0], x, :] = np.minimum(sheet[: strokes.shape[0], x, :], 0.85)
    return to_srgb8(np.clip(sheet, 0.0, 1.0))

