"""A mock haptic device on a pty pair: protocol v1 with a spring-mass handle.

``serial-mock:NAME?script=stroke`` opens one.  The device side holds the pty
master; the station opens the slave through pyserial exactly as it opens a
USB CDC port, through a stable symlink (like the one the udev rule makes) that
follows the device across unplug/replug.

The handle is a mass on a spring held by a scripted hand: every 0.25 ms of
model time ``m·a = k_hand·(hand − x) − c·v + F`` where ``F`` is the force the
station commands (clamped to the declared limits, zero while disabled, and
zero once no station frame has arrived for 50 ms — the device watchdog).  So
when the station renders the canvas pushing back, the handle stops above where
the hand would put it, as a real hand on a real device would feel.

The device records every force frame it receives (:attr:`received`) and the
force it applied at every model step (:attr:`applied`), which is what the
tests assert the limits and the watchdog on.

Scripts (hand target in mm, device frame): ``stroke`` (hover, press in, drag
pressing deeper, lift; 2 s), ``press`` (straight down and up at the centre;
2 s), ``rest`` (pressing lightly in a slow circle, forever), ``hover``
(forever).  Options: ``rate`` (pose Hz, default 1000), ``limit`` (declared
force limit N, default 3.3), ``corrupt`` (fraction of pose frames with a
flipped byte), ``seed``, ``unplug`` (seconds after the start to unplug),
``replug`` (seconds until it comes back, default 0.3), ``tilt`` (degrees the
hand leans the handle to the right).
"""

from __future__ import annotations

import math
import os
import random
import select
import shutil
import tempfile
import threading
import time
import tty
from collections.abc import Callable
from dataclasses import dataclass, field

from station.drivers.serial.protocol import (
    ERR_BAD_FRAME,
    ERR_OVER_LIMIT,
    ERR_VERSION,
    ERR_WATCHDOG,
    POSE_CLAMPED,
    POSE_ENABLED,
    POSE_WATCHDOG,
    PROTOCOL_MAJOR,
    PROTOCOL_MINOR,
    STATION_TYPES,
    DeviceError,
    Enable,
    Force,
    FrameDecoder,
    Heartbeat,
    Hello,
    HelloRequest,
    Message,
    Pose,
    Sequencer,
    Vibration,
)

Vec3 = tuple[float, float, float]
HandScript = Callable[[float], Vec3]
WATCHDOG_S = 0.05
STEP_S = 0.00025
KEEP = 600_000
"""Records kept per log (10 minutes at 1 kHz): a demo may run the mock for hours."""


def _keep(log: list) -> None:
    if len(log) > KEEP:
        del log[: KEEP // 2]


def _smooth(a: float) -> float:
    a = min(1.0, max(0.0, a))
    return a * a * (3 - 2 * a)


def _lerp(p: Vec3, q: Vec3, a: float) -> Vec3:
    return (p[0] + (q[0] - p[0]) * a, p[1] + (q[1] - p[1]) * a, p[2] + (q[2] - p[2]) * a)


def _stroke(t: float) -> Vec3:
    start, end = (-20.0, -8.0), (20.0, 8.0)
    if t < 0.3:
        return (*start, 15.0)
    if t < 0.6:  # down until the hand would put the tip 1 mm into the hairs
        return (*start, 15.0 - 10.0 * _smooth((t - 0.3) / 0.3))
    if t < 1.6:  # drag, pressing from 1 mm to 4 mm deep
        a = (t - 0.6) / 1.0
        x, y = start[0] + (end[0] - start[0]) * a, start[1] + (end[1] - start[1]) * a
        return (x, y, 5.0 - 3.0 * a)
    if t < 1.8:
        return (*end, 2.0 + 13.0 * _smooth((t - 1.6) / 0.2))
    return (*end, 15.0)


def _press(t: float) -> Vec3:
    return (0.0, 0.0, 15.0 - 12.0 * math.sin(math.pi * min(1.0, t / 2.0)))


def _rest(t: float) -> Vec3:
    a = 2 * math.pi * t / 2.0
    return (10.0 * math.cos(a), 10.0 * math.sin(a), 4.0)


def _hover(t: float) -> Vec3:
    return (0.0, 0.0, 20.0)


SCRIPTS: dict[str, tuple[HandScript, float | None]] = {
    "stroke": (_stroke, 2.0), "press": (_press, 2.0), "rest": (_rest, None),
    "hover": (_hover, None),
}  # fmt: skip


def default_hello(limit: float = 3.3, rate_hz: int = 1000) -> Hello:
    return Hello(PROTOCOL_MAJOR, PROTOCOL_MINOR, 0x1209, 0x4A50, rate_hz, buttons=2, rot_axes=2,
                 force_axes=3, max_force=(limit * 0.9, limit * 0.9, limit), max_torque=0.0,
                 workspace=(160.0, 120.0, 70.0), serial="MOCK0001",
                 name="Mock spring-mass haptic pen")


@dataclass(frozen=True)
class Received:
    """A force frame as the device received it (``t``: device clock, s)."""

    t: float
    force: Force
    seq: int


@dataclass
class HandleModel:
    """The spring-mass handle (SI inside: m, m/s, N; positions reported in mm)."""

    mass: float = 0.05  # kg
    k_hand: float = 1000.0  # N/m: a hand gripping the pen
    damping: float = 10.0  # N·s/m (about 0.7 of critical with the hand spring)
    pos: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.02])
    vel: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])

    def step(self, hand_mm: Vec3, force: Vec3, dt: float) -> None:
        for i in range(3):
            acc = (self.k_hand * (hand_mm[i] / 1000.0 - self.pos[i]) - self.damping * self.vel[i]
                   + force[i]) / self.mass
            self.vel[i] += acc * dt  # semi-implicit Euler: stable for these stiffnesses at 0.25 ms
            self.pos[i] += self.vel[i] * dt

    @property
    def mm(self) -> Vec3:
        return (self.pos[0] * 1000.0, self.pos[1] * 1000.0, self.pos[2] * 1000.0)


