"""A mock hidraw node: serves timed reports over a SOCK_SEQPACKET socket.

The station's :class:`~station.drivers.transport.hidraw.HidrawTransport` reads
it exactly like ``/dev/hidrawN`` (select, then one ``os.read`` per report —
SEQPACKET keeps report boundaries as hidraw does); the "ioctls" answer from
the recording: descriptor, (bus, vid, pid), name, phys.  Feature reports the
driver sends are logged in :attr:`MockHidrawNode.features` (the Wacom ``02 02``
mouse-mode switch must show up there).

Reports are paced by their timestamps at ``speed`` (1.0 = as recorded,
``None`` = as fast as the reader takes them).  Each report read is stamped
with its recorded time, so replays through the mock are deterministic.
"""

from __future__ import annotations

import collections
import logging
import socket
import threading
import time
from collections.abc import Callable, Iterable

from station.drivers.transport.base import HidDeviceInfo, TimedReport

log = logging.getLogger(__name__)


class MockHidrawNode:
    """A hidraw node backed by a list (or generator) of :class:`TimedReport`.

    Args:
        info: identity and report descriptor to answer the ioctls with.
        reports: the reports to serve, in time order.
        speed: playback speed (1.0 real time); ``None`` = no pacing.
        refuse_features: feature reports to fail with EPIPE (to test error paths).
        on_feature: called with each feature report accepted (the device reacting).
        finite: the end of ``reports`` is the end of a recording (else an unplug).
    """

    def __init__(self, info: HidDeviceInfo, reports: Iterable[TimedReport],
                 speed: float | None = None, refuse_features: Iterable[bytes] = (),
                 on_feature: Callable[[bytes], None] | None = None, finite: bool = True) -> None:
        self.info = info
        self.finite = finite  # False: the end of the reports looks like an unplug
        self.on_feature = on_feature
        self.path = info.path or f"mock-hidraw:{info.vid:04x}:{info.pid:04x}"
        self.speed = speed
        self.features: list[bytes] = []
        self.refuse = {bytes(r) for r in refuse_features}
        self._times: collections.deque[float] = collections.deque()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._ours, self._theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        self._ours.setblocking(False)
        self._feeder = threading.Thread(target=self._feed, args=(iter(reports),),
                                        name="mock-hidraw", daemon=True)
        self._origin: tuple[float, float] | None = None
        self._now = 0.0
        self._feeder.start()

    # -- what the device does -------------------------------------------
    def _feed(self, reports: Iterable[TimedReport]) -> None:
        try:
            for report in reports:
                if self._stop.is_set():
                    return
                self._pace(report.time)
                with self._lock:
                    self._times.append(report.time)
                try:
                    self._theirs.send(report.data)
                except OSError:
                    return
        finally:
            try:
                self._theirs.shutdown(socket.SHUT_WR)  # the reader sees b"": end of stream
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

    # -- what the transport calls ----------------------------------------
    def fileno(self) -> int:
        return self._ours.fileno()

    def stamp(self, data: bytes, now: float) -> float:
        """The recorded time of the report just read (reports arrive in order)."""
        with self._lock:
            t = self._times.popleft() if self._times else now
        self._now = t
        return t

    def now(self) -> float:
        """The recording's clock: the time of the last report served."""
        if self.speed is not None and self._origin is not None:
            return self._origin[1] + (time.monotonic() - self._origin[0]) * self.speed
        return self._now

    def descriptor(self) -> bytes:
        return self.info.descriptor or b""

    def raw_info(self) -> tuple[int, int, int]:
        return self.info.bus, self.info.vid, self.info.pid

    def name(self) -> str:
        return self.info.name

    def phys(self) -> str:
        return self.info.phys or "mock"

    def set_feature(self, data: bytes) -> None:
        data = bytes(data)
        if data in self.refuse:
            raise BrokenPipeError(32, "Broken pipe")
        self.features.append(data)
        if self.on_feature is not None:
            self.on_feature(data)
        log.info("%s: feature report %s", self.path, data.hex(" "))

    def close(self) -> None:
        self._stop.set()
        for sock in (self._ours, self._theirs):
            try:
                sock.close()
            except OSError:
                pass
        if threading.current_thread() is not self._feeder:
            self._feeder.join(timeout=1.0)

    def __del__(self) -> None:  # a forgotten node must not leave a thread writing
        self._stop.set()

