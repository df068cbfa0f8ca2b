"""Linux input event codes used by the pen path: python-evdev's ``ecodes``.

``ecodes`` is generated from the kernel's ``linux/input-event-codes.h`` when
python-evdev is built, so the numbers are the kernel's, not a copy kept here.
python-evdev only exists for Linux (it needs the kernel's headers; evdev-binary
ships Linux wheels only); elsewhere the few codes the recording readers need
(evemu and libinput-record files replay on any OS) are written out below —
values from input-event-codes.h, which the kernel keeps stable as ABI.
"""

from __future__ import annotations

import sys

from station.events import Tool

if sys.platform == "linux":
    from evdev.ecodes import (
        ABS_DISTANCE,
        ABS_MISC,
        ABS_MT_POSITION_X,
        ABS_MT_SLOT,
        ABS_PRESSURE,
        ABS_RZ,
        ABS_THROTTLE,
        ABS_TILT_X,
        ABS_TILT_Y,
        ABS_WHEEL,
        ABS_X,
        ABS_Y,
        ABS_Z,
        BTN_0,
        BTN_LEFT,
        BTN_MIDDLE,
        BTN_RIGHT,
        BTN_STYLUS,
        BTN_STYLUS2,
        BTN_STYLUS3,
        BTN_TOOL_AIRBRUSH,
        BTN_TOOL_BRUSH,
        BTN_TOOL_DOUBLETAP,
        BTN_TOOL_FINGER,
        BTN_TOOL_LENS,
        BTN_TOOL_MOUSE,
        BTN_TOOL_PEN,
        BTN_TOOL_PENCIL,
        BTN_TOOL_RUBBER,
        BTN_TOUCH,
        EV,
        EV_ABS,
        EV_KEY,
        EV_MSC,
        EV_REL,
        EV_SYN,
        MSC_SERIAL,
        SYN_CONFIG,
        SYN_DROPPED,
        SYN_MT_REPORT,
        SYN_REPORT,
    )
else:  # pragma: no cover - no python-evdev off Linux
    EV_SYN, EV_KEY, EV_REL, EV_ABS, EV_MSC = 0x00, 0x01, 0x02, 0x03, 0x04
    EV = {EV_SYN: "EV_SYN", EV_KEY: "EV_KEY", EV_REL: "EV_REL", EV_ABS: "EV_ABS",
          EV_MSC: "EV_MSC"}
    SYN_REPORT, SYN_CONFIG, SYN_MT_REPORT, SYN_DROPPED = 0, 1, 2, 3
    ABS_X, ABS_Y, ABS_Z, ABS_RZ, ABS_THROTTLE, ABS_WHEEL = 0x00, 0x01, 0x02, 0x05, 0x06, 0x08
    ABS_PRESSURE, ABS_DISTANCE, ABS_TILT_X, ABS_TILT_Y = 0x18, 0x19, 0x1A, 0x1B
    ABS_MISC, ABS_MT_SLOT, ABS_MT_POSITION_X = 0x28, 0x2F, 0x35
    MSC_SERIAL = 0x00
    BTN_0, BTN_LEFT, BTN_RIGHT, BTN_MIDDLE = 0x100, 0x110, 0x111, 0x112
    (BTN_TOOL_PEN, BTN_TOOL_RUBBER, BTN_TOOL_BRUSH, BTN_TOOL_PENCIL, BTN_TOOL_AIRBRUSH,
     BTN_TOOL_FINGER, BTN_TOOL_MOUSE, BTN_TOOL_LENS) = range(0x140, 0x148)
    BTN_STYLUS3, BTN_TOUCH, BTN_STYLUS, BTN_STYLUS2, BTN_TOOL_DOUBLETAP = range(0x149, 0x14E)

PAD_DEVICE_ID = 0x0F
"""ABS_MISC value of Wacom pad frames (the kernel's wacom_wac.h, not an input code)."""

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

TYPE_NAMES: dict[int, str] = {t: str(EV[t]) for t in (EV_SYN, EV_KEY, EV_REL, EV_ABS, EV_MSC)}
"""Names of the event types the pen path reads."""

__all__ = [
    "ABS_DISTANCE", "ABS_MISC", "ABS_MT_POSITION_X", "ABS_MT_SLOT", "ABS_PRESSURE", "ABS_RZ",
    "ABS_THROTTLE", "ABS_TILT_X", "ABS_TILT_Y", "ABS_WHEEL", "ABS_X", "ABS_Y", "ABS_Z", "BTN_0",
    "BTN_LEFT", "BTN_MIDDLE", "BTN_RIGHT", "BTN_STYLUS", "BTN_STYLUS2", "BTN_STYLUS3",
    "BTN_TOOL_AIRBRUSH", "BTN_TOOL_BRUSH", "BTN_TOOL_DOUBLETAP", "BTN_TOOL_FINGER",
    "BTN_TOOL_LENS", "BTN_TOOL_MOUSE", "BTN_TOOL_PEN", "BTN_TOOL_PENCIL", "BTN_TOOL_RUBBER",
    "BTN_TOUCH", "EV", "EV_ABS", "EV_KEY", "EV_MSC", "EV_REL", "EV_SYN", "MSC_SERIAL",
    "PAD_DEVICE_ID", "PEN_TOOL_KEYS", "SYN_CONFIG", "SYN_DROPPED", "SYN_MT_REPORT",
    "SYN_REPORT", "TYPE_NAMES",
]  # fmt: skip
