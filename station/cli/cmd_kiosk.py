"""``station kiosk``: the live painting window for visitors (see docs/kiosk.md)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from station.canvas.profiles import get_profile
from station.cli.argtypes import auto_or_ms
from station.cli.buskeys import add_key_flags, check_keys
from station.cli.cmd_gallery import add_web_flags, web_options
from station.errors import BadInput
from station.kiosk.app import KioskApp, KioskConfig
from station.kiosk.idle import IdleConfig
from station.kiosk.mouse import parse_pressure
from station.sim.paint import parse_size


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "kiosk", help="the live painting window a visitor paints on with a pen",
        description="Open the kiosk window: the live canvas fed by pen drivers on the bus, a "
                    "pen-only control panel, three views, an attract screen when idle, paintings "
                    "saved to a gallery served on a web page with a QR code. A visitor cannot "
                    "quit; the operator stops it with SIGTERM/SIGINT or a 'stop' command on the "
                    "bus (the painting is saved).")
    p.add_argument("--bus", default=None, metavar="ENDPOINT",
                   help="bus endpoint the pen drivers publish on (default ipc)")
    p.add_argument("--size", metavar="WxH", help="canvas size in cells (800x600)")
    p.add_argument("--profile", help="paint profile (watercolor)")
    p.add_argument("--backend", choices=("auto", "cpu", "numpy", "gl"), default="auto",
                   help="canvas backend (auto: cpu with numba, else numpy; gl shares the "
                        "window's OpenGL 4.3 context)")
    p.add_argument("--seed", type=int, default=0, help="paper seed")
    p.add_argument("--rate", type=float, metavar="HZ", help="simulation steps per second")
    p.add_argument("--windowed", metavar="WxH", nargs="?", const="1024x768",
                   help="a window instead of fullscreen (development), default 1024x768")
    p.add_argument("--monitor", type=int, default=0, help="fullscreen on this monitor (0)")
    p.add_argument("--gallery", default="gallery", metavar="DIR",
                   help="where finished paintings go (created)")
    p.add_argument("--serve", default="127.0.0.1:8080", metavar="HOST:PORT",
                   help="serve the gallery web page here (127.0.0.1:8080: this machine "
                        "only; name the kiosk's address for visitors' phones; 'none': do "
                        "not serve)")
    add_web_flags(p)
    p.add_argument("--base-url", metavar="URL",
                   help="address the QR codes point to (default http://<this machine>:PORT)")
    p.add_argument("--attract-after", type=float, default=45.0, metavar="S",
                   help="seconds without the pen before the attract screen shows")
    p.add_argument("--idle-minutes", type=float, default=3.0, metavar="N",
                   help="minutes without the pen before the painting is saved to the gallery "
                        "and a fresh canvas starts")
    p.add_argument("--view", choices=("2d", "3d", "follow"), default="2d", help="first view")
    p.add_argument("--status", metavar="ENDPOINT",
                   help="where to publish status ('none' to disable; default as station sim)")
    p.add_argument("--cmd", metavar="ENDPOINT",
                   help="where `station send` reaches the kiosk (default @ipc:kiosk-cmd; 'none' "
                        "to disable)")
    p.add_argument("--autosave", type=float, default=30.0, metavar="SECONDS",
                   help="seconds between autosaves of the painting in <gallery>/.live (0: off)")
    p.add_argument("--no-vsync", action="store_true", help="do not wait for vertical blank")
    p.add_argument("--present", choices=("auto", "swap", "partial"), default="auto",
                   help="present whole frames (swap) or only the changed rectangles "
                        "(partial, GLX_MESA_copy_sub_buffer; auto: partial on a software "
                        "rasteriser, swap on a GPU)")
    p.add_argument("--predict-ms", type=auto_or_ms, default=None, metavar="MS|auto",
                   help="draw the brush's shadow this far ahead along the pen's motion "
                        "(auto: the window's own measured pen-to-screen lag, the default; "
                        "0: off)")
    p.add_argument("--inline-sim", action="store_true",
                   help="run the simulation steps in the frame loop, not in a thread")
    p.add_argument("--input", choices=("auto", "pen", "mouse"), default="auto",
                   help="what paints besides pen drivers on the bus: the window's mouse or "
                        "touchscreen (auto: yes, except while a pen is heard; pen: no; "
                        "mouse: yes)")
    p.add_argument("--mouse-pressure", default="speed", metavar="P|speed",
                   help="the mouse's pressure in (0, 1], or 'speed' (a slow stroke presses, "
                        "a fast one flicks; the default)")
    p.add_argument("--duration", type=float, metavar="SECONDS", help="stop after this long")
    p.add_argument("--screenshot-dir", metavar="DIR",
                   help="directory for 'screenshot {\"name\": N}' commands from the bus")
    add_key_flags(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    width, height = parse_size(args.size) if args.size else (800, 600)
    if args.profile:
        get_profile(args.profile)
    window = (1024, 768)
    if args.windowed:
        window = parse_size(args.windowed, "--windowed")
    if not (args.attract_after > 0):
        raise BadInput("must be > 0 seconds", "--attract-after")
    if not (args.idle_minutes > 0):
        raise BadInput("must be > 0 minutes", "--idle-minutes")
    if args.bus and args.bus.startswith("@"):
        raise BadInput("the kiosk connects to the bus (a driver or 'station bus' binds it); "
                       "drop the '@'", "--bus")
    check_keys(args.keys, args.client_key,
               (("--bus", args.bus, False), ("--status", args.status, True),
                ("--cmd", args.cmd, True)))
    if not (0 <= args.autosave <= 3600):
        raise BadInput("must be 0 (off) to 3600 seconds", "--autosave")
    mouse_pressure = parse_pressure(args.mouse_pressure)
    serve = None if args.serve == "none" else args.serve
    if serve is not None:
        _host, sep, port = serve.rpartition(":")
        if not sep or not port.isdigit() or not 0 <= int(port) < 65536:
            raise BadInput(f"{serve!r} is not HOST:PORT", "--serve")
    cfg = KioskConfig(
        bus=args.bus, width=width, height=height, profile=args.profile or "watercolor",
        backend=args.backend, seed=args.seed, rate=args.rate, fullscreen=not args.windowed,
        monitor=args.monitor, window=window, gallery=Path(args.gallery), serve=serve,
        base_url=args.base_url, web=web_options(args),
        idle=IdleConfig(attract_after=args.attract_after, finish_after=args.idle_minutes * 60),
        status=args.status, duration=args.duration,
        screenshot_dir=Path(args.screenshot_dir) if args.screenshot_dir else None,
        view=args.view, vsync=not args.no_vsync, cmd=args.cmd, autosave=args.autosave,
        sim_thread=not args.inline_sim, predict_ms=args.predict_ms,
        present=args.present, keys=args.keys, client_key=args.client_key,
        input=args.input, mouse_pressure=mouse_pressure)
    app = KioskApp(cfg)
    app.install_signal_handlers()
    sys.stderr.write(f"station kiosk: {width}x{height} {cfg.profile} on "
                     f"{app.session.backend_name}, window {app.size[0]}x{app.size[1]}, gallery "
                     f"{app.gallery.root} at {app.base_url}\n")
    final = app.run()
    sys.stderr.write("station kiosk: stopped " + json.dumps(
        {k: final.get(k) for k in ("frames", "samples", "commands", "stamps", "saved")}) + "\n")
    return 0
