"""``station send CMD [ARGS]``: send a command to a running ``station sim`` or kiosk,
and say what it did with it.

A kiosk also takes its window's commands (:mod:`station.kiosk.commands`: ``view``,
``fresh``, ``screenshot``, ``message``), checked here as strictly.

ARGS is one JSON object (``'{"size": 12, "pigment": {"Black": 0.5}}'``) or
``key=value`` pairs whose values are JSON where they parse as JSON and strings
otherwise (``station send profile name=ink``).  The process that takes the
command checks it exactly as a session log's command is checked, and also
refuses a key nothing reads; it answers (:mod:`station.answer`), naming itself
(sim or kiosk, pid) and its session.  Exit 0 with its answer on stdout; exit 2
with one line when it refused the command; exit 1 when nobody takes or answers
it within ``--timeout``.  ``--to sim`` (the default) and ``--to kiosk`` pick the
process by its default endpoint, and a command sent with them is refused by a
process of the other kind; ``--to ENDPOINT`` names any endpoint.  Over tcp
(CURVE, ``--keys``/``--client-key``) the answer comes back over the same
connection (:data:`station.answer.PEER`), with the same exits.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import secrets
import sys
import time
from dataclasses import replace
from typing import Any

import zmq

from station.answer import PEER, ReplyRequest
from station.bus import Publisher, runtime_dir
from station.cli.buskeys import add_key_flags, check_keys
from station.errors import BadInput, StationError
from station.events import Command
from station.kiosk.commands import check_kiosk_command, is_kiosk_command

# the defaults of `station sim --cmd` and `station kiosk --cmd` (station.sim.live, which
# this start-up-time-critical command does not import: it pulls in the whole sim)
DEFAULT_CMD_ENDPOINT = "ipc:sim-cmd"
KIOSK_CMD_ENDPOINT = "ipc:kiosk-cmd"

DEFAULT_TIMEOUT_S = 3.0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("send", help="send a command (brush, profile, dry, save, stop …) to "
                                    "a running station sim or kiosk, and show its answer",
                       description="Send one command to a running `station sim` or `station "
                                   "kiosk` and print its answer: brush, profile, wait, dry, "
                                   "new_layer, clear, hairdryer, save, stop, … ARGS: a JSON "
                                   "object or key=value pairs (values JSON or text). Exit 0: "
                                   "done (the answer names the process and its session); 2: "
                                   "refused (one line saying why); 1: nobody answered.",
                       epilog="examples:\n"
                              "  station send brush size=12 'pigment={\"Burnt Umber\": 0.7}'\n"
                              "  station send profile name=ink\n"
                              "  station send --to kiosk view name=3d\n"
                              "  station send stop --to ipc:///run/station/sim-a.cmd --json",
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("cmd", metavar="CMD", help="command name")
    p.add_argument("args", nargs="*", metavar="ARGS", help="JSON object or key=value pairs")
    p.add_argument("--to", metavar="sim|kiosk|ENDPOINT", default=None,
                   help="who takes it: 'sim' (ipc:sim-cmd, the default of `station sim "
                        "--cmd`), 'kiosk' (ipc:kiosk-cmd) or any command endpoint")
    p.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT_S, metavar="S",
                   help="how long to wait for the process to take and answer it (default 3 s)")
    p.add_argument("--json", action="store_true",
                   help="print the answer as one JSON object")
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


def target_endpoint(to: str | None) -> tuple[str, str | None]:
    """``--to`` → (endpoint spec, the kind of process expected there or ``None``)."""
    if to is None or to == "sim":
        return ">" + DEFAULT_CMD_ENDPOINT, "sim"
    if to == "kiosk":
        return ">" + KIOSK_CMD_ENDPOINT, "kiosk"
    return to, None


def run(args: argparse.Namespace) -> int:
    if not (math.isfinite(args.timeout) and 0 < args.timeout <= 60):
        raise BadInput("must be in (0, 60] seconds", "--timeout")
    command = Command(t=0.0, cmd=args.cmd, args=parse_args(args.args), where="CMD")
    to = args.to
    if is_kiosk_command(command.cmd):  # the kiosk's window commands, checked as it will
        check_kiosk_command(command, where=f"command {command.cmd!r}")
        to = to or "kiosk"  # only a kiosk has a window: `station send view name=3d` finds it
    target, expect = target_endpoint(to)
    check_keys(args.keys, args.client_key, (("--to", target, False),))
    deadline = time.monotonic() + args.timeout
    over_ipc = "tcp://" not in target
    ctx: zmq.Context[zmq.Socket[bytes]] = zmq.Context.instance()
    inbox = None
    tag = secrets.token_hex(6)
    if not over_ipc:  # the answer comes back over the connection we open
        command = replace(command, reply=ReplyRequest(to=PEER, id=tag,
                                                      expect=expect).as_record())
    else:
        # the answer comes back on a socket of our own in the runtime directory
        # (station.answer: the taking process connects only there)
        path = runtime_dir() / f"reply-{os.getpid()}-{tag}"
        inbox = ctx.socket(zmq.PULL)
        inbox.setsockopt(zmq.LINGER, 0)
        inbox.bind(f"ipc://{path}")
        command = replace(command, reply=ReplyRequest(to=f"ipc://{path}", id=tag,
                                                      expect=expect).as_record())
    try:
        with Publisher(target, bind=False, replay=False, keys=args.keys,
                       client_key=args.client_key, context=ctx) as pub:
            if not pub.wait_for_subscribers(1, timeout=max(0.0, deadline - time.monotonic())):
                if pub.refusals:
                    key = f"client-{args.client_key}.key" if args.client_key else "client.key"
                    raise StationError(f"the station process on {pub.url} refused this "
                                       f"client's CURVE key ({key}): it is not in its "
                                       "authorized/ directory")
                if expect != "kiosk":
                    # nobody to answer: a command the sim would refuse is still bad
                    # input (exit 2), said as the sim would say it
                    _check_here(command)
                raise StationError(f"no station {expect or 'process'} listens on {pub.url} "
                                   "(is it running? its --cmd endpoint?)")
            pub.publish_cmd(command)
            if inbox is None:
                got = _peer_answer(pub, tag, deadline)
            else:
                left_ms = int(max(0.0, deadline - time.monotonic()) * 1000)
                got = _answer(inbox.recv()) if inbox.poll(left_ms, zmq.POLLIN) else None
            if got is None:
                raise StationError(f"{command.cmd} went to {pub.url} but nobody answered "
                                   f"within {args.timeout:g} s (a station older than its "
                                   "answers, or a process busy painting)")
            answer = got
    finally:
        if inbox is not None:
            inbox.close()
            with contextlib.suppress(OSError):
                path.unlink()
    who = (f"{answer.get('process', '?')} {answer.get('pid', '?')} "
           f"(session {answer.get('session', '?')})")
    if not answer.get("ok"):
        raise BadInput(f"refused by {who}: {answer.get('error', 'no reason given')}",
                       command.cmd)
    if args.json:
        sys.stdout.write(json.dumps(answer) + "\n")
    else:
        sys.stdout.write(f"{who}: {answer.get('did', 'done')}\n")
    return 0


def _peer_answer(pub: Publisher, tag: str, deadline: float) -> dict[str, Any] | None:
    """Our answer among what came back over the tcp connection (other senders' answers
    may pass by: each carries its own id), or ``None`` at the deadline."""
    while (data := pub.recv_upstream(max(0.0, deadline - time.monotonic()))) is not None:
        with contextlib.suppress(StationError):
            answer = _answer(data)
            if answer.get("id") == tag:
                return answer
    return None


def _answer(data: bytes) -> dict[str, Any]:
    try:
        obj = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        raise StationError("the answer is not JSON (not a station process?)") from None
    if not isinstance(obj, dict):
        raise StationError("the answer is not a JSON object (not a station process?)")
    return obj


def _check_here(command: Command) -> None:
    """Nobody answers: check the command here, as the sim would, so a bad one (an
    unknown key included) is still exit 2 (the sim's modules load only for this case:
    they take a second)."""
    # in the function: the sim's modules take a second to load, and only this case needs them
    from station.canvas.palette import default_palette
    from station.sim.player import check_sent_command

    check_sent_command(command, default_palette(), where=f"command {command.cmd!r}")
