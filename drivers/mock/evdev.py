"""A mock evdev pen: scripted pen states → kernel-style event frames.

Like the kernel's input core, only changed values are sent, each frame ends
with SYN_REPORT, the tool key goes down on proximity-in (with ABS_MISC tool id
and MSC_SERIAL, as hid-wacom does) and up on proximity-out.  Used to make
evemu / libinput-record traces for tests and demos.
"""

from __future__ import annotations

import collections
import errno
import math
import os
import threading
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any

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


# -- a mock evdev node: python-evdev's InputDevice interface over a recording ----------------
@dataclass(frozen=True)
class _PyAbsInfo:
    value: int
    min: int
    max: int
    fuzz: int
    flat: int
    resolution: int


@dataclass(frozen=True)
class _PyEvent:
    sec: int
    usec: int
    type: int
    code: int
    value: int

    def timestamp(self) -> float:
        return self.sec + self.usec / 1e6


@dataclass(frozen=True)
class _PyInfo:
    bustype: int
    vendor: int
    product: int
    version: int


class MockEvdevNode:
    """An evdev node serving recorded events with python-evdev's ``InputDevice`` interface.

    A feeder thread releases one frame (up to SYN_REPORT) at a time when it is
    due (``speed``; ``None`` = at once) and signals it through a pipe, so
    ``select`` on :attr:`fd` works as on a real node.  ``drop_frames`` lists
    frame indices the "kernel buffer" loses: the reader gets SYN_DROPPED and a
    SYN_REPORT instead, while :meth:`absinfo` and :meth:`active_keys` reflect
    them (what EVIOCGABS/EVIOCGKEY return).  At the end of the events
    :meth:`read` raises ENODEV: the end of the recording (``finite``) or an unplug.
    """

    def __init__(self, caps: EvdevCaps, events: Iterable[InputEvent], path: str = "",
                 speed: float | None = None, drop_frames: Iterable[int] = (),
                 finite: bool = True) -> None:
        self.caps = caps
        self.path = path or caps.path or "mock-evdev"
        self.name = caps.name
        self.info = _PyInfo(caps.bus, caps.vid, caps.pid, caps.version)
        self.finite = finite
        self.speed = speed
        self.grabbed = False
        self.grabs = 0
        self._drop = set(drop_frames)
        self._abs = {code: a.value for code, a in caps.absinfo.items()}
        self._keys: set[int] = set()
        # (the frame as it happened, the events the reader gets for it)
        self._ready: collections.deque[tuple[list[InputEvent], list[InputEvent]]] = \
            collections.deque()
        self._lock = threading.Lock()
        self._rfd, self._wfd = os.pipe()
        self._closed_w = False
        os.set_blocking(self._rfd, False)
        self._stop = threading.Event()
        self._origin: tuple[float, float] | None = None
        self._now = 0.0
        self._feeder = threading.Thread(target=self._feed, args=(list(events),), daemon=True,
                                        name="mock-evdev")
        self._feeder.start()

    @property
    def fd(self) -> int:
        return self._rfd

    def _frames(self, events: list[InputEvent]) -> Iterator[list[InputEvent]]:
        frame: list[InputEvent] = []
        for ev in events:
            frame.append(ev)
            if ev.type == c.EV_SYN and ev.code == c.SYN_REPORT:
                yield frame
                frame = []
        if frame:
            yield frame

    def _feed(self, events: list[InputEvent]) -> None:
        try:
            for index, frame in enumerate(self._frames(events)):
                if self._stop.is_set():
                    return
                self._pace(frame[0].time)
                if index in self._drop:
                    t = frame[-1].time
                    delivered = [InputEvent(t, c.EV_SYN, c.SYN_DROPPED, 0),
                                 InputEvent(t, c.EV_SYN, c.SYN_REPORT, 0)]
                else:
                    delivered = frame
                with self._lock:
                    self._ready.append((frame, delivered))
                os.write(self._wfd, b"x")
        except OSError:
            return
        finally:
            with self._lock:
                self._closed_w = True
                try:
                    os.close(self._wfd)  # the reader sees EOF: no more frames
                except OSError:
                    pass

    def _pace(self, t: float) -> None:
        if self.speed is None:
            return
        now = time.monotonic()
        if self._origin is None:
            self._origin = (now, t)
        due = self._origin[0] + (t - self._origin[1]) / self.speed
        while not self._stop.is_set() and (delay := due - time.monotonic()) > 0:
            self._stop.wait(min(delay, 0.05))

    def _apply(self, frame: list[InputEvent]) -> None:
        for ev in frame:
            if ev.type == c.EV_ABS:
                self._abs[ev.code] = ev.value
            elif ev.type == c.EV_KEY and ev.value in (0, 1):
                (self._keys.add if ev.value else self._keys.discard)(ev.code)

    # -- python-evdev's InputDevice interface -------------------------------------------------
    def capabilities(self, absinfo: bool = True) -> dict[int, list[Any]]:
        caps: dict[int, list[Any]] = {c.EV_KEY: sorted(self.caps.keys)}
        caps[c.EV_ABS] = [(code, _PyAbsInfo(a.value, a.minimum, a.maximum, a.fuzz, a.flat,
                                            a.resolution))
                          for code, a in sorted(self.caps.absinfo.items())]
        if self.caps.msc:
            caps[c.EV_MSC] = sorted(self.caps.msc)
        return caps

    def read(self) -> Iterator[_PyEvent]:
        try:
            signalled = os.read(self._rfd, 4096)
        except BlockingIOError:
            raise
        except OSError as exc:
            raise OSError(errno.ENODEV, "No such device") from exc
        out: list[_PyEvent] = []
        with self._lock:
            if not signalled and not self._ready:
                raise OSError(errno.ENODEV, "No such device")
            # The device state moves on as frames reach the reader, dropped ones included;
            # a read stops after a drop so the reader's resync sees the state right after it.
            while self._ready:
                frame, delivered = self._ready.popleft()
                self._apply(frame)
                for ev in delivered:
                    sec = int(ev.time)
                    out.append(_PyEvent(sec, round((ev.time - sec) * 1e6), ev.type, ev.code,
                                        ev.value))
                self._now = frame[-1].time
                if delivered is not frame:
                    break
            if self._ready and not self._closed_w:
                os.write(self._wfd, b"x")  # frames left: the node stays readable
        return iter(out)

    def now(self) -> float:
        if self.speed is not None and self._origin is not None:
            return self._origin[1] + (time.monotonic() - self._origin[0]) * self.speed
        return self._now

    def absinfo(self, code: int) -> _PyAbsInfo:
        a = self.caps.absinfo[code]
        with self._lock:
            value = self._abs.get(code, a.value)
        return _PyAbsInfo(value, a.minimum, a.maximum, a.fuzz, a.flat, a.resolution)

    def active_keys(self) -> list[int]:
        with self._lock:
            return sorted(self._keys)

    def grab(self) -> None:
        if self.grabbed:
            raise OSError(errno.EBUSY, "Device or resource busy")
        self.grabbed = True
        self.grabs += 1

    def ungrab(self) -> None:
        self.grabbed = False

    def close(self) -> None:
        self._stop.set()
        try:
            os.close(self._rfd)
        except OSError:
            pass
        if threading.current_thread() is not self._feeder:
            self._feeder.join(timeout=1.0)
