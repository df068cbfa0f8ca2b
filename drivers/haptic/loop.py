"""The haptic loop: one thread that reads poses, computes the force and sends it, at 1 kHz.

A :class:`HapticSession` owns a serial transport.  :meth:`handshake` opens
the protocol session (hello request → hello: identity, version, limits);
:meth:`start` runs the loop thread, which on every tick

1. reads what the device sent (non-blocking) and decodes it: poses update the
   brush state (and, when the device is also the input, become raw pen
   samples for the pipeline); a bad frame or a device error trips the safety
   filter (zero force this tick);
2. computes the wanted force: the contact model (the brush against the canvas)
   evaluated on the newest pose, plus the force frames that arrive on the bus
   (``haptic.<device>``) interpolated between simulation frames, plus the
   deformable brush's reaction frames (from the simulation's ``HapticForce``
   messages or from a local :class:`ReactionWorker` at the sim rate),
   interpolated likewise, with friction and paper grain added at the loop rate
   (:class:`~station.drivers.haptic.contact.Surface`);
3. passes it through the :class:`SafetyFilter` (watchdog, clamps, rate limit);
4. sends it (a force frame every tick is also the device's heartbeat).

The loop is decoupled from the simulation: it never waits for a sim frame.
It keeps time with absolute deadlines (sleep, then a short spin), so a late
tick does not shift the ones after it; ticks later than a whole period are
counted as overruns and the schedule restarts from now.  On stop it sends zero
force and disables the motors; an unplugged device stops the loop (the device
zeroes itself: its watchdog sees the silence).
"""

from __future__ import annotations

import atexit
import collections
import logging
import math
import os
import threading
import time
import weakref
from array import array
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

from station.drivers.haptic.contact import (
    BrushState,
    ContactModel,
    FrameInterpolator,
    RoundBrushContact,
    Surface,
    Vec3,
    pressure_from_force,
)
from station.drivers.haptic.reaction import ReactionModel, ReactionWorker
from station.drivers.haptic.safety import ZERO, ForceLimits, SafetyFilter
from station.drivers.raw import Axis, AxisRanges, RawSample
from station.drivers.serial.protocol import (
    DEVICE_TYPES,
    ERR_VERSION,
    PROTOCOL_MAJOR,
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
from station.drivers.transport.base import DeviceGone, TransportError

from station import wire

log = logging.getLogger(__name__)

POS_RES = 100.0  # raw position units per mm
TILT_RES = 100.0  # raw tilt units per degree
PRESSURE_MAX = 1000
HISTORY = 65536  # tick times kept for the period statistics
READY_TIMEOUT_S = 30.0
"""How long ``start()`` waits for the reaction worker's solver to load, s."""
BACKLOG_S = 0.5
"""Poses queued longer than this are stamped with their arrival (a device clock jump), s."""


@dataclass
class HapticConfig:
    """How the station drives one haptic device.

    Attributes:
        rate_hz: haptic loop rate, Hz.
        force: send forces (False: the device is only an input; motors stay off).
        input: publish the pose as pen samples.
        max_force: configured limit below the device's declared ones, N (None: the device's).
        rate_n_per_s: largest force change per second and axis, N/s.
        watchdog_s: inputs older than this command zero force, s.
        contact: the brush's contact model (None: forces only from the bus).
        full_force: normal force that is a full-pressure press, N.
        paper_z: height of the paper surface in the device frame, mm.
        proximity_mm: the handle is "in proximity" below this height above the paper, mm.
        handshake_timeout: seconds to wait for the device's hello.
        spin_s: busy-wait this long before each deadline (timing precision for CPU; on a
            loaded machine without real-time priority it makes the scheduler preempt the
            loop more, so the default is 0).
        realtime: SCHED_FIFO priority for the loop thread (1..99; 0 = normal scheduling).
            Needs CAP_SYS_NICE (or an rtprio limit); refused, the loop runs normally and
            the status says why.
        reaction: a reaction model evaluated by a :class:`ReactionWorker` thread at
            ``reaction_hz`` (the deformable brush computed in the driver).
        reaction_hz: rate of that worker, Hz (40: a frame every 25 ms keeps clear of the
            50 ms watchdog when a solve is late).
        reaction_process: solve in a child process (beside the loop, not sharing its GIL).
        surface: friction and grain added at the loop rate to the reaction frames (the
            worker's and the bus's ``HapticForce``); None: the frames as they come.
        pressure: the pen pressure of a pose (None: the contact model's normal force over
            ``full_force``); the deformable brush's is its handle height
            (:func:`~station.drivers.haptic.deformable.height_pressure`).
    """

    rate_hz: float = 1000.0
    force: bool = True
    input: bool = True
    max_force: float | None = None
    rate_n_per_s: float = 200.0
    watchdog_s: float = 0.05
    contact: ContactModel | None = field(default_factory=RoundBrushContact)
    full_force: float = 2.0
    paper_z: float = 0.0
    proximity_mm: float = 30.0
    handshake_timeout: float = 1.0
    spin_s: float = 0.0
    realtime: int = 0
    reaction: ReactionModel | None = None
    reaction_hz: float = 40.0
    reaction_process: bool = True
    surface: Surface | None = None
    pressure: Callable[[BrushState], float] | None = None


@dataclass
class LoopStats:
    """Counts of a session (what ``station driver`` reports in its status)."""

    ticks: int = 0
    overruns: int = 0
    frames_sent: int = 0
    poses: int = 0
    device_errors: Counter[str] = field(default_factory=Counter)
    bus_forces: int = 0
    reaction_frames: int = 0
    reaction_s: float = 0.0  # seconds the reaction worker spent computing
    vibrations: int = 0
    dropped_samples: int = 0


def handle_axis(q: tuple[float, float, float, float]) -> Vec3:
    """Unit vector along the handle (tip → top) for orientation quaternion (w, x, y, z)."""
    w, x, y, z = q
    return (2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y))


