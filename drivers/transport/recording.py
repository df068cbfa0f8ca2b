"""Recording transports: a trace device played back as if it were live.

Timestamps are the recorded ones.  ``speed`` paces playback (1.0 = as
recorded, 2.0 = twice as fast); ``None`` plays as fast as the reader takes it.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from station.drivers.evdev import codes as c
from station.drivers.evdev.frames import EvdevState, InputEvent, StaticState
from station.drivers.traces.model import TraceDevice
from station.drivers.transport.base import EndOfStream, HidDeviceInfo, TimedReport


class Pacer:
    """Maps recording time to wall time at ``speed`` (None = no waiting)."""

    def __init__(self, speed: float | None, clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        self.speed = speed
        self.clock = clock
        self.sleep = sleep
        self._origin: tuple[float, float] | None = None
        self.now_trace = 0.0

    def wait(self, t: float, timeout: float | None) -> bool:
        """Wait until recording time ``t`` is due; False if ``timeout`` ran out first."""
        if self.speed is None:
            self.now_trace = t
            return True
        now = self.clock()
        if self._origin is None:
            self._origin = (now, t)
        due = self._origin[0] + (t - self._origin[1]) / self.speed
        if timeout is not None and due - now > timeout:
            self.sleep(max(0.0, timeout))
            self.now_trace = self.trace_now()
            return False
        if due > now:
            self.sleep(due - now)
        self.now_trace = t
        return True

    def trace_now(self) -> float:
        if self.speed is None or self._origin is None:
            return self.now_trace
        return self._origin[1] + (self.clock() - self._origin[0]) * self.speed


class RecordedHidTransport:
    """The reports of one hid-recorder device; feature reports are logged."""

    def __init__(self, device: TraceDevice, path: str = "", speed: float | None = None) -> None:
        self.device = device
        self.info: HidDeviceInfo = device.hid_info(path or device.where)
        self.pacer = Pacer(speed)
        self.features_sent: list[bytes] = []
        self._i = 0

    def read(self, timeout: float | None = None) -> TimedReport | None:
        reports = self.device.reports
        if self._i >= len(reports):
            raise EndOfStream(f"{self.info.path}: end of recording")
        report = reports[self._i]
        if not self.pacer.wait(report.time, timeout):
            return None
        self._i += 1
        return report

    def now(self) -> float:
        return self.pacer.trace_now()

    def send_feature(self, data: bytes) -> None:
        self.features_sent.append(bytes(data))

    def close(self) -> None:
        self._i = len(self.device.reports)


class RecordedEvdevTransport:
    """The events of one evemu / libinput-record device, a frame per read.

    The device state for a SYN_DROPPED resync is the state the recording had
    reached (values of all events up to the drop), which is what the kernel
    would report.
    """

    def __init__(self, device: TraceDevice, speed: float | None = None) -> None:
        if device.caps is None:
            raise ValueError("not an evdev trace device")
        self.device = device
        self.caps = device.caps
        self.pacer = Pacer(speed)
        self._i = 0
        self._state = StaticState({k: a.value for k, a in self.caps.absinfo.items()}, set())

    def read(self, timeout: float | None = None) -> list[InputEvent]:
        events = self.device.events
        if self._i >= len(events):
            raise EndOfStream(f"{self.device.where}: end of recording")
        if not self.pacer.wait(events[self._i].time, timeout):
            return []
        out: list[InputEvent] = []
        while self._i < len(events):
            ev = events[self._i]
            self._i += 1
            out.append(ev)
            if ev.type == c.EV_ABS:
                self._state.abs[ev.code] = ev.value
            elif ev.type == c.EV_KEY and ev.value in (0, 1):
                (self._state.keys.add if ev.value else self._state.keys.discard)(ev.code)
            if ev.type == c.EV_SYN and ev.code == c.SYN_REPORT:
                break
        return out

    def state(self) -> EvdevState:
        # Everything recorded up to now, including what a SYN_DROPPED made us skip.
        return self._state

    def now(self) -> float:
        return self.pacer.trace_now()

    def close(self) -> None:
        self._i = len(self.device.events)
