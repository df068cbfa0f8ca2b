"""``station log cat|stats FILE``: inspect a session log."""

from __future__ import annotations

import argparse
import json
import sys

from station.events import PenSample
from station.sessionlog import SessionLogReader, summarise


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("log", help="inspect a session log (.jsonl)")
    logsub = p.add_subparsers(dest="log_command", metavar="ACTION", required=True,
                              parser_class=type(p))
    cat = logsub.add_parser("cat", help="print the records, one per line")
    cat.add_argument("file")
    cat.add_argument("--json", action="store_true", help="normalised JSON lines instead of text")
    cat.set_defaults(func=run_cat)
    stats = logsub.add_parser("stats", help="summary of a log as JSON")
    stats.add_argument("file")
    stats.set_defaults(func=run_stats)


def run_cat(args: argparse.Namespace) -> int:
    out = sys.stdout
    with SessionLogReader(args.file) as reader:
        h = reader.header
        if args.json:
            out.write(json.dumps(h.to_record()) + "\n")
        else:
            out.write(f"# session {h.width}x{h.height} profile={h.profile} seed={h.seed}\n")
        for rec in reader:
            if args.json:
                out.write(json.dumps(rec.to_record()) + "\n")
            elif isinstance(rec, PenSample):
                state = "down" if rec.touching else ("hover" if rec.proximity else "out")
                out.write(
                    f"{rec.t:10.4f} pen  {rec.device:<10} {rec.tool.value:<8} {state:<5} "
                    f"x={rec.x:.4f} y={rec.y:.4f} p={rec.pressure:.3f} "
                    f"tilt=({rec.tilt_x:+.1f},{rec.tilt_y:+.1f}) buttons={rec.buttons:#x}\n"
                )
            else:
                out.write(f"{rec.t:10.4f} cmd  {rec.cmd} {json.dumps(rec.args)}\n")
    return 0


def run_stats(args: argparse.Namespace) -> int:
    with SessionLogReader(args.file) as reader:
        json.dump(summarise(reader), sys.stdout, indent=2)
    sys.stdout.write("\n")
    return 0
