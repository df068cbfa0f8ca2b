"""``station sim --bus ENDPOINT``: the live simulation process."""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import TYPE_CHECKING

from station.backends.distributed.guard import abort_job_on_error
from station.backends.factory import create_distributed
from station.canvas.palette import default_palette
from station.canvas.profiles import get_profile
from station.cli.argtypes import seconds_or_zero
from station.cli.buskeys import add_key_flags, check_keys
from station.cli.cmd_paint import BACKEND_HELP, BACKENDS
from station.errors import BadInput, StationError
from station.events import Command
from station.sim.live import LiveConfig
from station.sim.live_bus import LiveSim
from station.sim.paint import check_outputs, load_resume_state, parse_size
from station.sim.player import check_command
from station.sim.recovery import resolve_log

if TYPE_CHECKING:
    from station.sim.live import LiveConfig
    from station.sim.live_bus import LiveSim

MAX_AUTOSAVE_S = 86400.0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("sim", help="run the live canvas simulation on the bus",
                       description="Subscribe to pen samples and commands on the bus, paint "
                                   "them with the round brush, step the canvas at a fixed "
                                   "rate, log the session, autosave, and publish status. "
                                   "SIGTERM or SIGINT saves state and log and exits 0; after "
                                   "a crash --recover continues where it stopped.")
    p.add_argument("--bus", default=None, metavar="ENDPOINT",
                   help="bus endpoint to subscribe to (default ipc; ipc:sub for a proxy)")
    p.add_argument("--size", metavar="WxH", help="canvas size (800x600)")
    p.add_argument("--profile", help="paint profile (watercolor)")
    p.add_argument("--backend", choices=BACKENDS, default="auto", help=BACKEND_HELP)
    p.add_argument("--seed", type=int, default=0, help="paper seed")
    p.add_argument("--rate", type=float, metavar="HZ",
                   help="simulation steps per second (default 1/dt of the profile)")
    p.add_argument("--log", metavar="session.jsonl",
                   help="write the session log here (default: a new file in "
                        "$XDG_DATA_HOME/station/sessions); an existing file is never "
                        "overwritten: the session then goes to NAME-2.jsonl")
    p.add_argument("--state", metavar="S.npz", help="save the canvas state here on exit")
    p.add_argument("--png", metavar="OUT.png", help="write the final image here on exit")
    p.add_argument("--status", metavar="ENDPOINT",
                   help="where to publish status (default: the proxy's ipc:pub when --bus is "
                        "ipc:sub, else @ipc:sim-status; 'none' to disable)")
    p.add_argument("--duration", type=seconds_or_zero, metavar="SECONDS",
                   help="stop by itself after this many seconds")
    p.add_argument("--resume", metavar="S.npz",
                   help="continue a saved canvas state (its size, profile and seed)")
    p.add_argument("--autosave", type=float, default=30.0, metavar="SECONDS",
                   help="write the full state next to the log every SECONDS, between "
                        "strokes (default 30; 0 = off)")
    p.add_argument("--recover", nargs="?", const="latest", metavar="LOG",
                   help="after a crash: load LOG's autosave, replay the log since it and "
                        "go on appending to LOG (default: the newest log in the sessions "
                        "directory)")
    p.add_argument("--cmd", metavar="ENDPOINT",
                   help="where `station send` reaches this sim (default @ipc:sim-cmd; "
                        "'none' to disable)")
    p.add_argument("--brush", metavar="JSON",
                   help="the brush to start with, as a brush command's arguments: "
                        "'{\"size\": 14, \"pigment\": {\"Indanthrone Blue\": 0.9}}' "
                        "(logged as the session's first command)")
    add_key_flags(p)
    p.add_argument("--distributed", action="store_true",
                   help="one canvas over all ranks of an MPI job: mpiexec -n N station sim "
                        "... --distributed; rank 0 reads the bus and writes log, state and "
                        "status (see docs/distributed.md)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    check_keys(args.keys, args.client_key,
               (("--bus", args.bus, False), ("--status", args.status, True),
                ("--cmd", args.cmd, True)))
    size = parse_size(args.size) if args.size else None
    if args.profile:
        get_profile(args.profile)
    check_outputs(((args.log, "--log"), (args.state, "--state"), (args.png, "--png")))
    if not (math.isfinite(args.autosave) and 0 <= args.autosave <= MAX_AUTOSAVE_S):
        raise BadInput(f"must be 0 (off) or up to {MAX_AUTOSAVE_S:g} seconds", "--autosave")
    if args.recover is not None:
        for flag, value in (("--resume", args.resume), ("--log", args.log),
                            ("--size", args.size), ("--profile", args.profile)):
            if value:
                raise BadInput(f"{flag} cannot be used with --recover (the log says it)",
                               flag)
        # which log, before anything is bound or opened (a wrong one is bad input)
        args.recover = str(resolve_log(args.recover))
    brush = _start_brush(args.brush)
    if args.resume:  # the state's size and profile; flags must agree
        load_resume_state(args.resume, size, args.profile)
    width, height = size or (800, 600)
    profile = args.profile or "watercolor"
    cfg = LiveConfig(bus=args.bus, width=width, height=height, profile=profile,
                     backend=args.backend, seed=args.seed, rate=args.rate,
                     log_path=args.log, state_path=args.state, png_path=args.png,
                     status=args.status, duration=args.duration, resume=args.resume,
                     autosave=args.autosave, recover=args.recover, cmd=args.cmd,
                     keys=args.keys, client_key=args.client_key, brush=brush)
    if args.distributed:
        with abort_job_on_error():
            if _follower(cfg):
                return 0
            cfg.distributed = True
            return _lead(LiveSim(cfg))
    return _lead(LiveSim(cfg))


