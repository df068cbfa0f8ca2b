"""``station send CMD [ARGS]``: send a command to a running ``station sim`` or kiosk.

A kiosk also takes its window's commands (:mod:`station.kiosk.commands`: ``view``,
``fresh``, ``screenshot``, ``message``), checked here as strictly.

ARGS is one JSON object (``'{"size": 12, "pigment": {"Black": 0.5}}'``) or
``key=value`` pairs whose values are JSON where they parse as JSON and strings
otherwise (``station send profile name=ink``).  The command is validated
exactly as a session log's command is (:func:`station.sim.player.check_command`)
before it goes on the bus: a bad one is exit 2 with one line.  Exit 1 when no
simulation listens on the endpoint.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any

from station.cli.buskeys import add_key_flags, check_keys
from station.errors import BadInput, StationError
from station.events import Command

DEFAULT_TIMEOUT_S = 3.0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("send", help="send a command (brush, profile, dry, save, stop …) to "
                                    "a running station sim or kiosk",
                       description="Send one command to a running `station sim`: brush, "
                                   "profile, wait, dry, new_layer, clear, save, stop; a kiosk "
                                   "also takes view name=2d|3d|follow, fresh, screenshot "
                                   "name=N, message text=T. ARGS: a JSON object or "
                                   "key=value pairs (values JSON or text).")
    p.add_argument("cmd", metavar="CMD", help="command name")
    p.add_argument("args", nargs="*", metavar="ARGS", help="JSON object or key=value pairs")
    p.add_argument("--to", metavar="ENDPOINT", default=None,
                   help="the sim's command endpoint (default: ipc:sim-cmd, what `station "
                        "sim --cmd` binds by default)")
    p.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT_S, metavar="S",
                   help="how long to wait for the sim to be there (default 3 s)")
    add_key_flags(p)
    p.set_defaults(func=run)


def parse_args(words: list[str]) -> dict[str, Any]:
    """ARGS words → the command's ``args`` object (see the module docstring)."""
    if len(words) == 1 and words[0].lstrip().startswith("{"):
        try:
            obj = json.loads(words[0], parse_constant=_no_constant)
        except ValueError as exc:
            raise BadInput(f"not a JSON object ({exc})", "ARGS") from None
        if not isinstance(obj, dict):
            raise BadInput("must be a JSON object", "ARGS")
        return obj
    out: dict[str, Any] = {}
    for word in words:
        key, sep, text = word.partition("=")
        if not sep or not key.isidentifier():
            raise BadInput(f"{word!r} is not key=value (or give one JSON object)", "ARGS")
        if key in out:
            raise BadInput(f"{key!r} given twice", "ARGS")
        try:
            out[key] = json.loads(text, parse_constant=_no_constant)
        except ValueError:
            out[key] = text
    return out


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a JSON number")


def run(args: argparse.Namespace) -> int:
    from station.bus import Publisher
    from station.canvas.palette import default_palette
    from station.kiosk.commands import check_kiosk_command, is_kiosk_command
    from station.sim.live import DEFAULT_CMD_ENDPOINT
    from station.sim.player import check_command

    if not (math.isfinite(args.timeout) and 0 < args.timeout <= 60):
        raise BadInput("must be in (0, 60] seconds", "--timeout")
    command = Command(t=0.0, cmd=args.cmd, args=parse_args(args.args), where="CMD")
    if is_kiosk_command(command.cmd):  # the kiosk's window listens on the same endpoint
        check_kiosk_command(command, where=f"command {command.cmd!r}")
    else:
        check_command(command, default_palette(), where=f"command {command.cmd!r}")
    target = args.to or ">" + DEFAULT_CMD_ENDPOINT
    check_keys(args.keys, args.client_key, (("--to", target, False),))
    with Publisher(target, bind=False, replay=False, keys=args.keys,
                   client_key=args.client_key) as pub:
        if not pub.wait_for_subscribers(1, timeout=args.timeout):
            if pub.refusals:
                key = f"client-{args.client_key}.key" if args.client_key else "client.key"
                raise StationError(f"the station sim on {pub.url} refused this client's "
                                   f"CURVE key ({key}): it is not in that sim's "
                                   "authorized/ directory")
            raise StationError(f"no station sim listens on {pub.url} (is it running? "
                               "its --cmd endpoint?)")
        pub.publish_cmd(command)
    sys.stderr.write(f"station send: {command.cmd} {json.dumps(command.args)} -> {pub.url}\n")
    return 0
