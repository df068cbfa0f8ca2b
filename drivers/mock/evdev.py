"""A mock evdev pen: scripted pen states → kernel-style event frames.

Like the kernel's input core, only changed values are sent, each frame ends
with SYN_REPORT, the tool key goes down on proximity-in (with ABS_MISC tool id
and MSC_SERIAL, as hid-wacom does) and up on proximity-out.  Used to make
evemu / libinput-record traces for tests and demos.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from station.drivers.evdev import codes as c
from station.drivers.evdev.frames import AbsInfo, EvdevCaps, InputEvent
from station.drivers.mock.script import PenState

from station.events import Button, Tool

_TOOL_KEY = {tool: code for code, tool in c.PEN_TOOL_KEYS.items()}


def wacom_like_caps(name: str = "Mock Wacom Intuos Pro M Pen", max_x: int = 44704,
                    max_y: int = 27940, max_pressure: int = 2047, resolution: int = 200,
                    vid: int = 0x056A, pid: int = 0x0315) -> EvdevCaps:
    """Capabilities like hid-wacom gives an Intuos pen node (tilt res 57 units/radian)."""
    absinfo = {
        c.ABS_X: AbsInfo(0, max_x, 4, 0, resolution),
        c.ABS_Y: AbsInfo(0, max_y, 4, 0, resolution),
        c.ABS_Z: AbsInfo(-900, 899, 0, 0, 0),
        c.ABS_WHEEL: AbsInfo(0, 1023, 0, 0, 0),
        c.ABS_PRESSURE: AbsInfo(0, max_pressure, 0, 0, 0),
        c.ABS_DISTANCE: AbsInfo(0, 63, 0, 0, 0),
        c.ABS_TILT_X: AbsInfo(-64, 63, 0, 0, 57),
        c.ABS_TILT_Y: AbsInfo(-64, 63, 0, 0, 57),
        c.ABS_MISC: AbsInfo(0, 0, 0, 0, 0),
    }
    keys = frozenset({*c.PEN_TOOL_KEYS, c.BTN_TOUCH, c.BTN_STYLUS, c.BTN_STYLUS2,
                      c.BTN_STYLUS3})
    return EvdevCaps(name=name, absinfo=absinfo, keys=keys, vid=vid, pid=pid, bus=3,
                     version=0x110, msc=frozenset({c.MSC_SERIAL}))


def touchpad_caps(name: str = "Mock Wacom Intuos Pro M Finger") -> EvdevCaps:
    """A touch interface: ABS_X/Y and BTN_TOOL_FINGER, no pen keys."""
    absinfo = {c.ABS_X: AbsInfo(0, 4096, 0, 0, 40), c.ABS_Y: AbsInfo(0, 4096, 0, 0, 40),
               c.ABS_MT_SLOT: AbsInfo(0, 9), c.ABS_MT_POSITION_X: AbsInfo(0, 4096)}
    return EvdevCaps(name=name, absinfo=absinfo, keys=frozenset({c.BTN_TOOL_FINGER, c.BTN_TOUCH,
                     c.BTN_TOOL_DOUBLETAP}), vid=0x056A, pid=0x0315, bus=3)


def _units(v: float, info: AbsInfo) -> int:
    return round(info.minimum + min(1.0, max(0.0, v)) * (info.maximum - info.minimum))


def states_to_events(caps: EvdevCaps, timed_states: Iterable[tuple[float, PenState]]
                     ) -> list[InputEvent]:
    """Kernel-style events for timed pen states (only changes, SYN_REPORT per state)."""
    a = caps.absinfo
    events: list[InputEvent] = []
    current_abs: dict[int, int] = {}
    keys: set[int] = set()
    in_prox = False
    for t, s in timed_states:
        frame: list[tuple[int, int, int]] = []

        def key(code: int, down: bool, frame: list[tuple[int, int, int]] = frame) -> None:
            if (code in keys) != down and code in caps.keys:
                frame.append((c.EV_KEY, code, int(down)))
                (keys.add if down else keys.discard)(code)

        def absv(code: int, value: int, frame: list[tuple[int, int, int]] = frame) -> None:
            if code in a and current_abs.get(code) != value:
                frame.append((c.EV_ABS, code, value))
                current_abs[code] = value

        if not s.proximity:
            if not in_prox:
                continue
            for code in (c.BTN_TOUCH, c.BTN_STYLUS, c.BTN_STYLUS2):
                key(code, False)
            absv(c.ABS_PRESSURE, 0)
            absv(c.ABS_MISC, 0)
            for code in list(keys):
                key(code, False)
            in_prox = False
        else:
            absv(c.ABS_X, _units(s.x, a[c.ABS_X]))
            absv(c.ABS_Y, _units(s.y, a[c.ABS_Y]))
            p_info = a.get(c.ABS_PRESSURE)
            pressure = _units(s.pressure, p_info) if p_info else 0
            absv(c.ABS_PRESSURE, pressure)
            absv(c.ABS_DISTANCE, _units(s.distance, a[c.ABS_DISTANCE])
                 if c.ABS_DISTANCE in a else 0)
            absv(c.ABS_TILT_X, max(-64, min(63, round(s.tilt_x))))
            absv(c.ABS_TILT_Y, max(-64, min(63, round(s.tilt_y))))
            if s.tool is Tool.AIRBRUSH:
                absv(c.ABS_WHEEL, _units(s.wheel, a[c.ABS_WHEEL]))
            if c.ABS_Z in a and s.tool is Tool.PEN and s.tool_id == 0x10804:  # Art Pen
                absv(c.ABS_Z, round(s.rotation * 5) if math.isfinite(s.rotation) else 0)
            absv(c.ABS_MISC, s.tool_id)
            key(_TOOL_KEY[s.tool], True)
            key(c.BTN_TOUCH, pressure > 10)
            key(c.BTN_STYLUS, bool(s.buttons & Button.STYLUS))
            key(c.BTN_STYLUS2, bool(s.buttons & Button.STYLUS2))
            if c.MSC_SERIAL in caps.msc:
                frame.append((c.EV_MSC, c.MSC_SERIAL, s.serial))
            in_prox = True
        events.extend(InputEvent(t, *e) for e in frame)
        events.append(InputEvent(t, c.EV_SYN, c.SYN_REPORT, 0))
    return events
