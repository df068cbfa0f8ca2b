"""``station doctor [BLUEPRINT]``: GL, devices and permissions, udev rules, calibration
files, the bus, free disk — each with what to fix.  Exit 1 if something is wrong."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from station.blueprint.doctor import as_json, report, run_checks
from station.blueprint.load import load
from station.blueprint.plan import resolve
from station.bus import runtime_dir


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("doctor", help="check this machine can run a station, and say what "
                                      "to fix")
    p.add_argument("file", nargs="?", metavar="BLUEPRINT",
                   help="check what this blueprint needs (its devices, calibration, gallery, "
                        "a running station's bus)")
    p.add_argument("--set", action="append", default=[], metavar="ID.ATTR=VALUE",
                   dest="overrides", help="blueprint override, as for station run")
    p.add_argument("--run-dir", type=Path, metavar="DIR", help="the station's run directory "
                   "(as given to station run)")
    p.add_argument("--no-gl", action="store_true",
                   help="skip the OpenGL check and the backend probe (the cached choice only)")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    plan = None
    if args.file:
        bp = load(args.file, args.overrides)
        plan = resolve(bp, args.run_dir or runtime_dir() / f"run-{bp.name}", Path.cwd())
    checks = run_checks(plan, gl=not args.no_gl)
    if args.json:
        json.dump(as_json(checks), sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(report(checks))
    return 1 if any(c.status == "fail" for c in checks) else 0
