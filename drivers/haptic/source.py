"""A haptic device as a pen source of the driver pipeline (``serial:`` and ``serial-mock:`` SPECs).

``serial:/dev/ttyACM0``, ``serial:usb:VID:PID[:SERIAL]`` (the udev symlink,
else pyserial's enumeration) or ``serial-mock:NAME?script=…`` open a
:class:`HapticSession` and run its 1 kHz loop; :class:`HapticPenSource`
hands the loop's raw pen samples to :class:`~station.drivers.pipeline.PenDriver`
like any tablet, so ``station driver`` publishes them, reconnects, counts
bad frames and reports status unchanged.  :meth:`HapticPenSource.attach_bus`
subscribes to ``haptic.<device>`` for forces and vibrations from the station.

Options (both schemes): ``input=0`` (forces only, no pen samples),
``force=0`` (input only, motors off), ``max_force`` (N, a limit below the
device's), ``rate`` (loop Hz), ``slew`` (N/s), ``stiffness`` (N/mm), ``hair``
(mm), ``friction``, ``grain``, ``full_force`` (N that is full pressure),
``paper_z`` (mm), ``baud``, ``rt`` (SCHED_FIFO priority of the loop thread,
0 = off), ``spin_us`` (busy-wait before each deadline).  ``serial-mock:`` adds the mock's options
(:mod:`station.drivers.mock.haptic`).
"""

from __future__ import annotations

import atexit
import logging
import os
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any

from station.drivers.devicedata import SourceInfo
from station.drivers.haptic.contact import BrushState, RoundBrushContact, Surface
from station.drivers.haptic.loop import HapticConfig, HapticSession, zero_all
from station.drivers.mock.haptic import SCRIPTS, MockHapticDevice, default_hello
from station.drivers.raw import AxisRanges, RawSample
from station.drivers.serial.transport import (
    DEFAULT_BAUD,
    SerialTransport,
    UsbSerialId,
    find_usb_port,
)
from station.drivers.transport.base import (
    DeviceGone,
    DeviceSpecError,
    EndOfStream,
    TransportError,
)

from station.brush.geometry import BrushShapeError, get_shape
from station.bus import Subscriber

if TYPE_CHECKING:
    from station.drivers.pipeline.spec import DeviceSpec

log = logging.getLogger(__name__)

COMMON_OPTIONS = {"input", "force", "max_force", "rate", "slew", "stiffness", "hair", "friction",
                  "grain", "full_force", "paper_z", "baud", "rt", "spin_us", "contact", "shape",
                  "tuft", "press_depth", "reaction_rate"}
CONTACTS = ("round", "deformable", "bus")
"""``contact=``: the round brush's spring in the loop (the default); the deformable
brush solved in the driver at ``reaction_rate``; or the deformable brush's reaction
from ``station sim`` over ``haptic.<device>`` (the sim holds the painting brush)."""
MOCK_OPTIONS = {"script", "limit", "corrupt", "seed", "unplug", "replug", "tilt", "pose_rate"}

# The mock devices of this process by SPEC: a reconnecting driver reopens the
# same device (that came back on its symlink), as it would a real one.
_MOCKS: dict[str, MockHapticDevice] = {}
_MOCKS_LOCK = threading.Lock()


@atexit.register
def _stop_mocks() -> None:
    zero_all()  # the sessions first: they still talk to their (mock) devices
    for spec_text in list(_MOCKS):
        forget_mock(spec_text)


