"""The kiosk's own commands (the window's, not the painting's), checked in one place.

``station send`` checks them before they go on the bus (a bad one is exit 2 with
one line, as a bad painting command is); the kiosk checks them again when they
come (from the bus, where anything may arrive) and logs and drops a bad one.

* ``view {"name": "2d"|"3d"|"follow"}`` — the view;
* ``fresh {}`` — save the painting to the gallery and start a fresh canvas;
* ``screenshot {"name": N}`` — the window into ``--screenshot-dir``/N.png (a plain
  name: letters, digits, ``-``, ``_``; refused without ``--screenshot-dir``);
* ``message {"text": T}`` — an operator's note on the panel.

``save`` and ``stop`` are the live simulation's (``station sim`` has them too);
the kiosk handles them for its gallery.
"""

from __future__ import annotations

import re

from station.errors import BadInput
from station.events import Command

# the window's views (station.kiosk.views makes their cameras): named here, so that
# `station send`, whose start-up time counts, checks `view` without numpy
VIEWS = ("2d", "3d", "follow")
KIOSK_COMMANDS = ("view", "fresh", "screenshot", "message")
SCREENSHOT_NAME = re.compile(r"^[A-Za-z0-9_-]{1,64}$")
MESSAGE_MAX = 200


def is_kiosk_command(name: str) -> bool:
    return name in KIOSK_COMMANDS


def check_kiosk_command(cmd: Command, where: str = "CMD") -> None:
    """Raise :class:`BadInput` if ``cmd`` (one of :data:`KIOSK_COMMANDS`) has bad
    arguments."""
    args = cmd.args
    if cmd.cmd == "view":
        if set(args) != {"name"} or args["name"] not in VIEWS:
            raise BadInput(f"view needs name={'|'.join(VIEWS)}", where)
    elif cmd.cmd == "fresh":
        if args:
            raise BadInput("fresh takes no arguments", where)
    elif cmd.cmd == "screenshot":
        name = args.get("name")
        if set(args) != {"name"} or not isinstance(name, str) or \
                not SCREENSHOT_NAME.match(name):
            raise BadInput("screenshot needs name=N (letters, digits, - and _; no path)", where)
    elif cmd.cmd == "message":
        text = args.get("text")
        if set(args) != {"text"} or not isinstance(text, str) or not text.strip():
            raise BadInput('message needs text="..."', where)
    else:
        raise BadInput(f"{cmd.cmd!r} is not a kiosk command ({', '.join(KIOSK_COMMANDS)})",
                       where)
