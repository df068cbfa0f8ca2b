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
import resource
import signal
import sys
from pathlib import Path

from station.errors import BadInput
from station.kiosk.gallery import Gallery, GalleryError, GalleryServer, WebOptions, check_id
from station.sim.paint import BYTES_PER_CELL
from station.stopsignal import StopSignal


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
    m.add_argument("--max-memory", type=int, default=None, metavar="MB",
                   help="the replay's memory budget (default: 768 MB plus 1.5x what the "
                        "painting's canvas needs, plus its 2x print); past it the replay "
                        "fails and is not tried again")
    m.set_defaults(func=run_make)
    s = gsub.add_parser("serve", help="serve the gallery's web pages until stopped")
    s.add_argument("--root", default="gallery", help="gallery directory (gallery)")
    s.add_argument("--serve", default="127.0.0.1:8080", metavar="HOST:PORT",
                   help="where to serve (127.0.0.1:8080: this machine only; name the "
                        "kiosk's address, or 0.0.0.0, for phones on its network)")
    s.add_argument("--base-url", metavar="URL",
                   help="the address the QR codes point to (default: the address asked)")
    add_web_flags(s)
    s.set_defaults(func=run_serve)
    e = gsub.add_parser("expire", help="delete the paintings older than N days")
    e.add_argument("--root", default="gallery", help="gallery directory (gallery)")
    e.add_argument("--keep-days", type=float, required=True, metavar="N",
                   help="delete paintings saved more than N days ago")
    e.set_defaults(func=run_expire)


def add_web_flags(p: argparse.ArgumentParser) -> None:
    """The gallery web page's options (``gallery serve`` and the kiosk)."""
    p.add_argument("--gallery-index", action="store_true",
                   help="list every painting at / (off: each only through its own link)")
    p.add_argument("--gallery-logs", action="store_true",
                   help="serve each painting's session log and metadata (off)")
    p.add_argument("--keep-days", type=float, metavar="N",
                   help="delete paintings saved more than N days ago (checked hourly; "
                        "default: keep them)")
    p.add_argument("--per-client", type=int, default=8, metavar="N",
                   help="connections one client address may hold (8)")


def web_options(args: argparse.Namespace) -> WebOptions:
    from station.kiosk.gallery import WebOptions  # the CLI's per-command start-up

    if args.keep_days is not None and not (0 < args.keep_days < 1e6):
        raise BadInput(f"must be a number of days > 0, not {args.keep_days}", "--keep-days")
    if not 1 <= args.per_client <= 1000:
        raise BadInput("must be 1..1000", "--per-client")
    return WebOptions(index=args.gallery_index, session_logs=args.gallery_logs,
                      keep_days=args.keep_days, per_client=args.per_client)


def run_make(args: argparse.Namespace) -> int:
    check_id(args.id)
    if not 0 <= args.nice <= 19:
        raise BadInput("must be 0..19", "--nice")
    root = Path(args.root)
    if not (root / args.id).is_dir():
        raise BadInput(f"no painting {args.id} in {root}", "ID")
    if args.max_memory is not None and not 64 <= args.max_memory <= 1 << 20:
        raise BadInput("must be 64..1048576 MB", "--max-memory")
    if args.nice:
        os.nice(args.nice)
    gallery = Gallery(root)
    budget = args.max_memory or _default_budget_mb(gallery.meta(args.id) or {})
    # a hostile or huge log must not take the kiosk's memory: the data segment (heap
    # and anonymous maps) is capped; a MemoryError past it is this painting's failure.
    # Only the soft limit, given back after: `gallery make` may run inside a longer-lived
    # process (a test, a script), which must not keep the budget.
    soft, hard = resource.getrlimit(resource.RLIMIT_DATA)
    cap = budget << 20 if hard == resource.RLIM_INFINITY else min(budget << 20, hard)
    resource.setrlimit(resource.RLIMIT_DATA, (cap, hard))
    try:
        made = gallery.make(args.id)
    except (MemoryError, OSError) as exc:  # out of budget (a library's mmap fails: OSError)
        why = f"{type(exc).__name__}: {str(exc)[:120]} (memory budget {budget} MB)"
        gallery.mark_failed(args.id, why)
        raise GalleryError(f"painting {args.id}: the replay failed: {why}") from None
    except BaseException as exc:
        # the negative cache: no web request starts this replay again
        gallery.mark_failed(args.id, f"{type(exc).__name__}: {exc}")
        raise
    finally:
        resource.setrlimit(resource.RLIMIT_DATA, (soft, hard))
    for path in made:
        sys.stdout.write(f"{path}\n")
    return 0


def _default_budget_mb(meta: dict[str, object]) -> int:
    w, h = meta.get("width"), meta.get("height")
    cells = w * h if isinstance(w, int) and isinstance(h, int) and 0 < w * h < 1 << 26 \
        else 800 * 600
    # the 2x print renders 4 pixels a cell through 12-channel float32 spectra, about ten
    # such arrays alive at once: an 800x600 painting's replay and print peaked at 2.1 GB
    # RSS (measured), past the canvas-only budget of 1385 MB it used to get
    return 768 + int(1.5 * cells * BYTES_PER_CELL + cells * PRINT_BYTES_PER_CELL) // (1 << 20)


PRINT_BYTES_PER_CELL = 4 * 12 * 4 * 10
"""Memory the 2x print takes per canvas cell [bytes]: 4 pixels x 12 channels x float32 x
about 10 arrays at once."""


def run_expire(args: argparse.Namespace) -> int:
    if not (0 < args.keep_days < 1e6):
        raise BadInput(f"must be a number of days > 0, not {args.keep_days}", "--keep-days")
    root = Path(args.root)
    if not root.is_dir():
        raise BadInput(f"no gallery directory {root}", "--root")
    for pid in Gallery(root).expire(args.keep_days):
        sys.stdout.write(f"deleted {pid}\n")
    return 0


def run_serve(args: argparse.Namespace) -> int:
    host, sep, port = args.serve.rpartition(":")
    if not sep or not port.isdigit() or not 0 <= int(port) < 65536:
        raise BadInput(f"{args.serve!r} is not HOST:PORT", "--serve")
    server = GalleryServer(Gallery(Path(args.root)), host or "127.0.0.1", int(port),
                           args.base_url, web_options(args)).start()
    stop = StopSignal()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, stop.handler)
    sys.stderr.write(f"station gallery: serving {args.root} on {host or '127.0.0.1'}:"
                     f"{server.port}\n")
    while not stop.wait(0.5):  # a timed wait: the signal handlers run meanwhile
        pass
    server.stop()
    return 0
