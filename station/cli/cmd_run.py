"""``station run BLUEPRINT``: run a whole station from its blueprint, supervised.

See :mod:`station.blueprint.supervisor` and docs/blueprint.md.  A blueprint
that cannot work is refused before anything starts (exit 2, element and line).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from station.blueprint.load import load
from station.blueprint.model import SupervisorError
from station.blueprint.plan import resolve
from station.blueprint.supervisor import (
    Supervisor,
    argv_for,
    child_env,
    prepare_run_dir,
    running_pid,
)
from station.bus import runtime_dir
from station.errors import BadInput

if TYPE_CHECKING:
    from station.blueprint.plan import Plan


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="run a station blueprint: every component its own "
                                   "process, supervised",
                       description="Start every component of the blueprint in dependency "
                                   "order, restart crashed ones with back-off (a crashed sim "
                                   "recovers its painting), apply the blueprint's rules; "
                                   "SIGTERM/SIGINT stop everything in reverse order, the "
                                   "painting saved.")
    p.add_argument("file", metavar="BLUEPRINT", help="blueprint file or bundled name")
    p.add_argument("--set", action="append", default=[], metavar="ID.ATTR=VALUE",
                   dest="overrides", help="override an attribute, e.g. sim.width=400 "
                                          "(repeatable; empty VALUE removes it)")
    p.add_argument("--once", action="store_true",
                   help="stop when every pen source has finished (a mock script, a trace) "
                        "and the painting has taken all it sent")
    p.add_argument("--duration", type=float, metavar="SECONDS", help="stop after this long")
    p.add_argument("--run-dir", type=Path, metavar="DIR",
                   help="private directory for sockets, logs and state (created 0700; "
                        "default: RUNTIME/run-NAME)")
    p.add_argument("--workdir", type=Path, metavar="DIR",
                   help="where relative output paths go (default: the current directory)")
    p.add_argument("--component", metavar="ID",
                   help="run only this component in the foreground (what a per-component "
                        "systemd unit does; a sim whose log exists recovers from it)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:

    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
        raise BadInput("must be > 0 seconds", "--duration")
    bp = load(args.file, args.overrides)
    run_dir = args.run_dir or runtime_dir() / f"run-{bp.name}"
    workdir = args.workdir or Path.cwd()
    # A per-component unit names its log without a start time, so a restart finds it.
    plan = resolve(bp, run_dir, workdir, stamp="" if args.component else None)
    if args.component:
        try:
            proc = plan.process(args.component)
        except KeyError:
            raise BadInput(f"no process component {args.component!r} in {bp.file}",
                           "--component") from None
        prepare_run_dir(plan.run_dir)
        for path in proc.outputs:
            (path if proc.kind == "kiosk" else path.parent).mkdir(parents=True, exist_ok=True)
        argv = [sys.executable, "-m", "station", *argv_for(proc)]
        sys.stderr.write(f"station run: {proc.id}: {' '.join(argv[2:])}\n")
        sys.stderr.flush()
        os.chdir(plan.workdir)
        os.execve(sys.executable, argv, child_env(plan))
    prepare_run_dir(plan.run_dir)
    other = running_pid(plan.run_dir)
    if other is not None:
        raise SupervisorError(f"{plan.run_dir}: station {bp.name!r} already runs there "
                              f"(pid {other}); use another --run-dir")
    sup = Supervisor(plan, once=args.once, duration=args.duration)
    code = sup.run()
    _say_outputs(plan)
    return code


def _say_outputs(plan: Plan) -> None:
    """Where the pictures went: the one thing a person wants to know when it stops."""
    for proc in plan.processes:
        for path in proc.outputs:
            if path.suffix in (".png", ".npz", ".jsonl") and path.is_file():
                what = {".png": "picture", ".npz": "canvas state",
                        ".jsonl": "session log"}[path.suffix]
                sys.stderr.write(f"station run: {proc.id}: {what}: {path.resolve()}\n")