class MockHapticDevice:
    """The device side (see the module docstring).  ``start()`` runs it in a thread."""

    def __init__(self, script: str = "stroke", hello: Hello | None = None, corrupt: float = 0.0,
                 seed: int = 0, unplug_at: float | None = None, replug_after: float | None = 0.3,
                 tilt_deg: float = 0.0, directory: str | None = None) -> None:
        self.hand, self.duration = SCRIPTS[script]
        self.hello = hello or default_hello()
        self.corrupt = corrupt
        self.rng = random.Random(seed)
        self.unplug_at = unplug_at
        self.replug_after = replug_after
        self.tilt = math.radians(tilt_deg)
        self._dir = directory or tempfile.mkdtemp(prefix="station-haptic-")
        self.path = os.path.join(self._dir, "ttyHAPTIC0")
        self.model = HandleModel()
        self.model.pos = [p / 1000.0 for p in self.hand(0.0)]
        self.received: list[Received] = []
        self.applied: list[tuple[float, float, float]] = []
        """(t, applied |F| in N, t of the last station frame) at every 1 ms of model time."""
        self.poses_sent: list[float] = []
        self.violations = 0
        self.bad_frames = 0
        self.watchdog_trips = 0
        self.unplugs = 0
        self.plugged = False
        self.finished = False
        self.muted = False  # stop sending poses (the station's watchdog test)
        self._master = self._slave = -1
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._reset_session()
        self._plug()

    # -- plugging -------------------------------------------------------------------
    def _reset_session(self) -> None:
        self.decoder = FrameDecoder(accept=STATION_TYPES, synced=False)
        self.seq = Sequencer()
        self.session = False
        self.enabled = False
        self.command: Force = Force()
        self.vibration: tuple[float, float, float] = (0.0, 0.0, 0.0)  # amplitude, Hz, until
        self.last_rx: float | None = None
        self._tripped = False
        self._error_sent = 0.0

    def _plug(self) -> None:
        master, slave = os.openpty()
        tty.setraw(slave)  # no line discipline: the protocol's bytes pass untouched
        os.set_blocking(master, False)
        self._master, self._slave = master, slave
        tmp = self.path + ".new"
        if os.path.lexists(tmp):
            os.unlink(tmp)
        os.symlink(os.ttyname(slave), tmp)
        os.replace(tmp, self.path)  # atomic, like udev moving its link
        self._reset_session()
        self.plugged = True

    def unplug(self) -> None:
        """The cable is pulled: the port vanishes and the motors lose power."""
        with self._lock:
            if not self.plugged:
                return
            self.plugged = False
            self.unplugs += 1
            for fd in (self._master, self._slave):
                try:
                    os.close(fd)
                except OSError:
                    pass
            if os.path.lexists(self.path):
                os.unlink(self.path)
            self._reset_session()

    def replug(self) -> None:
        with self._lock:
            if not self.plugged and not self.finished:
                self._plug()

    # -- running --------------------------------------------------------------------
    def start(self) -> MockHapticDevice:
        self._t0 = time.monotonic()
        self._thread = threading.Thread(target=self._run, name="mock-haptic", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        self.unplug()
        shutil.rmtree(self._dir, ignore_errors=True)

    def now(self) -> float:
        """Device clock: seconds since start()."""
        return time.monotonic() - self._t0

    def _run(self) -> None:
        period = 1.0 / self.hello.rate_hz
        model_t = 0.0
        next_t = time.monotonic()
        unplugged_at: float | None = None
        while not self._stop.is_set():
            now = self.now()
            if self.duration is not None and now >= self.duration and not self.finished:
                self.finished = True
                self.unplug()  # a finite script ends as a device that goes away for good
            if self.unplug_at is not None and now >= self.unplug_at and self.plugged \
                    and not self.unplugs:
                self.unplug()
                unplugged_at = now
            if unplugged_at is not None and self.replug_after is not None \
                    and now >= unplugged_at + self.replug_after:
                unplugged_at = None
                self.replug()
            with self._lock:
                if self.plugged:
                    self._receive(now)
                while model_t + STEP_S <= now:
                    model_t += STEP_S
                    self._physics(model_t)
                if self.plugged and self.session and not self.muted:
                    self._send_pose(now)
            next_t += period
            wait = next_t - time.monotonic()
            if wait > 0:
                time.sleep(wait)
            else:
                next_t = time.monotonic()

    def _receive(self, now: float) -> None:
        try:
            ready, _, _ = select.select([self._master], [], [], 0)
            data = os.read(self._master, 65536) if ready else b""
        except OSError:  # EIO: the station's side is not open (yet)
            data = b""
        before = self.decoder.stats.bad_frames
        for seq, msg in self.decoder.feed(data):
            self._handle(seq, msg, now)
        if self.decoder.stats.bad_frames != before:
            self.bad_frames = self.decoder.stats.bad_frames
            self._error(ERR_BAD_FRAME, "bad frame dropped", now)

    def _handle(self, seq: int, msg: Message, now: float) -> None:
        if isinstance(msg, HelloRequest):
            if msg.major != PROTOCOL_MAJOR:
                self._write(DeviceError(ERR_VERSION, f"speaks {PROTOCOL_MAJOR}.x"))
                return
            self.session = True
            self._write(self.hello)
            return
        self.last_rx = now
        self._tripped = False
        if isinstance(msg, Force):
            self.received.append(Received(now, msg, seq))
            _keep(self.received)
            lim = self.hello.max_force
            if any(abs(f) > m for f, m in zip(msg.vector, lim, strict=False)):
                self.violations += 1
                self._error(ERR_OVER_LIMIT, "force over the declared limit, clamped", now)
            self.command = msg
        elif isinstance(msg, Enable):
            self.enabled = msg.on
        elif isinstance(msg, Vibration):
            self.vibration = (min(msg.amplitude, self.hello.max_force[2]), msg.frequency_hz,
                              now + msg.duration_ms / 1000.0)
        elif isinstance(msg, Heartbeat):
            pass

    def output_force(self, t: float) -> Vec3:
        """What the motors push at device time ``t`` (the watchdog and the limits applied)."""
        if not self.enabled or self.last_rx is None or t - self.last_rx > WATCHDOG_S:
            return (0.0, 0.0, 0.0)
        lim = self.hello.max_force
        f = [min(m, max(-m, v)) for v, m in zip(self.command.vector, lim, strict=False)]
        amp, hz, until = self.vibration
        if amp and t < until:
            f[2] += amp * math.sin(2 * math.pi * hz * t)
            f[2] = min(lim[2], max(-lim[2], f[2]))
        return (f[0], f[1], f[2])

    def _physics(self, t: float) -> None:
        force = self.output_force(t)
        if self.enabled and self.last_rx is not None and t - self.last_rx > WATCHDOG_S \
                and not self._tripped:
            self._tripped = True
            self.watchdog_trips += 1
            self._error(ERR_WATCHDOG, "no station frame for 50 ms: force off", t)
        self.model.step(self.hand(t), force, STEP_S)
        if round(t / STEP_S) % 4 == 0:
            self.applied.append((t, math.sqrt(sum(f * f for f in force)),
                                 -1.0 if self.last_rx is None else self.last_rx))
            _keep(self.applied)

    def _send_pose(self, now: float) -> None:
        x, y, z = self.model.mm
        half = self.tilt / 2
        flags = (POSE_ENABLED if self.enabled else 0) | (POSE_WATCHDOG if self._tripped else 0)
        if self.enabled and any(abs(f) > m for f, m in zip(self.command.vector,
                                                           self.hello.max_force, strict=False)):
            flags |= POSE_CLAMPED
        pose = Pose(round(now * 1e6) & 0xFFFFFFFF, x, y, z,
                    (math.cos(half), 0.0, math.sin(half), 0.0), 0, flags)
        frame = bytearray(self.seq.frame(pose))
        if self.corrupt and self.rng.random() < self.corrupt:
            i = self.rng.randrange(len(frame) - 1)  # never the delimiter: resync stays cheap
            frame[i] ^= 1 << self.rng.randrange(8)
            if frame[i] == 0:
                frame[i] = 0x55
        self.poses_sent.append(now)
        _keep(self.poses_sent)
        self._write_raw(bytes(frame))

    def _error(self, code: int, text: str, now: float) -> None:
        if now - self._error_sent >= 0.01:  # at most 100 error frames a second
            self._error_sent = now
            self._write(DeviceError(code, text))

    def _write(self, msg: Message) -> None:
        self._write_raw(self.seq.frame(msg))

    def _write_raw(self, data: bytes) -> None:
        if not self.plugged:
            return
        try:
            os.write(self._master, data)
        except OSError:  # nobody reads: the pty buffer is full; like a UART, frames are lost
            pass
