"""``station bus``: a standalone forwarder between many publishers and many subscribers."""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from pathlib import Path
from types import FrameType

from station.bus import resolve_endpoint, run_proxy


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "bus",
        help="run the bus proxy (publishers connect to --pub, subscribers to --sub)",
        description="Forward every publisher to every subscriber. Publishers (drivers) use "
        "'--bus >ENDPOINT' of --pub, subscribers (the simulation, tools) ENDPOINT of --sub.",
    )
    p.add_argument("--pub", default="ipc:pub", help="endpoint publishers connect to (ipc:pub)")
    p.add_argument("--sub", default="ipc:sub", help="endpoint subscribers connect to (ipc:sub)")
    p.add_argument("--keys", type=Path, default=None, help="CURVE key directory (tcp only)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    pub_url = resolve_endpoint(args.pub, True).url
    sub_url = resolve_endpoint(args.sub, True).url
    stop = threading.Event()

    def _stop(signum: int, frame: FrameType | None) -> None:
        stop.set()

    signal.signal(signal.SIGTERM, _stop)
    signal.signal(signal.SIGINT, _stop)
    sys.stderr.write(f"station bus: publishers -> {pub_url}, subscribers <- {sub_url}\n")
    sys.stderr.flush()
    run_proxy(args.pub, args.sub, keys=args.keys, stop=stop)
    return 0
