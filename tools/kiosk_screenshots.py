"""Make the README's kiosk screenshots from a scripted visitor session (one command).

    .venv/bin/python tools/kiosk_screenshots.py            # writes docs/img/kiosk-*.png

It starts its own Xvfb (1920×1080; ``--display :N`` uses a running X server
instead), opens the kiosk in this process at 1920×1080, and paints as a visitor
without a tablet would, with the mouse and the kiosk's defaults: a sky of French
Ultramarine and Cerulean (granulating) laid as a wash in zig-zag rows, a drop of
rose into the wet wash, green hills each laid as one wash (their edges darken as
they dry), a dark stroke, a dry-brush drag with a dry brush, clean water dropped
into the damp sky and hills (blooms); it waits for the strokes to dry (at most
``--dry-seconds``), then takes the top, table and brush views, saves the
painting to the gallery (the screen with its QR code, and the gallery's
picture), waits for its replay and takes the attract screen replaying it.

Writes ``docs/img/kiosk-2d.png``, ``kiosk-3d.png``, ``kiosk-follow.png``,
``kiosk-saved.png``, ``kiosk-attract.png``, ``kiosk-painting.png`` (the
gallery's picture of the painting), and the painting's take-home page in headless
Chromium, ``kiosk-phone.png`` (390 px wide) and ``gallery-page.png`` (1280);
``--out DIR`` writes them elsewhere.
Look at each one.
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from station.kiosk.app import KioskApp, KioskConfig
from station.kiosk.gallery import GalleryServer, painting_url
from station.kiosk.idle import IdleConfig

OUT = Path(__file__).resolve().parent.parent / "docs" / "img"
SCREEN = (1920, 1080)

Points = list[tuple[float, float]]


def start_xvfb() -> tuple[subprocess.Popen[bytes], str]:
    """An Xvfb of :data:`SCREEN` on a display number it picks itself."""
    exe = shutil.which("Xvfb")
    if exe is None:
        raise SystemExit("kiosk_screenshots: no Xvfb (apt install xvfb) and no --display")
    r, w = os.pipe()
    proc = subprocess.Popen([exe, "-displayfd", str(w), "-screen", "0",
                             f"{SCREEN[0]}x{SCREEN[1]}x24", "-nolisten", "tcp", "-noreset"],
                            pass_fds=(w,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(w)
    with os.fdopen(r) as f:
        number = f.readline().strip()
    if not number:
        proc.kill()
        raise SystemExit("kiosk_screenshots: Xvfb did not start")
    return proc, f":{number}"


def drag(app: KioskApp, pts: Points, seconds: float) -> None:
    """A mouse drag through canvas points (u, v) over ``seconds``, frames between."""
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
    app.on_cursor(app.window, 10_000, 10_000)  # the pointer away: no shadow in the shots


def zigzag_rows(v0: float, v1: float, rows: int, n: int = 40) -> Points:
    """A wash laid in rows, back and forth, each row overlapping the last."""
    pts: Points = []
    for r in range(rows):
        v = v0 + (v1 - v0) * r / max(rows - 1, 1)
        us = [0.04 + 0.92 * k / (n - 1) for k in range(n)]
        pts += [(u, v + 0.01 * math.sin(7 * u)) for u in (us if r % 2 == 0 else us[::-1])]
    return pts


def wave(u0: float, u1: float, v: float, amp: float, n: int = 80) -> Points:
    return [(u0 + (u1 - u0) * k / (n - 1),
             v + amp * math.sin(2 * math.pi * 1.3 * k / (n - 1))) for k in range(n)]


def settle(app: KioskApp, seconds: float) -> None:
    t_end = time.monotonic() + seconds
    while time.monotonic() < t_end:
        app.frame(0.016)


def wait_dry(app: KioskApp, seconds: float) -> None:
    """Frames until the paper is dry or ``seconds`` passed (the wet paint keeps moving
    until then; a loaded machine steps slower)."""
    t_end = time.monotonic() + seconds
    while time.monotonic() < t_end:
        settle(app, 1.0)
        wet = app.session.wet_fraction()
        if wet is not None and wet < 0.002:
            break
    sys.stderr.write(f"wet fraction {app.session.wet_fraction()}\n")


def shot(app: KioskApp, out: Path, name: str) -> None:
    path = out / f"{name}.png"
    app.screenshots.append(path)
    app.frame(0.016)
    sys.stderr.write(f"wrote {path}\n")


def dab(app: KioskApp, u: float, v: float, r: float, seconds: float = 0.5) -> None:
    """A small circling touch at (u, v), ``r`` across: how a visitor drops paint or
    water into a wash with the mouse."""
    drag(app, [(u + r * math.cos(1.3 * k), v + 0.75 * r * math.sin(1.3 * k))
               for k in range(10)], seconds)


def hill(app: KioskApp, u0: float, u1: float, top: float, foot: float, amp: float,
         seconds: float) -> None:
    """A hill laid as one wash: its crest, then back and forth down to its foot, each
    row into the last while it is wet (one shape whose edge darkens as it dries, not a
    line)."""
    rows = 4  # rows closer than the brush is wide: they run together
    pts: Points = []
    for r in range(rows):
        v = top + (foot - top) * r / (rows - 1)
        row = wave(u0, u1, v, amp * (1.0 - 0.6 * r / (rows - 1)), n=40)
        pts += row if r % 2 == 0 else row[::-1]
    drag(app, pts, seconds)


def paint(app: KioskApp) -> None:
    """The visitor's painting (see the module docstring), with the kiosk's defaults
    (water, strength, the round brush) except where a visitor would move a slider."""
    p = app.panel
    settle(app, 1.0)
    # the sky: a big, wet brush of French Ultramarine and Cerulean (both granulate)
    # laid in zig-zag rows
    p.set_size(72.0)
    p.set_water(1.0)
    p.tap_pigment("French Ultramarine")
    p.toggle_mixing()
    p.tap_pigment("Cerulean Blue")
    p.toggle_mixing()
    drag(app, zigzag_rows(0.07, 0.33, 6), 8.0)  # unhurried: a slow brush presses
    # a drop of rose into the wet wash: it feathers out
    p.set_size(30.0)
    p.tap_pigment("Quinacridone Rose")
    dab(app, 0.3, 0.2, 0.01)
    # hills: a green wash and a warm one below it, each laid as one shape
    p.set_water(0.8)  # the slider back at the kiosk's default
    p.set_size(40.0)
    p.tap_pigment("Hookers Green")
    hill(app, 0.04, 0.96, 0.5, 0.58, 0.05, 4.5)
    p.toggle_mixing()
    p.tap_pigment("Hansa Yellow")  # green + yellow: a sap green
    p.toggle_mixing()
    hill(app, 0.08, 0.92, 0.67, 0.73, -0.035, 4.0)
    # a dark stroke: a tree, in ink
    p.set_size(9.0)
    p.tap_pigment("Sumi Ink")
    drag(app, [(0.72 + 0.01 * math.sin(5 * k / 40), 0.66 - 0.3 * k / 40) for k in range(41)],
         1.2)
    drag(app, [(0.72 + 0.1 * k / 20, 0.5 - 0.08 * k / 20) for k in range(21)], 0.6)
    # a dry-brush drag: a nearly dry, broad brush pulled fast across the foreground
    p.set_size(30.0)
    p.set_water(0.0)
    p.tap_pigment("Burnt Umber")
    for v in (0.86, 0.92):  # two quick pulls: the tuft runs dry along each
        drag(app, [(0.1 + 0.8 * k / 40, v + 0.012 * math.sin(3 * k / 40))
                   for k in range(41)], 0.35)
    # clean water dropped into the sky and the green once their shine has gone (damp,
    # 16 s more since session 14's slower absorption, 8 s before: dropped any sooner they
    # are still wet and the water only pales a soft disc): the water pushes the settling
    # paint out to a dark front (backruns, blooms)
    settle(app, 16.0)
    p.fresh_mix()
    p.set_water(1.0)
    p.set_size(26.0)
    for u, v in ((0.55, 0.17), (0.82, 0.25), (0.3, 0.55)):
        dab(app, u, v, 0.008, 0.4)


#: The take-home page as a phone (390 px wide, the README's phone) and a laptop show it.
PAGES = (("kiosk-phone", (390, 844)), ("gallery-page", (1280, 800)))


def page_shots(app: KioskApp, pid: str, out: Path) -> None:
    """The painting's take-home page, served as the kiosk serves it, in headless
    Chromium at a phone's and a laptop's width (skipped, said, without Chromium)."""
    exe = shutil.which("chromium") or shutil.which("chromium-browser") or \
        shutil.which("google-chrome")
    if exe is None:
        sys.stderr.write("no Chromium: the take-home page's screenshots are not made\n")
        return
    server = GalleryServer(app.gallery, "127.0.0.1", 0).start()
    try:
        url = painting_url(f"http://127.0.0.1:{server.port}", pid)
        for name, (w, h) in PAGES:
            path = out / f"{name}.png"
            subprocess.run([exe, "--headless=new", "--no-sandbox", "--disable-gpu",
                            "--hide-scrollbars", "--force-device-scale-factor=1",
                            f"--window-size={w},{h}", f"--screenshot={path}", url],
                           capture_output=True, timeout=120, check=False)
            sys.stderr.write(f"wrote {path}\n" if path.exists() else f"no {path}\n")
    finally:
        server.stop()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--display", help="a running X server (default: start an Xvfb)")
    ap.add_argument("--out", type=Path, default=OUT, help=f"where the PNGs go ({OUT})")
    ap.add_argument("--dry-seconds", type=float, default=90.0,
                    help="wait at most this long for the paint to dry (90)")
    args = ap.parse_args(argv)
    xvfb = None
    if args.display:
        os.environ["DISPLAY"] = args.display
    else:
        xvfb, os.environ["DISPLAY"] = start_xvfb()
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix="kiosk-shots-"))
    try:
        cfg = KioskConfig(bus=f">ipc://{tmp}/bus", fullscreen=False, window=SCREEN,
                          gallery=tmp / "gallery", serve=None, status="none", cmd="none",
                          vsync=False, autosave=0, input="mouse",
                          idle=IdleConfig(attract_after=3600, finish_after=7200))
        app = KioskApp(cfg)
        try:
            paint(app)
            wait_dry(app, args.dry_seconds)
            app.follow_at = (0.66, 0.3)
            for view, name in (("2d", "kiosk-2d"), ("3d", "kiosk-3d"),
                               ("follow", "kiosk-follow")):
                app.panel.set_view(view)
                settle(app, 0.6)
                shot(app, out, name)
            app.panel.set_view("2d")
            pid = app.save_now()
            settle(app, 0.6)
            shot(app, out, "kiosk-saved")
            shutil.copyfile(cfg.gallery / pid / "painting.png", out / "kiosk-painting.png")
            sys.stderr.write(f"wrote {out / 'kiosk-painting.png'}\n")
            replay = cfg.gallery / pid / "replay.webp"
            failed = cfg.gallery / pid / "replay.failed"
            t_end = time.monotonic() + 600
            while not (replay.exists() or failed.exists()) and time.monotonic() < t_end:
                settle(app, 1.0)
            if not replay.exists():  # the attract screen paints its demo stroke then
                why = (cfg.gallery / pid / "make.log").read_text().strip()
                sys.stderr.write(f"no replay of the painting: {why}\n")
            page_shots(app, pid, out)
            app._set_qr(None)
            app.idle.cfg.attract_after = 0.1
            settle(app, 2.5)
            shot(app, out, "kiosk-attract")
        finally:
            app.close()
    finally:
        if xvfb is not None:
            xvfb.terminate()
            xvfb.wait(10)
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
