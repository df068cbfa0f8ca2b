"""``station blueprint check|show|systemd FILE``: a station blueprint without running it.

FILE is a blueprint file or the name of a bundled one (``headless-demo``,
``kiosk``, ``two-tablets``, ``record-only``; ``station blueprint list``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from station.blueprint import diagram
from station.blueprint.exposure import gallery_exposure
from station.blueprint.load import bundled, bundled_names, load
from station.blueprint.plan import resolve
from station.blueprint.systemd import write_units
from station.bus import runtime_dir


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("blueprint", help="check, show or turn into systemd units a station "
                                         "blueprint (docs/blueprint.md)")
    bsub = p.add_subparsers(dest="blueprint_command", metavar="ACTION", required=True,
                            parser_class=type(p))
    ls = bsub.add_parser("list", help="the bundled blueprints")
    ls.set_defaults(func=run_list)
    chk = bsub.add_parser("check", help="validate: schema and wiring (exit 2 with the "
                                         "element and line)")
    _common(chk)
    chk.set_defaults(func=run_check)
    show = bsub.add_parser("show", help="print the resolved wiring and processes")
    _common(show)
    show.add_argument("--dot", action="store_true", help="Graphviz dot instead of text")
    show.set_defaults(func=run_show)
    sd = bsub.add_parser("systemd", help="write systemd units for the station")
    _common(sd)
    sd.add_argument("-o", "--output", required=True, type=Path, metavar="DIR",
                    help="directory to write the units to (created)")
    sd.add_argument("--per-component", action="store_true",
                    help="one unit per component instead of one supervisor unit")
    sd.add_argument("--install-path", metavar="PATH",
                    help="where the blueprint will live on the target machine "
                         "(default /etc/station/NAME.xml)")
    sd.add_argument("--user", help="the dedicated user (default: the blueprint's user= "
                                   "or 'station')")
    sd.add_argument("--station", metavar="PATH",
                    help="the station executable on the target (default: this one)")
    sd.set_defaults(func=run_systemd)


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE", help="blueprint file or bundled name")
    p.add_argument("--set", action="append", default=[], metavar="ID.ATTR=VALUE",
                   dest="overrides", help="override an attribute (repeatable; empty VALUE "
                                          "removes it)")


def run_list(args: argparse.Namespace) -> int:
    for name in bundled_names():
        bp = load(str(bundled(name)))
        print(f"{name:<16} {bp.description}")
    return 0


def run_check(args: argparse.Namespace) -> int:
    bp = load(args.file, args.overrides)
    plan = resolve(bp, Path("/nonexistent-run"), Path.cwd())
    for line in gallery_exposure(bp):  # it runs: a warning, not a refusal
        sys.stderr.write(f"station blueprint: warning: {line}\n")
    sys.stderr.write(f"station blueprint: {bp.file}: ok ({len(plan.processes)} processes, "
                     f"{len(plan.edges)} wires, {len(bp.rules)} rules)\n")
    return 0


def run_show(args: argparse.Namespace) -> int:
    bp = load(args.file, args.overrides)
    plan = resolve(bp, runtime_dir() / f"run-{bp.name}", Path.cwd())
    sys.stdout.write(diagram.dot(plan) if args.dot else diagram.text(plan))
    return 0


def run_systemd(args: argparse.Namespace) -> int:
    bp = load(args.file, args.overrides)
    written = write_units(bp, args.output, per_component=args.per_component,
                          install_path=args.install_path, user=args.user,
                          station=args.station, overrides=args.overrides)
    for path in written:
        print(path)
    return 0