def haptic_config(spec: DeviceSpec) -> HapticConfig:
    """The session configuration a SPEC's options describe (DeviceSpecError when malformed)."""
    allowed = COMMON_OPTIONS | (MOCK_OPTIONS if spec.scheme == "serial-mock" else set())
    unknown = sorted(set(spec.options) - allowed)
    if unknown:
        raise DeviceSpecError(f"unknown option {unknown[0]!r} for {spec.scheme}: (one of "
                              f"{', '.join(sorted(allowed))})", "--device")
    for flag in ("input", "force"):
        if spec.options.get(flag, "1").lower() not in ("0", "1", "true", "false", "yes", "no",
                                                       "on", "off"):
            raise DeviceSpecError(f"{flag}={spec.options[flag]!r} must be 0 or 1", "--device")
    on = {k: spec.options.get(k, "1").lower() in ("1", "true", "yes", "on")
          for k in ("input", "force")}
    if not on["input"] and not on["force"]:
        raise DeviceSpecError("input=0 and force=0 leave the device nothing to do", "--device")
    friction = spec.number("friction", 0.15, 0.0, 1.0)
    grain = spec.number("grain", 0.05, 0.0, 0.5)
    kind = spec.options.get("contact", "round")
    if kind not in CONTACTS:
        raise DeviceSpecError(f"contact={kind!r}: one of {', '.join(CONTACTS)}", "--device")
    extra: dict[str, Any] = {}
    if kind == "round":
        for opt in ("shape", "tuft", "press_depth", "reaction_rate"):
            if opt in spec.options:
                raise DeviceSpecError(f"{opt}= is for contact=deformable or contact=bus",
                                      "--device")
        contact: RoundBrushContact | None = RoundBrushContact(
            hair_mm=spec.number("hair", 6.0, 0.5, 50.0),
            stiffness=spec.number("stiffness", 0.5, 0.01, 5.0),
            friction=friction, grain=grain)
    else:
        # the spine solver (numba, NLopt) only for a deformable brush: a round one starts fast
        from station.drivers.haptic.deformable import DeformableBrushContact, height_pressure

        for opt in ("hair", "stiffness"):
            if opt in spec.options:
                raise DeviceSpecError(f"{opt}= is for contact=round (the deformable brush's "
                                      "tuft is tuft= and shape=)", "--device")
        try:
            shape = get_shape(spec.options.get("shape", "round3d"))
        except BrushShapeError as exc:
            raise DeviceSpecError(f"shape=: {exc}", "--device") from None
        tuft = spec.number("tuft", 6.0, 0.5, 50.0)
        depth = spec.number("press_depth", shape.press_depth, 0.05, 0.97)
        surface = Surface(friction=friction, grain=grain)
        contact = None

        def pressure(state: BrushState) -> float:
            return height_pressure(state.position[2], tuft, depth)

        extra = {"surface": surface, "pressure": pressure}
        if kind == "deformable":
            extra["reaction"] = DeformableBrushContact(shape=shape, tuft_mm=tuft,
                                                       surface=surface)
            extra["reaction_hz"] = spec.number("reaction_rate", 40.0, 5.0, 500.0)
        elif "reaction_rate" in spec.options:
            raise DeviceSpecError("reaction_rate= is for contact=deformable (with contact=bus "
                                  "the sim's rate sets it)", "--device")
    max_force = spec.options.get("max_force")
    return HapticConfig(
        rate_hz=spec.number("rate", 1000.0, 50.0, 4000.0),
        force=on["force"], input=on["input"],
        max_force=spec.number("max_force", 0.0, 0.05, 50.0) if max_force is not None else None,
        rate_n_per_s=spec.number("slew", 200.0, 1.0, 10000.0),
        contact=contact,
        full_force=spec.number("full_force", 2.0, 0.05, 50.0),
        paper_z=spec.number("paper_z", 0.0, -500.0, 500.0),
        realtime=round(spec.number("rt", 0, 0, 99)),
        spin_s=spec.number("spin_us", 0.0, 0.0, 1000.0) / 1e6, **extra)


def mock_device(spec: DeviceSpec) -> MockHapticDevice:
    """The mock device of a ``serial-mock:`` SPEC (created and started on first use)."""
    with _MOCKS_LOCK:
        mock = _MOCKS.get(spec.text)
        if mock is not None:
            return mock
        script = spec.options.get("script", "stroke")
        if script not in SCRIPTS:
            raise DeviceSpecError(f"no mock haptic script {script!r} (one of "
                                  f"{', '.join(SCRIPTS)})", "--device")
        unplug = spec.options.get("unplug")
        replug = spec.number("replug", 0.3, -1.0, 60.0)
        hello = default_hello(spec.number("limit", 3.3, 0.1, 50.0),
                              round(spec.number("pose_rate", 1000.0, 50.0, 4000.0)))
        mock = MockHapticDevice(script, hello, corrupt=spec.number("corrupt", 0.0, 0.0, 1.0),
                                seed=int(spec.number("seed", 0, 0, 2**31)),
                                unplug_at=spec.number("unplug", 0.0, 0.0, 3600.0)
                                if unplug is not None else None,
                                replug_after=replug if replug >= 0 else None,
                                tilt_deg=spec.number("tilt", 0.0, -60.0, 60.0)).start()
        _MOCKS[spec.text] = mock
        return mock


def forget_mock(spec_text: str) -> None:
    """Stop and drop the mock device of a SPEC (tests; the driver's end)."""
    with _MOCKS_LOCK:
        mock = _MOCKS.pop(spec_text, None)
    if mock is not None:
        mock.stop()


