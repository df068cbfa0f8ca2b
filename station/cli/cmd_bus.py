"""``station bus``: a standalone forwarder between many publishers and many subscribers."""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path

from station.bus import resolve_endpoint, run_proxy
from station.cli.buskeys import check_keys
from station.stopsignal import StopSignal


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "bus",
        help="run the bus proxy (publishers connect to --pub, subscribers to --sub)",
        description="Forward every publisher to every subscriber. Publishers (drivers) use "
        "'--bus >ENDPOINT' of --pub, subscribers (the simulation, tools) ENDPOINT of --sub.",
    )
    p.add_argument("--pub", default="ipc:pub", help="endpoint publishers connect to (ipc:pub)")
    p.add_argument("--sub", default="ipc:sub", help="endpoint subscribers connect to (ipc:sub)")
    p.add_argument("--keys", type=Path, default=None, metavar="DIR",
                   help="CURVE key directory for tcp endpoints (default "
                        "~/.config/station/keys; not used on ipc)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    check_keys(args.keys, None, (("--pub", args.pub, True), ("--sub", args.sub, True)))
    pub_url = resolve_endpoint(args.pub, True).url
    sub_url = resolve_endpoint(args.sub, True).url
    stop = StopSignal()

    signal.signal(signal.SIGTERM, stop.handler)
    signal.signal(signal.SIGINT, stop.handler)
    sys.stderr.write(f"station bus: publishers -> {pub_url}, subscribers <- {sub_url}\n")
    sys.stderr.flush()
    rejected = run_proxy(args.pub, args.sub, keys=args.keys, stop=stop)
    if rejected:
        sys.stderr.write(f"station bus: stopped; refused {rejected} connection(s) with a "
                         "client key not authorised\n")
    return 0