def tilt_degrees(axis: Vec3) -> tuple[float, float]:
    """(tilt_x, tilt_y) in degrees of a handle axis (PenSample's convention)."""
    ax, ay, az = axis
    az = max(az, 1e-6)
    return math.degrees(math.atan2(ax, az)), math.degrees(math.atan2(ay, az))


_LIVE: weakref.WeakSet[HapticSession] = weakref.WeakSet()


@atexit.register
def zero_all() -> None:
    """Station exit: every live session commands zero force and disables the motors."""
    for session in list(_LIVE):
        session.stop()


class ByteLink(Protocol):
    """The byte stream to the device (a :class:`~station.drivers.serial.transport.
    SerialTransport`, or a test's line)."""

    def read(self, timeout: float | None = 0.0) -> bytes:
        """What arrived, waiting up to ``timeout`` s for the first byte."""
        ...

    def write(self, data: bytes) -> None:
        """Send one frame whole."""
        ...

    def close(self) -> None:
        ...


class HapticSession:
    """One protocol session with one device; see the module docstring."""

    def __init__(self, transport: ByteLink, config: HapticConfig | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.transport = transport
        self.config = config or HapticConfig()
        self.clock = clock
        self.decoder = FrameDecoder(accept=DEVICE_TYPES, synced=False)
        self.seq = Sequencer()
        self.stats = LoopStats()
        self.hello: Hello | None = None
        self.limits: ForceLimits | None = None
        self.safety: SafetyFilter | None = None
        self.gone: TransportError | None = None
        self.pose: Pose | None = None
        self.pose_time: float | None = None
        self.state: BrushState | None = None
        self.force: Vec3 = ZERO
        self.samples: collections.deque[RawSample] = collections.deque(maxlen=8192)
        self.sample_ready = threading.Condition()
        self.tick_times = array("d")
        self._bus = FrameInterpolator()
        self._bus_time: float | None = None
        self._bus_offset: float | None = None
        self._bus_lock = threading.Lock()
        self._reaction = FrameInterpolator()
        self._reaction_time: float | None = None
        self._reaction_offset: float | None = None
        self._worker: ReactionWorker | None = None
        self._pending_vibration: Vibration | None = None
        self._bad_seen = 0
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._paused = threading.Event()
        self._stopped = False
        self._velocity: Vec3 = ZERO
        self._last_pose: Pose | None = None
        self.realtime = "off"
        self._heartbeat = 0.0
        self._sample_t = -math.inf

    # -- setup ----------------------------------------------------------------------
    def handshake(self) -> Hello:
        """Open the session: hello request until a hello comes (TransportError if none)."""
        deadline = self.clock() + self.config.handshake_timeout
        next_request = 0.0
        while self.hello is None:
            now = self.clock()
            if now >= deadline:
                raise TransportError(f"{getattr(self.transport, 'port', 'device')}: no hello "
                                     f"within {self.config.handshake_timeout:g} s (not a "
                                     "station haptic device, or it is not responding)")
            if now >= next_request:
                # The leading delimiter ends whatever partial frame the device holds.
                self.transport.write(b"\x00" + self.seq.frame(HelloRequest()))
                next_request = now + 0.2
            for _, msg in self.decoder.feed(self.transport.read(0.01)):
                if isinstance(msg, Hello):
                    self.hello = msg
                elif isinstance(msg, DeviceError):
                    self.stats.device_errors[msg.name] += 1
                    if msg.code == ERR_VERSION:
                        raise TransportError(f"device does not speak haptic protocol "
                                             f"{PROTOCOL_MAJOR}.x ({msg.text})")
        hello = self.hello
        if hello.major != PROTOCOL_MAJOR:
            raise TransportError(f"device speaks haptic protocol {hello.major}.{hello.minor}, "
                                 f"this station {PROTOCOL_MAJOR}.x")
        cfg = self.config
        self.limits = ForceLimits.from_device(hello.max_force, cfg.max_force, cfg.rate_n_per_s,
                                              cfg.watchdog_s)
        self.safety = SafetyFilter(self.limits, max_step_s=2.0 / cfg.rate_hz)
        if cfg.force:
            self._send(Force())
            self._send(Enable(True))
        return hello

    @property
    def ranges(self) -> AxisRanges:
        """The pen axes this device reports (position in 0.01 mm, tilt in 0.01°)."""
        assert self.hello is not None, "handshake first"
        wx, wy, _ = self.hello.workspace
        prox = self.config.proximity_mm
        return AxisRanges(Axis(0, round(wx * POS_RES), POS_RES), Axis(0, round(wy * POS_RES),
                                                                      POS_RES),
                          pressure=Axis(0, PRESSURE_MAX),
                          tilt_x=Axis(-9000, 9000, TILT_RES), tilt_y=Axis(-9000, 9000, TILT_RES),
                          distance=Axis(0, round(prox * POS_RES), POS_RES))

    def prepare(self) -> None:
        """Start the reaction worker (``config.reaction``) and wait until its solver
        answers (up to ``READY_TIMEOUT_S``); ``start()`` does it if not done before."""
        if self._worker is not None or self.config.reaction is None or not self.config.force:
            return
        self._worker = ReactionWorker(self, self.config.reaction, self.config.reaction_hz,
                                      self.config.reaction_process)
        self._worker.start()
        if not self._worker.ready.wait(READY_TIMEOUT_S):
            log.warning("haptic reaction: solver not ready after %g s; its force comes "
                        "when it is", READY_TIMEOUT_S)

    # -- the loop -------------------------------------------------------------------
    def start(self) -> None:
        if self.hello is None:
            self.handshake()
        _LIVE.add(self)
        self._thread = threading.Thread(target=self._run, name="haptic-loop", daemon=True)
        self._thread.start()
        self.prepare()

    def pause(self, paused: bool = True) -> None:
        """Freeze the loop without zeroing (a hung station, for the device-watchdog test)."""
        if paused:
            self._paused.set()
        else:
            self._paused.clear()

    def stop(self) -> None:
        """End the loop; zero force and motors off (best effort), then close the port."""
        if self._stopped:
            return
        self._stopped = True
        self._stop.set()
        if self._worker is not None:
            self._worker.stop()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        if self.gone is None:
            try:
                self._send(Force())
                self._send(Enable(False))
            except TransportError:
                pass
        self.force = ZERO
        self.transport.close()
        _LIVE.discard(self)
        with self.sample_ready:
            self.sample_ready.notify_all()

    def _run(self) -> None:
        period = 1.0 / self.config.rate_hz
        spin = self.config.spin_s
        clock = self.clock
        if self.config.realtime:
            try:  # Linux: pid 0 is this thread only
                os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(self.config.realtime))
                self.realtime = f"SCHED_FIFO {self.config.realtime}"
            except (OSError, AttributeError) as exc:
                self.realtime = f"refused: {exc}"
                log.warning("haptic loop: no real-time priority (%s)", exc)
        next_t = clock()
        try:
            while not self._stop.is_set():
                if self._paused.is_set():
                    time.sleep(period)
                    next_t = clock()
                    continue
                self.tick()
                next_t += period
                now = clock()
                if now > next_t + period:
                    self.stats.overruns += 1
                    next_t = now
                    time.sleep(period / 10)  # even late, never hog the CPU (under SCHED_FIFO)
                    continue
                wait = next_t - now - spin
                if wait > 0:
                    time.sleep(wait)
                while clock() < next_t:
                    pass
        except TransportError as exc:
            self.gone = exc if isinstance(exc, DeviceGone) else DeviceGone(str(exc))
            self.force = ZERO
            if self.safety is not None:
                self.safety.trip("disconnect")
            log.warning("haptic device gone: %s", exc)
        finally:
            with self.sample_ready:
                self.sample_ready.notify_all()

    def tick(self) -> None:
        """One loop iteration (public for the benchmark and single-stepped tests)."""
        now = self.clock()
        self.stats.ticks += 1
        if len(self.tick_times) >= HISTORY:
            del self.tick_times[: HISTORY // 2]
        self.tick_times.append(now)
        msgs = self.decoder.feed(self.transport.read(0))
        newest = next((m.t_us for _, m in reversed(msgs) if isinstance(m, Pose)), None)
        for _, msg in msgs:
            if isinstance(msg, Pose) and newest is not None:
                # Poses that queued up while this loop was held up keep their spacing: the
                # newest arrived now, the others the device's own time stamps earlier.
                age = ((newest - msg.t_us) & 0xFFFFFFFF) / 1e6
                self._pose(msg, now, now - age if age < BACKLOG_S else now)
            else:
                self._handle(msg, now)
        safety = self.safety
        assert safety is not None, "handshake first"
        bad = self.decoder.stats.bad_frames
        if bad != self._bad_seen:
            self._bad_seen = bad
            safety.trip("bad frame")
        if not self.config.force:
            if now - self._heartbeat >= 0.02:  # input only: the device still hears the station
                self._heartbeat = now
                self._send(Heartbeat(round(now * 1e6) & 0xFFFFFFFF))
            return
        wanted, updated = self._wanted(now)
        self.force = safety.apply(wanted, now, updated)
        self._send(Force(*self.force))
        vib = self._pending_vibration
        if vib is not None:
            self._pending_vibration = None
            self._send(vib)

    def _wanted(self, now: float) -> tuple[Vec3, float | None]:
        fx = fy = fz = 0.0
        updated: float | None = None
        contact = self.config.contact
        if contact is not None and self.state is not None:
            fx, fy, fz = contact.contact_force(self.state)
            updated = self.pose_time
        with self._bus_lock:
            bus_time = self._bus_time
            if bus_time is not None and now - bus_time <= self.config.watchdog_s:
                bx, by, bz = self._bus.sample(now)
                fx, fy, fz = fx + bx, fy + by, fz + bz
                if contact is None:
                    updated = bus_time
            elif bus_time is not None:  # the bus went quiet: its part stops
                self._bus.clear()
                self._bus_time = None
            r_time = self._reaction_time
            if r_time is not None and now - r_time <= self.config.watchdog_s:
                r = self._reaction.sample(now)
                if self.config.surface is not None and self.state is not None:
                    r = self.config.surface.apply(r, self.state)
                fx, fy, fz = fx + r[0], fy + r[1], fz + r[2]
                if contact is None:
                    # friction and grain follow the pose: both must be fresh
                    pose_t = self.pose_time if self.pose_time is not None else -math.inf
                    updated = min(r_time, pose_t) if updated is None else \
                        min(updated, r_time, pose_t)
            elif r_time is not None:  # the reaction frames stopped: their part stops
                self._reaction.clear()
                self._reaction_time = None
        return (fx, fy, fz), updated

    def _handle(self, msg: Message, now: float) -> None:
        if isinstance(msg, Pose):
            self._pose(msg, now)
        elif isinstance(msg, DeviceError):
            self.stats.device_errors[msg.name] += 1
            if self.safety is not None:
                self.safety.trip(f"device {msg.name}")
            if self.stats.device_errors[msg.name] <= 3:
                log.warning("haptic device error %s: %s", msg.name, msg.text)

    def _pose(self, pose: Pose, now: float, sample_t: float | None = None) -> None:
        """A pose arrived ``now``; ``sample_t``: when the device took it (station clock)."""
        self.stats.poses += 1
        last = self._last_pose
        if last is not None:
            dt = ((pose.t_us - last.t_us) & 0xFFFFFFFF) / 1e6
            if 0 < dt < 0.1:
                # 5 ms low-pass: finite differences of a 1 kHz pose are noisy
                a = min(1.0, dt / 0.005)
                v = ((pose.x - last.x) / dt, (pose.y - last.y) / dt, (pose.z - last.z) / dt)
                p = self._velocity
                self._velocity = (p[0] + a * (v[0] - p[0]), p[1] + a * (v[1] - p[1]),
                                  p[2] + a * (v[2] - p[2]))
        self._last_pose = pose
        self.pose, self.pose_time = pose, now
        axis = handle_axis(pose.q)
        self.state = BrushState(now, (pose.x, pose.y, pose.z - self.config.paper_z),
                                self._velocity, axis)
        if self.config.input:
            t = now if sample_t is None else sample_t
            self._sample_t = t = min(now, max(t, self._sample_t))  # never backwards
            self._sample(pose, axis, t)

    def _sample(self, pose: Pose, axis: Vec3, now: float) -> None:
        assert self.hello is not None and self.state is not None
        wx, wy, _ = self.hello.workspace
        height = pose.z - self.config.paper_z
        if self.config.pressure is not None:
            pressure = min(1.0, max(0.0, self.config.pressure(self.state)))
        else:
            fz = 0.0
            if self.config.contact is not None:
                fz = self.config.contact.contact_force(self.state)[2]
            pressure = pressure_from_force(fz, self.config.full_force)
        tx, ty = tilt_degrees(axis)
        prox_units = round(self.config.proximity_mm * POS_RES)
        raw = RawSample(
            time=now, proximity=height < self.config.proximity_mm,
            x=min(round(wx * POS_RES), max(0, round((pose.x + wx / 2) * POS_RES))),
            y=min(round(wy * POS_RES), max(0, round((pose.y + wy / 2) * POS_RES))),
            pressure=round(pressure * PRESSURE_MAX),
            tilt_x=round(tx * TILT_RES), tilt_y=round(ty * TILT_RES),
            distance=min(prox_units, max(0, round(height * POS_RES))),
            buttons=pose.buttons & 0x7)
        with self.sample_ready:
            if len(self.samples) == self.samples.maxlen:
                self.stats.dropped_samples += 1  # nobody reads: counted, never silent
            self.samples.append(raw)
            self.sample_ready.notify()

    # -- inputs from the station ----------------------------------------------------
    def submit_force(self, force: Vec3, t: float | None = None) -> None:
        """A force frame from the simulation (N, canvas frame) for time ``t`` on the loop's
        clock (default: now), interpolated between frames; its arrival feeds the watchdog."""
        now = self.clock()
        with self._bus_lock:
            self._bus.push(now if t is None else t, force, now)
            self._bus_time = now
            self.stats.bus_forces += 1

    def submit_reaction(self, force: Vec3, t: float | None = None) -> None:
        """A reaction frame of the deformable brush (N, canvas frame, no friction or
        grain) for time ``t`` on the loop's clock (default: now); the loop interpolates
        the frames, adds ``config.surface`` and its arrival feeds the watchdog."""
        now = self.clock()
        with self._bus_lock:
            self._reaction.push(now if t is None else t, force, now)
            self._reaction_time = now
            self.stats.reaction_frames += 1

    def submit_haptic(self, haptic: wire.Haptic | wire.HapticForce) -> None:
        """A ``haptic.<device>`` bus message: the brush's reaction force (``HapticForce``,
        N), a constant force along the paper normal (frequency 0: amplitude × the force
        limit, pushing the handle up), or a vibration."""
        limits = self.limits
        if limits is None:
            return
        if isinstance(haptic, wire.HapticForce):
            # placed by the simulation's time stamps, anchored at the least delayed arrival
            now = self.clock()
            lag = now - haptic.t
            if self._reaction_offset is None or lag < self._reaction_offset or \
                    lag - self._reaction_offset > 0.1:
                self._reaction_offset = lag
            self.submit_reaction((haptic.fx, haptic.fy, haptic.fz),
                                 haptic.t + self._reaction_offset)
            return
        if haptic.frequency_hz == 0.0:
            # Frames are placed by the simulation's own time stamps, anchored at the least
            # delayed arrival: the bus's delivery jitter must not become force jitter.
            now = self.clock()
            lag = now - haptic.t
            if self._bus_offset is None or lag < self._bus_offset or \
                    lag - self._bus_offset > 0.1:  # first frame, or the sim restarted its clock
                self._bus_offset = lag
            self.submit_force((0.0, 0.0, haptic.amplitude * limits.magnitude),
                              haptic.t + self._bus_offset)
            return
        self.stats.vibrations += 1
        self._pending_vibration = Vibration(haptic.amplitude * limits.magnitude,
                                            haptic.frequency_hz,
                                            min(65535, round(haptic.duration_s * 1000)))

    def _send(self, msg: Message) -> None:
        self.transport.write(self.seq.frame(msg))
        self.stats.frames_sent += 1

    # -- reading ----------------------------------------------------------------------
    def take_samples(self, timeout: float | None) -> list[RawSample]:
        """Raw pen samples since the last call (waiting up to ``timeout`` s for one)."""
        with self.sample_ready:
            if not self.samples and timeout and self.gone is None and not self._stopped:
                self.sample_ready.wait(timeout)
            out = list(self.samples)
            self.samples.clear()
        return out

    def status(self) -> dict[str, Any]:
        s, d = self.stats, self.decoder.stats
        safety = self.safety.stats if self.safety is not None else None
        return {
            "ticks": s.ticks, "overruns": s.overruns, "frames_sent": s.frames_sent,
            "poses": s.poses, "bad_frames": d.bad_frames, "bad_reasons": dict(d.bad_reasons),
            "lost_frames": d.lost, "device_errors": dict(s.device_errors),
            "bus_forces": s.bus_forces, "vibrations": s.vibrations,
            "reaction_frames": s.reaction_frames,
            "reaction_ms": round(1e3 * s.reaction_s / max(1, s.reaction_frames), 3)
            if self._worker is not None else None,
            "dropped_samples": s.dropped_samples,
            "force_n": [round(f, 4) for f in self.force],
            "watchdog_trips": safety.watchdog_trips if safety else 0,
            "zeroed": safety.zeroed if safety else 0,
            "clamped": safety.clamped if safety else 0,
            "rate_limited": safety.rate_limited if safety else 0,
            "trips": dict(safety.trips) if safety else {},
            "realtime": self.realtime,
        }
