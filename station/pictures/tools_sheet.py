"""The tools sheet: six panels painted by one bundled session log
(``station/data/tools/tools-sheet.jsonl``), each showing one tool of issue 14.

1. masking fluid: a disc masked, a wash over it, the mask rubbed off: white paper shows;
2. tissue: a crepe tissue pressed into a wet wash leaves its imprint;
3. eraser: a violet of ultramarine and rose; the eraser lifts only the rose in a band;
4. diffusion controller: stripes at 45 degrees written by the brush steer the spread;
5. mixing well: cerulean and hansa yellow mixed in the well, the brush paints the green;
6. tilt: drops of rose on a tilted canvas run downhill.

:func:`session_lines` makes the log (regenerate it with ``station tools-sheet
--write-session``); :func:`paint_sheet` replays it and labels the panels.
"""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

import numpy as np

from station.backends.factory import create_backend
from station.render.km import to_srgb8
from station.sessionlog import read_session
from station.sim.player import SessionPlayer

WIDTH, HEIGHT = 480, 320
PANEL = 160
TITLES = ("masking fluid", "tissue (crepe)", "eraser: rose only", "diffusion controller",
          "mixing well", "tilt 60 deg")


class _Log:
    """Records on a running session clock [s]."""

    def __init__(self) -> None:
        self.t = 0.0
        self.lines: list[dict[str, object]] = []

    def cmd(self, command: str, /, **args: object) -> None:
        self.lines.append({"type": "cmd", "t": round(self.t, 4), "cmd": command, "args": args})

    def wait(self, seconds: float) -> None:
        self.cmd("wait", seconds=seconds)

    def stroke(self, pts: list[tuple[float, float]], pressure: float = 0.9,
               dt: float = 0.04, tool: str = "pen") -> None:
        for x, y in pts:
            self.t += dt
            self.lines.append(self._pen(x, y, pressure, True, tool))
        self.t += dt
        x, y = pts[-1]
        self.lines.append(self._pen(x, y, 0.0, False, tool))

    def _pen(self, x: float, y: float, pressure: float, touching: bool, tool: str
             ) -> dict[str, object]:
        return {"type": "pen", "t": round(self.t, 4), "device": "sheet", "tool": tool,
                "x": round(x, 5), "y": round(y, 5), "pressure": pressure, "proximity": True,
                "touching": touching}


def _at(panel: int, u: float, v: float) -> tuple[float, float]:
    """Canvas-normalised point of panel-relative (u, v) in [0, 1]."""
    col, row = panel % 3, panel // 3
    return (col * PANEL + u * PANEL) / WIDTH, (row * PANEL + v * PANEL) / HEIGHT


def _wash(log: _Log, panel: int, v0: float = 0.2, v1: float = 0.8) -> None:
    for v in np.linspace(v0, v1, 5):
        log.stroke([_at(panel, 0.12, float(v)), _at(panel, 0.88, float(v))], dt=0.05)


