"""evdev frames → :class:`RawSample`: capabilities, axis ranges and frame assembly.

The kernel delivers a pen state as a run of EV_ABS/EV_KEY/EV_MSC events closed
by ``SYN_REPORT``.  :class:`FrameAssembler` keeps the device state, applies a
frame when its ``SYN_REPORT`` arrives and turns the state into a raw sample.
``SYN_DROPPED`` means the kernel buffer overflowed: everything up to the next
``SYN_REPORT`` is discarded and the state is re-read from the device through an
:class:`EvdevState` (python-evdev's ``absinfo``/``active_keys`` live, a
:class:`StaticState` in tests).  Nothing here touches hardware.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass, field
from typing import Protocol

from station.drivers.evdev import codes as c
from station.drivers.raw import Axis, AxisRanges, RawSample

from station.events import Button, Tool


@dataclass(frozen=True, slots=True)
class InputEvent:
    """One evdev event; ``time`` in seconds from the transport (kernel timestamp)."""

    time: float
    type: int
    code: int
    value: int


@dataclass(frozen=True, slots=True)
class AbsInfo:
    """``struct input_absinfo`` of one axis (resolution as the kernel reports it)."""

    minimum: int
    maximum: int
    fuzz: int = 0
    flat: int = 0
    resolution: int = 0
    value: int = 0


@dataclass(frozen=True)
class EvdevCaps:
    """What an evdev node says about itself.

    Attributes:
        name: device name (``EVIOCGNAME``).
        vid, pid, bus, version: ``struct input_id``.
        absinfo: absolute axes by code.
        keys: EV_KEY codes the device can send.
        msc: EV_MSC codes the device can send.
        path: node path, e.g. ``/dev/input/event5`` ("" for traces).
    """

    name: str
    absinfo: Mapping[int, AbsInfo]
    keys: frozenset[int]
    vid: int = 0
    pid: int = 0
    bus: int = 0
    version: int = 0
    msc: frozenset[int] = frozenset()
    path: str = ""


def is_pen_device(caps: EvdevCaps) -> bool:
    """ABS_X and ABS_Y plus BTN_TOOL_PEN or BTN_STYLUS: a pen (not a touchpad or pad).

    Wacom *pad* nodes also declare ABS_X/ABS_Y and BTN_STYLUS (kernel
    wacom_setup_pad_capabilities, for old X drivers) next to BTN_0…: a node
    with pad buttons, no BTN_TOOL_PEN and no pressure is a pad, as udev's
    input_id tags it (ID_INPUT_TABLET_PAD), not a pen.
    """
    has_xy = c.ABS_X in caps.absinfo and c.ABS_Y in caps.absinfo
    if not has_xy:
        return False
    if c.BTN_TOOL_PEN in caps.keys:
        return True
    if c.BTN_STYLUS not in caps.keys:
        return False
    pad = c.BTN_0 in caps.keys and c.ABS_PRESSURE not in caps.absinfo
    return not pad


def _axis(info: AbsInfo | None, resolution: float | None = None) -> Axis | None:
    if info is None:
        return None
    res = resolution if resolution is not None else (float(info.resolution) or None)
    return Axis(info.minimum, info.maximum, res)


def ranges_from_caps(caps: EvdevCaps) -> AxisRanges:
    """Axis ranges in device units.

    The kernel gives x/y resolution in units per mm and angle resolution in units
    per radian (hid-wacom sets 57 on tilt, about one unit per degree, and 287 on
    ABS_Z, the Art Pen barrel rotation: 1800 units a turn); Axis wants units per
    degree, so both are converted.  ABS_WHEEL is the airbrush wheel.
    """
    a = caps.absinfo
    x, y = _axis(a.get(c.ABS_X)), _axis(a.get(c.ABS_Y))
    if x is None or y is None:
        raise ValueError(f"{caps.name!r} has no ABS_X/ABS_Y")

    def angle(code: int) -> Axis | None:
        info = a.get(code)
        if info is None:
            return None
        per_degree = info.resolution * math.pi / 180.0 if info.resolution else None
        return _axis(info, per_degree)

    return AxisRanges(
        x=x,
        y=y,
        pressure=_axis(a.get(c.ABS_PRESSURE)),
        tilt_x=angle(c.ABS_TILT_X),
        tilt_y=angle(c.ABS_TILT_Y),
        distance=_axis(a.get(c.ABS_DISTANCE)),
        rotation=angle(c.ABS_Z),
        wheel=_axis(a.get(c.ABS_WHEEL)),
    )


class EvdevState(Protocol):
    """The device's current state, read after SYN_DROPPED (EVIOCGABS / EVIOCGKEY)."""

    def abs_values(self) -> Mapping[int, int]: ...

    def active_keys(self) -> Collection[int]: ...


@dataclass
class StaticState:
    """A fixed device state: what tests (and traces) hand the assembler for a resync."""

    abs: dict[int, int] = field(default_factory=dict)
    keys: set[int] = field(default_factory=set)

    def abs_values(self) -> Mapping[int, int]:
        return self.abs

    def active_keys(self) -> Collection[int]:
        return self.keys


# Which tool wins when several BTN_TOOL_* are down at once (the kernel sends the
# new tool before releasing the old one on some devices): the more specific one.
_TOOL_PRIORITY = (
    c.BTN_TOOL_RUBBER, c.BTN_TOOL_AIRBRUSH, c.BTN_TOOL_BRUSH, c.BTN_TOOL_PENCIL,
    c.BTN_TOOL_MOUSE, c.BTN_TOOL_LENS, c.BTN_TOOL_PEN,
)  # fmt: skip
_BUTTON_KEYS = {c.BTN_STYLUS: Button.STYLUS, c.BTN_STYLUS2: Button.STYLUS2,
                c.BTN_STYLUS3: Button.STYLUS3}  # fmt: skip