def open_haptic(spec: DeviceSpec, name: str | None = None) -> HapticPenSource:
    """Open the device a ``serial:``/``serial-mock:`` SPEC names and start its loop."""
    config = haptic_config(spec)
    baud = round(spec.number("baud", DEFAULT_BAUD, 1200, 12_000_000))
    mock = None
    if spec.scheme == "serial-mock":
        mock = mock_device(spec)
        if mock.finished:
            raise EndOfStream(f"{spec.text}: the mock's script has ended")
        port = mock.path
    elif spec.target.startswith("usb:"):
        port = find_usb_port(UsbSerialId.parse(spec.target[len("usb:"):]))
    else:
        port = spec.target
    if not os.path.exists(port):
        raise TransportError(f"{port}: no such serial device (unplugged?)")
    transport = SerialTransport(port, baudrate=baud)
    session = HapticSession(transport, config)
    try:
        session.prepare()  # the deformable brush's solver loads before the hand is there
        session.handshake()
        session.start()
    except BaseException:
        session.stop()
        raise
    return HapticPenSource(session, spec, name=name, mock=mock)


class HapticPenSource:
    """The pipeline's view of a haptic session (a :class:`PenSource`)."""

    def __init__(self, session: HapticSession, spec: DeviceSpec, name: str | None = None,
                 mock: MockHapticDevice | None = None) -> None:
        self.session = session
        self.spec = spec
        hello = session.hello
        assert hello is not None
        self.hello = hello
        self.name = name or "haptic-" + (hello.serial.lower() or "0")[:40]
        self.ranges: AxisRanges = session.ranges
        self.finite = mock is not None and mock.duration is not None
        self.mock = mock
        self.stats = _Stats(session)
        self._bus_thread: threading.Thread | None = None
        self._bus_stop = threading.Event()

    def read_raw(self, timeout: float | None) -> list[RawSample]:
        samples = self.session.take_samples(timeout)
        if not samples and self.session.gone is not None:
            if self.mock is not None and self.mock.finished:
                raise EndOfStream(f"{self.spec.text}: the mock's script has ended")
            raise DeviceGone(str(self.session.gone))
        return samples

    def now(self) -> float:
        return self.session.clock()

    def describe(self) -> SourceInfo:
        h = self.hello
        port = getattr(self.session.transport, "port", "")  # a test's byte line has none
        return {
            "name": self.name, "source": "serial", "path": port,
            "product": h.name, "vid": h.vid, "pid": h.pid, "usb_id": f"{h.vid:04x}:{h.pid:04x}",
            "serial": h.serial, "bus": 3, "parser": "haptic-serial", "generic": False,
            "model": "", "can_map_mm": True,
            "protocol": f"{h.major}.{h.minor}", "rate_hz": h.rate_hz,
            "max_force_n": list(h.max_force),
            "limits_n": list(self.session.limits.axis) if self.session.limits else None,
            "haptic": self.session.status(),
        }

    def attach_bus(self, endpoint: str | list[str] | None, keys: Path | None = None,
                   client_key: str | None = None) -> None:
        """Subscribe to ``haptic.<name>`` at ``endpoint`` (or several): forces and
        vibrations from the station (``keys``, ``client_key``: CURVE on tcp, as the
        driver's own bus)."""
        sub = Subscriber(endpoint, topics=(f"haptic.{self.name}",), keys=keys,
                         client_key=client_key)

        def listen() -> None:
            try:
                while not self._bus_stop.is_set():
                    msg = sub.recv(timeout_ms=50)
                    if msg is not None and msg.kind == "haptic":
                        self.session.submit_haptic(msg.value)
            finally:
                sub.close()

        self._bus_thread = threading.Thread(target=listen, name="haptic-bus", daemon=True)
        self._bus_thread.start()

    def close(self) -> None:
        self._bus_stop.set()
        if self._bus_thread is not None:
            self._bus_thread.join(timeout=1.0)
        self.session.stop()


class _Stats:
    """Frame counts in the shape of the pipeline's SourceStats."""

    def __init__(self, session: HapticSession) -> None:
        self._s = session

    @property
    def reports(self) -> int:
        return self._s.decoder.stats.frames

    @property
    def bad_reports(self) -> int:
        return self._s.decoder.stats.bad_frames

    @property
    def bad_reasons(self) -> dict[str, int]:
        return dict(self._s.decoder.stats.bad_reasons)
