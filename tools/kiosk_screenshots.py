"""Make the README's kiosk screenshots (docs/img/kiosk-*.png) at 1920×1080.

Runs the kiosk in this process on ``$DISPLAY`` (an Xvfb with a screen of at
least 1920×1080: ``Xvfb :5 -screen 0 1920x1080x24 & DISPLAY=:5 python
tools/kiosk_screenshots.py``), paints a few strokes with the mouse path (as a
visitor without a tablet would), waits for the paint to settle a little, and
takes the top, table and brush views; then saves the painting to the gallery,
waits for its replay, and takes the attract screen replaying it.

``--inline-sim`` steps the simulation in the frame loop (``station kiosk
--inline-sim``): every frame then shows tiles rendered between steps. With the
simulation thread (the default) a frame can show a wet tile rendered while a
step's kernel wrote it, for one frame (see docs/kiosk.md); the README's shots
are taken inline so they show the picture, not that frame.
"""

from __future__ import annotations

import math
import sys
import tempfile
import time
from pathlib import Path

from station.kiosk.app import KioskApp, KioskConfig
from station.kiosk.idle import IdleConfig

OUT = Path(__file__).resolve().parent.parent / "docs" / "img"


def drag(app: KioskApp, pts: list[tuple[float, float]], seconds: float) -> None:
    """A mouse drag through canvas points (u, v) over ``seconds``, a frame per event."""
    x, y, w, h = app.canvas_rect()
    left = app.glfw.MOUSE_BUTTON_LEFT
    n = len(pts)
    app.on_cursor(app.window, x + pts[0][0] * w, y + pts[0][1] * h)
    app.on_mouse_button(app.window, left, app.glfw.PRESS, 0)
    t0 = time.monotonic()
    for i, (u, v) in enumerate(pts):
        while time.monotonic() < t0 + seconds * i / n:
            app.frame(0.008)
        app.on_cursor(app.window, x + u * w, y + v * h)
        app.frame(0.008)
    app.on_mouse_button(app.window, left, app.glfw.RELEASE, 0)
    app.frame(0.008)


def wave(u0: float, u1: float, v: float, amp: float, n: int = 90) -> list[tuple[float, float]]:
    return [(u0 + (u1 - u0) * k / (n - 1),
             v + amp * math.sin(2 * math.pi * 1.3 * k / (n - 1))) for k in range(n)]


def settle(app: KioskApp, seconds: float) -> None:
    t_end = time.monotonic() + seconds
    while time.monotonic() < t_end:
        app.frame(0.016)


def shot(app: KioskApp, name: str) -> None:
    app.screenshots.append(OUT / f"{name}.png")
    app.frame(0.016)
    sys.stderr.write(f"wrote {OUT / name}.png\n")


def main() -> int:
    tmp = Path(tempfile.mkdtemp(prefix="kiosk-shots-"))
    cfg = KioskConfig(bus=f">ipc://{tmp}/bus", fullscreen=False, window=(1920, 1080),
                      gallery=tmp / "gallery", serve=None, status="none", cmd="none",
                      vsync=False, autosave=0, input="mouse",
                      sim_thread="--inline-sim" not in sys.argv,
                      idle=IdleConfig(attract_after=3600, finish_after=7200))
    app = KioskApp(cfg)
    try:
        p = app.panel
        settle(app, 1.0)
        p.set_size(46.0)
        p.set_water(1.0)
        p.tap_pigment("French Ultramarine")
        drag(app, wave(0.06, 0.94, 0.22, 0.05), 2.5)  # a sky wash
        p.set_size(30.0)
        p.tap_pigment("Hansa Yellow")
        drag(app, wave(0.1, 0.9, 0.62, 0.08), 2.0)
        p.toggle_mixing()
        p.tap_pigment("Quinacridone Rose")  # yellow + rose: an orange
        p.toggle_mixing()
        drag(app, wave(0.15, 0.85, 0.72, -0.06), 2.0)
        p.set_size(14.0)
        p.tap_pigment("Sumi Ink")
        drag(app, [(0.2 + 0.6 * k / 59, 0.45 - 0.12 * math.sin(math.pi * k / 59))
                   for k in range(60)], 1.6)
        settle(app, 4.0)
        if "--check" in sys.argv:  # the texture against one made from scratch
            import numpy as np

            app.session.stop_worker()
            app.session.run_due_steps = lambda max_steps=2: 0  # type: ignore[method-assign]
            for _ in range(200):
                app.frame(0.016)
                if not app.display.behind() and not app.session.dirty.any():
                    break
            got, want = app.display.read(), app.display.expected()
            d = np.abs(got - want).max(axis=2)
            ys, xs = np.nonzero(d > 1e-3)
            print("texture differs at", len(ys), "cells", list(zip(ys[:10], xs[:10], strict=True)),
                  float(d.max()))
            return 0
        app.follow_at = (0.5, 0.62)
        app.on_cursor(app.window, 10_000, 10_000)  # the pointer off the canvas: no shadow
        for view, name in (("2d", "kiosk-2d"), ("3d", "kiosk-3d"), ("follow", "kiosk-follow")):
            p.set_view(view)
            settle(app, 0.6)
            shot(app, name)
        p.set_view("2d")
        pid = app.save_now()
        replay = cfg.gallery / pid / "replay.webp"
        t_end = time.monotonic() + 600
        while not replay.exists() and time.monotonic() < t_end:
            settle(app, 1.0)
        app._set_qr(None)
        app.idle.cfg.attract_after = 0.1
        settle(app, 2.2)
        shot(app, "kiosk-attract")
    finally:
        app.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
