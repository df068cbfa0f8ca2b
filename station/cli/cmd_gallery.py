"""``station gallery make|serve``: a kiosk's gallery without the kiosk.

``make`` replays a painting's session log once and writes its replay animation
and its print (see :mod:`station.kiosk.gallery`); the kiosk starts it for each
painting it saves, and it lowers its own CPU priority first (``--nice``), so
the replay does not take the cores from the next visitor.  ``serve`` serves
the gallery's web pages (the kiosk serves them itself while it runs).
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from pathlib import Path

from station.errors import BadInput
from station.kiosk.gallery import Gallery, GalleryServer, check_id


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("gallery", help="make a painting's replay and print, or serve a "
                                       "gallery's web pages",
                       description="The kiosk's gallery: make the replay animation and the "
                                   "2x print of a painting from its session log, or serve "
                                   "the gallery's pages without a kiosk.")
    gsub = p.add_subparsers(dest="gallery_cmd", required=True)
    m = gsub.add_parser("make", help="replay a painting's log: replay.webp and "
                                     "painting-2x.png")
    m.add_argument("id", metavar="ID", help="painting id (YYYYMMDD-HHMMSS-xxxxxx)")
    m.add_argument("--root", default="gallery", help="gallery directory (gallery)")
    m.add_argument("--nice", type=int, default=19, metavar="N",
                   help="lower this process's CPU priority by N first (19; 0: not)")
    m.set_defaults(func=run_make)
    s = gsub.add_parser("serve", help="serve the gallery's web pages until stopped")
    s.add_argument("--root", default="gallery", help="gallery directory (gallery)")
    s.add_argument("--serve", default="0.0.0.0:8080", metavar="HOST:PORT",
                   help="where to serve (0.0.0.0:8080)")
    s.add_argument("--base-url", metavar="URL",
                   help="the address the QR codes point to (default: the address asked)")
    s.set_defaults(func=run_serve)


def run_make(args: argparse.Namespace) -> int:
    check_id(args.id)
    if not 0 <= args.nice <= 19:
        raise BadInput("must be 0..19", "--nice")
    root = Path(args.root)
    if not (root / args.id).is_dir():
        raise BadInput(f"no painting {args.id} in {root}", "ID")
    if args.nice:
        os.nice(args.nice)
    for path in Gallery(root).make(args.id):
        sys.stdout.write(f"{path}\n")
    return 0


def run_serve(args: argparse.Namespace) -> int:
    host, sep, port = args.serve.rpartition(":")
    if not sep or not port.isdigit() or not 0 <= int(port) < 65536:
        raise BadInput(f"{args.serve!r} is not HOST:PORT", "--serve")
    server = GalleryServer(Gallery(Path(args.root)), host or "0.0.0.0", int(port),
                           args.base_url).start()
    stop = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.set())
    sys.stderr.write(f"station gallery: serving {args.root} on {host or '0.0.0.0'}:"
                     f"{server.port}\n")
    while not stop.wait(0.5):  # a timed wait: the signal handlers run meanwhile
        pass
    server.stop()
    return 0