@dataclass
class AssemblerStats:
    """Counters: frames seen, samples made, SYN_DROPPED episodes and the events they cost."""

    frames: int = 0
    samples: int = 0
    dropped: int = 0
    discarded_events: int = 0
    resyncs: int = 0
    pad_frames: int = 0


class FrameAssembler:
    """Assembles evdev events into raw samples, one per SYN_REPORT in proximity.

    ``feed`` returns a :class:`RawSample` when a frame completes and the tool is
    (or just left) proximity, else ``None``.  A device with no BTN_TOOL_* keys
    is taken to be in proximity while it sends frames.
    """

    def __init__(self, caps: EvdevCaps, state: EvdevState | None = None) -> None:
        self.caps = caps
        self.state_source = state
        self.stats = AssemblerStats()
        self._abs: dict[int, int] = {code: info.value for code, info in caps.absinfo.items()}
        self._keys: set[int] = set()
        self._pending_abs: dict[int, int] = {}
        self._pending_keys: dict[int, bool] = {}
        self._serial: int | None = None
        self._pending_serial: int | None = None
        self._dropping = False
        self._was_in = False
        self._has_tool_keys = any(k in caps.keys for k in c.PEN_TOOL_KEYS)
        self._has_touch = c.BTN_TOUCH in caps.keys

    def feed(self, ev: InputEvent) -> RawSample | None:
        if self._dropping:
            if ev.type == c.EV_SYN and ev.code == c.SYN_REPORT:
                self._dropping = False
                return self._resync(ev.time)
            self.stats.discarded_events += 1
            return None
        if ev.type == c.EV_ABS:
            self._pending_abs[ev.code] = ev.value
        elif ev.type == c.EV_KEY:
            if ev.value in (0, 1):  # 2 is autorepeat: no change of state
                self._pending_keys[ev.code] = bool(ev.value)
        elif ev.type == c.EV_MSC and ev.code == c.MSC_SERIAL:
            self._pending_serial = ev.value & 0xFFFFFFFF
        elif ev.type == c.EV_SYN:
            if ev.code == c.SYN_REPORT:
                return self._commit(ev.time)
            if ev.code == c.SYN_DROPPED:
                self.stats.dropped += 1
                self.stats.discarded_events += len(self._pending_abs) + len(self._pending_keys)
                self._pending_abs.clear()
                self._pending_keys.clear()
                self._pending_serial = None
                self._dropping = True
        return None

    def _is_pad_frame(self) -> bool:
        """A frame of the pad sharing the pen's node (kernels before 2.6.38 and some
        out-of-tree wacom drivers): BTN_TOOL_FINGER, or tool id 15 with serial -1.
        Its ABS_MISC/MSC_SERIAL/wheel values belong to the pad, not to the pen."""
        if not self._has_tool_keys:
            return False
        if c.BTN_TOOL_FINGER in self._pending_keys:
            return True
        return (self._pending_abs.get(c.ABS_MISC) == c.PAD_DEVICE_ID
                and self._pending_serial == 0xFFFFFFFF)

    def _commit(self, time: float) -> RawSample | None:
        self.stats.frames += 1
        if self._is_pad_frame():
            self.stats.pad_frames += 1
            self._pending_abs.clear()
            self._pending_keys.clear()
            self._pending_serial = None
            return None
        self._abs.update(self._pending_abs)
        for code, down in self._pending_keys.items():
            if down:
                self._keys.add(code)
            else:
                self._keys.discard(code)
        if self._pending_serial is not None:
            self._serial = self._pending_serial
        changed = bool(self._pending_abs or self._pending_keys or self._pending_serial is not None)
        self._pending_abs.clear()
        self._pending_keys.clear()
        self._pending_serial = None
        if not changed:
            return None
        return self._sample(time)

    def _resync(self, time: float) -> RawSample | None:
        """Re-read the whole state after SYN_DROPPED (no state source: keep ours)."""
        self.stats.resyncs += 1
        if self.state_source is not None:
            self._abs.update(self.state_source.abs_values())
            self._keys = {k for k in self.state_source.active_keys() if k in self.caps.keys}
        return self._sample(time)

    def _sample(self, time: float) -> RawSample | None:
        tool_code = next((k for k in _TOOL_PRIORITY if k in self._keys), None)
        proximity = tool_code is not None if self._has_tool_keys else True
        if not proximity:
            if not self._was_in:
                return None
            self._was_in = False
            self.stats.samples += 1
            return RawSample(time=time, proximity=False, valid=False, serial=self._serial)
        self._was_in = True
        a = self._abs
        axes = self.caps.absinfo

        def get(code: int) -> int | None:
            return a.get(code) if code in axes else None

        buttons = 0
        for code, bit in _BUTTON_KEYS.items():
            if code in self._keys:
                buttons |= int(bit)
        tool = c.PEN_TOOL_KEYS[tool_code] if tool_code is not None else Tool.PEN
        tool_id = get(c.ABS_MISC)
        self.stats.samples += 1
        return RawSample(
            time=time,
            proximity=True,
            x=a.get(c.ABS_X, 0),
            y=a.get(c.ABS_Y, 0),
            tip=(c.BTN_TOUCH in self._keys) if self._has_touch else None,
            pressure=get(c.ABS_PRESSURE),
            tilt_x=get(c.ABS_TILT_X),
            tilt_y=get(c.ABS_TILT_Y),
            distance=get(c.ABS_DISTANCE),
            rotation=get(c.ABS_Z),
            wheel=get(c.ABS_WHEEL),
            buttons=buttons,
            tool=tool,
            serial=self._serial or None,
            tool_id=tool_id or None,
            eraser=tool is Tool.ERASER,
        )
