"""``auto:pen``: the first pen tablet plugged into this machine, for blueprints that do
not name one (the bundled ``kiosk``).

Looked for in the order a person would expect: evdev pen nodes (the kernel driver
serves every tablet it knows; lowest ``eventN`` first), then hidraw nodes of a model
in the device data (bundled or the user's own).  Nothing readable found is a
:class:`TransportError`, so a driver waits and looks again, as it does for an
unplugged tablet; ``station devices`` says what is here and why a node cannot be
opened.
"""

from __future__ import annotations

import os
from collections.abc import Callable

from station.drivers.evdev.frames import is_pen_device
from station.drivers.registry import find_device
from station.drivers.transport.base import TransportError
from station.drivers.transport.evdev import EvdevNode, list_evdev
from station.drivers.transport.hidraw import list_hidraw

WHAT = "pen"


def first_pen_spec(evdev_root: str = "/dev/input",
                   opener: Callable[[str], EvdevNode] | None = None,
                   hidraw_sysfs: str = "/sys/class/hidraw") -> str:
    """The SPEC of the first pen tablet here (``evdev:/dev/input/eventN`` or
    ``hidraw:/dev/hidrawN``); :class:`TransportError` when there is none."""
    unreadable = 0
    if os.path.isdir(evdev_root):
        for entry in list_evdev(evdev_root, opener):
            if "error" in entry:
                unreadable += 1
            elif is_pen_device(entry["caps"]):
                return f"evdev:{entry['path']}"
    for e in list_hidraw(hidraw_sysfs):
        if find_device(int(str(e["vid"])), int(str(e["pid"])), int(str(e["bus"]))) is None:
            continue
        if e["readable"]:
            return f"hidraw:{e['path']}"
        unreadable += 1
    more = (f" ({unreadable} node(s) not readable: install the udev rules)" if unreadable
            else "")
    raise TransportError(f"auto:{WHAT}: no pen tablet found{more}; `station devices` lists "
                         "what is here")