def session_lines() -> list[str]:
    """The session log of the sheet, one JSON text per line."""
    log = _Log()
    head = {"format": "station-session", "version": 1,
            "canvas": {"width": WIDTH, "height": HEIGHT}, "profile": "watercolor", "seed": 7}
    # 1 masking fluid
    log.cmd("mask", size=56, x=_at(0, 0.5, 0.5)[0], y=_at(0, 0.5, 0.5)[1])
    log.cmd("brush", size=26, water=1.0, pigment={"French Ultramarine": 0.5})
    _wash(log, 0)
    log.wait(2.0)
    log.cmd("dry")
    log.cmd("mask_remove")
    # 2 tissue
    log.cmd("brush", size=26, water=1.0, pigment={"Hansa Yellow": 0.9, "Burnt Umber": 0.3})
    _wash(log, 1)
    log.wait(0.1)
    x, y = _at(1, 0.5, 0.5)
    log.cmd("tissue", kind="crepe", scale=9, size=80, absorb=1.0, x=x, y=y)
    log.wait(1.5)
    log.cmd("dry")
    # 3 eraser: only the rose goes
    log.cmd("brush", size=26, water=1.0,
            pigment={"French Ultramarine": 0.35, "Quinacridone Rose": 0.5})
    _wash(log, 2)
    log.wait(0.5)
    log.cmd("eraser", fields=["p:Quinacridone Rose", "q:Quinacridone Rose"], fraction=0.9,
            size=24)
    log.stroke([_at(2, 0.1, 0.5), _at(2, 0.5, 0.5), _at(2, 0.9, 0.5)], dt=0.03)
    log.wait(1.0)
    log.cmd("dry")
    # 4 diffusion controller: stripes at 45 degrees under a clear-water wash, then drops
    log.cmd("diffusion", pattern="stripes", period=3, angle=45, strength=1.0, interval=1,
            fade=30.0)
    log.cmd("brush", size=44, water=1.0, pigment={"Burnt Umber": 0.0})
    for _ in range(3):
        log.stroke([_at(3, 0.12, 0.5), _at(3, 0.88, 0.5)], dt=0.05)
    log.cmd("diffusion", pattern="off")
    log.cmd("brush", size=10, water=0.1, pigment={"Burnt Umber": 1.0})
    for u in (0.3, 0.5, 0.7):
        log.stroke([_at(3, u, 0.5)], dt=0.05)
    log.wait(12.0)
    log.cmd("dry")
    log.cmd("diffusion", fade=2.0, pattern="off")
    # 5 mixing well
    log.cmd("well", add="Cerulean Blue", amount=0.6)
    log.cmd("well", add="Hansa Yellow", amount=0.6, settle=3.0)
    log.cmd("well", pick=True)
    log.cmd("brush", size=24, water=1.0)
    log.stroke([_at(4, 0.15, 0.3), _at(4, 0.5, 0.55), _at(4, 0.85, 0.3)], dt=0.06)
    log.stroke([_at(4, 0.15, 0.7), _at(4, 0.85, 0.7)], dt=0.06)
    log.wait(1.0)
    log.cmd("dry")
    # 6 tilt
    log.cmd("brush", size=24, water=1.0, pigment={"Quinacridone Rose": 0.5})
    for u in (0.25, 0.5, 0.75):
        log.stroke([_at(5, u, 0.18), _at(5, u, 0.2)], dt=0.1)
    log.cmd("tilt", angle=60, direction=90)
    log.wait(5.0)
    log.cmd("tilt", angle=0)
    log.wait(1.0)
    log.cmd("dry")
    return [json.dumps(head), *(json.dumps(r) for r in log.lines)]


def bundled_session() -> Path:
    """Path of the bundled session log of the sheet."""
    return Path(str(resources.files("station").joinpath("data", "tools",
                                                         "tools-sheet.jsonl")))


def paint_sheet(path: str | Path | None = None, backend: str = "auto") -> np.ndarray:
    """Replay the sheet's session and label the panels; uint8 sRGB (H, W, 3)."""
    header, records = read_session(path or bundled_session())
    canvas = create_backend(backend, header.width, header.height, header.profile,
                            seed=header.seed)
    player = SessionPlayer(canvas, header.width, header.height, header.profile)
    player.play(records)
    player.settle(0.5)
    img = to_srgb8(canvas.render())
    return _label(img)


def _label(img: np.ndarray) -> np.ndarray:
    try:
        from PIL import Image, ImageDraw  # optional extra: only the labels need it
    except ImportError:
        return img
    im = Image.fromarray(img)
    d = ImageDraw.Draw(im)
    for k, title in enumerate(TITLES):
        x, y = (k % 3) * PANEL, (k // 3) * PANEL
        d.rectangle([x, y, x + PANEL - 1, y + PANEL - 1], outline=(120, 120, 120))
        d.text((x + 5, y + 4), f"{k + 1} {title}", fill=(30, 30, 30))
    return np.asarray(im)