def _start_brush(text: str | None) -> dict[str, object] | None:
    """``--brush JSON`` → the brush command's arguments, checked as the sim will run them."""
    if text is None:
        return None
    try:
        args = json.loads(text)
    except ValueError as exc:
        raise BadInput(f"not JSON ({exc})", "--brush") from None
    if not isinstance(args, dict):
        raise BadInput("must be a JSON object of brush arguments", "--brush")
    check_command(Command(t=0.0, cmd="brush", args=args), default_palette(), where="--brush")
    return args


def _lead(sim: LiveSim) -> int:
    cfg = sim.cfg
    sim.install_signal_handlers()
    sys.stderr.write(f"station sim: {cfg.width}x{cfg.height} {cfg.profile} on {sim.backend_name}, "
                     f"{sim.player.rate:g} steps/s, subscribed to {sim.sub.endpoints[0].url}, "
                     f"logging to {sim.log_path}\n")
    final = sim.run()
    sys.stderr.write("station sim: stopped " + json.dumps(
        {k: final[k] for k in ("steps", "sim_time", "samples", "commands", "bad_commands",
                               "lost_samples", "synthetic_pen_ups", "storage_failures",
                               "flood_dropped", "unread_at_stop")})
        + "\n")
    return 0


def _follower(cfg: LiveConfig) -> bool:
    """On ranks other than 0 of an MPI job: follow rank 0's canvas calls; True when done."""
    import signal

    try:
        from mpi4py import MPI
    except ImportError as exc:
        raise StationError(f"--distributed needs mpi4py and an MPI library (pip install "
                           f"'painting-station[mpi]'): {exc}") from None
    if MPI.COMM_WORLD.Get_rank() == 0:
        return False
    # in the function: mpi4py (the optional ``mpi`` extra) is there, checked above
    from station.backends.distributed.relay import follow

    canvas, _name = create_distributed(cfg.backend, cfg.width, cfg.height, cfg.profile, cfg.seed)
    # Ctrl-C reaches every rank; rank 0 alone decides when to stop (then tells the others)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    follow(canvas)
    return True
