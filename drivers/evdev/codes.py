"""Linux input event codes used by the pen path (linux/input-event-codes.h).

Kept here as plain integers so the pure frame assembler and the trace readers
work without python-evdev (which only the live evdev transport needs).
"""

from __future__ import annotations

from station.events import Tool

EV_SYN, EV_KEY, EV_REL, EV_ABS, EV_MSC = 0x00, 0x01, 0x02, 0x03, 0x04
SYN_REPORT, SYN_CONFIG, SYN_MT_REPORT, SYN_DROPPED = 0, 1, 2, 3

ABS_X, ABS_Y, ABS_Z = 0x00, 0x01, 0x02
ABS_RZ = 0x05
ABS_THROTTLE = 0x06
ABS_WHEEL = 0x08
ABS_PRESSURE = 0x18
ABS_DISTANCE = 0x19
ABS_TILT_X = 0x1A
ABS_TILT_Y = 0x1B
ABS_MISC = 0x28
ABS_MT_SLOT = 0x2F
ABS_MT_POSITION_X = 0x35

MSC_SERIAL = 0x00
PAD_DEVICE_ID = 0x0F  # ABS_MISC value of Wacom pad frames (kernel wacom_wac.h)

BTN_0 = 0x100  # first pad button
BTN_LEFT, BTN_RIGHT, BTN_MIDDLE = 0x110, 0x111, 0x112
BTN_TOOL_PEN = 0x140
BTN_TOOL_RUBBER = 0x141
BTN_TOOL_BRUSH = 0x142
BTN_TOOL_PENCIL = 0x143
BTN_TOOL_AIRBRUSH = 0x144
BTN_TOOL_FINGER = 0x145
BTN_TOOL_MOUSE = 0x146
BTN_TOOL_LENS = 0x147
BTN_STYLUS3 = 0x149
BTN_TOUCH = 0x14A
BTN_STYLUS = 0x14B
BTN_STYLUS2 = 0x14C
BTN_TOOL_DOUBLETAP = 0x14D

PEN_TOOL_KEYS: dict[int, Tool] = {
    BTN_TOOL_PEN: Tool.PEN,
    BTN_TOOL_RUBBER: Tool.ERASER,
    BTN_TOOL_BRUSH: Tool.BRUSH,
    BTN_TOOL_PENCIL: Tool.PENCIL,
    BTN_TOOL_AIRBRUSH: Tool.AIRBRUSH,
    BTN_TOOL_MOUSE: Tool.MOUSE,
    BTN_TOOL_LENS: Tool.LENS,
}
"""BTN_TOOL_* codes of tablet tools and the tool each one means (finger excluded)."""

TYPE_NAMES = {EV_SYN: "EV_SYN", EV_KEY: "EV_KEY", EV_REL: "EV_REL", EV_ABS: "EV_ABS",
              EV_MSC: "EV_MSC"}  # fmt: skip
