"""The evdev driver: pen devices the kernel already parsed (``/dev/input/event*``).

Pure parts (capabilities, frame assembly, SYN_DROPPED resync) live in
:mod:`station.drivers.evdev.frames`; the live node is a transport
(:mod:`station.drivers.transport.evdev`) and discovery is in
:mod:`station.drivers.evdev.discover`.
"""

from station.drivers.evdev.frames import (
    AbsInfo,
    EvdevCaps,
    EvdevState,
    FrameAssembler,
    InputEvent,
    StaticState,
    is_pen_device,
    ranges_from_caps,
)

__all__ = [
    "AbsInfo",
    "EvdevCaps",
    "EvdevState",
    "FrameAssembler",
    "InputEvent",
    "StaticState",
    "is_pen_device",
    "ranges_from_caps",
]
