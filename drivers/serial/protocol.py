"""The serial haptic protocol, version 1.0 (docs/haptic-protocol.md): pure encoders and decoders.

Nothing here touches a port.  A frame on the wire is ``COBS(body) + 0x00``;
``body`` is a 4-byte header (version, type, sequence number), the payload,
and a CRC-16/CCITT-FALSE of header + payload (big-endian).  All payload
integers and floats are little-endian; forces are newtons, torques newton
metres, positions millimetres, times microseconds.

    decoder = FrameDecoder()
    for seq, message in decoder.feed(chunk):   # bad frames are counted, never raised
        ...
    port.write(encode_frame(Force(0.0, 0.0, 1.2), seq))
"""

from __future__ import annotations

import binascii
import math
import struct
from collections import Counter
from dataclasses import dataclass, field
from typing import ClassVar

from station.errors import BadInput

PROTOCOL_MAJOR = 1
PROTOCOL_MINOR = 0
DELIMITER = 0x00
HEADER = struct.Struct("<BBH")  # version, type, sequence number
CRC_SIZE = 2
MAX_BODY = 128
"""Largest header + payload + CRC; a longer frame is a framing error (lost delimiter)."""
MAX_ENCODED = MAX_BODY + MAX_BODY // 254 + 2


class ProtocolError(BadInput):
    """A frame that is not protocol v1 (bad COBS, CRC, length, type or value)."""


# -- COBS ---------------------------------------------------------------------------
# Written here rather than taken from the `cobs` package: that one is a C
# extension (an sdist on some platforms, and newcomers have no compiler), and
# the whole algorithm is the two short functions below, readable beside the spec.
def cobs_encode(data: bytes) -> bytes:
    """Consistent Overhead Byte Stuffing: ``data`` without any zero byte (+1 byte per 254)."""
    out = bytearray()
    block = bytearray()
    for byte in data:
        if byte == 0:
            out.append(len(block) + 1)
            out += block
            block.clear()
            continue
        block.append(byte)
        if len(block) == 254:
            out.append(255)
            out += block
            block.clear()
    out.append(len(block) + 1)
    out += block
    return bytes(out)


def cobs_decode(data: bytes) -> bytes:
    """Inverse of :func:`cobs_encode`; :class:`ProtocolError` for anything it cannot produce."""
    out = bytearray()
    i, n = 0, len(data)
    while i < n:
        code = data[i]
        if code == 0:
            raise ProtocolError("zero byte inside a COBS frame")
        end = i + code
        if end > n:
            raise ProtocolError(f"COBS block of {code - 1} bytes runs past the frame end")
        block = data[i + 1 : end]
        if 0 in block:
            raise ProtocolError("zero byte inside a COBS frame")
        out += block
        i = end
        if code != 255 and i < n:
            out.append(0)
    return bytes(out)


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF; check value 0x29B1 for ``b"123456789"``)."""
    return binascii.crc_hqx(data, 0xFFFF)


# -- messages -----------------------------------------------------------------------
def _finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)


def _text(data: bytes, at: int, limit: int, what: str) -> tuple[str, int]:
    if at >= len(data):
        raise ProtocolError(f"{what} length missing")
    n = data[at]
    if n > limit or at + 1 + n > len(data):
        raise ProtocolError(f"{what} of {n} bytes does not fit")
    try:
        return data[at + 1 : at + 1 + n].decode("utf-8"), at + 1 + n
    except UnicodeDecodeError:
        raise ProtocolError(f"{what} is not UTF-8") from None


def _pack_text(text: str, limit: int) -> bytes:
    raw = text.encode("utf-8")[:limit]
    return bytes([len(raw)]) + raw


@dataclass(frozen=True, slots=True)
class Hello:
    """Device → station, answering :class:`HelloRequest`: who the device is and what it can do.

    Attributes:
        major, minor: protocol version the device speaks.
        vid, pid: USB ids (0 where the device has none).
        rate_hz: pose update rate the device sends, Hz (1..10000).
        buttons: number of buttons (bits of :attr:`Pose.buttons`).
        rot_axes: orientation axes the device senses (0..3; 0 = the pose's
            quaternion is always the identity).
        force_axes: 3 (force) or 6 (force and torque).
        max_force: largest force per axis the device can render, N (x, y, z).
        max_torque: largest torque per axis, N·m (0 for a 3-axis device).
        workspace: reach in mm along x, y, z, centred on the device origin in
            x and y, z from 0 (the table plane) up.
        serial: device serial number (≤ 32 bytes UTF-8).
        name: product name (≤ 48 bytes UTF-8).
    """

    TYPE: ClassVar[int] = 0x01
    _S: ClassVar[struct.Struct] = struct.Struct("<BBHHHBBBB7f")

    major: int
    minor: int
    vid: int
    pid: int
    rate_hz: int
    buttons: int
    rot_axes: int
    force_axes: int
    max_force: tuple[float, float, float]
    max_torque: float
    workspace: tuple[float, float, float]
    serial: str = ""
    name: str = ""

    def payload(self) -> bytes:
        return self._S.pack(self.major, self.minor, self.vid, self.pid, self.rate_hz,
                            self.buttons, self.rot_axes, self.force_axes, 0,
                            *self.max_force, self.max_torque,
                            *self.workspace) + _pack_text(self.serial, 32) + _pack_text(
            self.name, 48)

    @classmethod
    def parse(cls, data: bytes) -> Hello:
        if len(data) < cls._S.size:
            raise ProtocolError(f"hello payload of {len(data)} bytes, need {cls._S.size}+")
        (major, minor, vid, pid, rate, buttons, rot, faxes, _reserved,
         fx, fy, fz, tq, wx, wy, wz) = cls._S.unpack_from(data)  # fmt: skip
        serial, at = _text(data, cls._S.size, 32, "serial")
        name, at = _text(data, at, 48, "name")
        if at != len(data):
            raise ProtocolError(f"{len(data) - at} stray bytes after hello")
        if not 1 <= rate <= 10000 or rot > 3 or faxes not in (3, 6) or buttons > 16:
            raise ProtocolError(f"hello out of range (rate {rate}, rot axes {rot}, "
                                f"force axes {faxes}, buttons {buttons})")
        if not _finite(fx, fy, fz, tq, wx, wy, wz) or min(fx, fy, fz, tq) < 0 \
                or max(fx, fy, fz) > 100 or min(wx, wy, wz) <= 0:
            raise ProtocolError("hello limits or workspace not finite and positive")
        return cls(major, minor, vid, pid, rate, buttons, rot, faxes, (fx, fy, fz), tq,
                   (wx, wy, wz), serial, name)


@dataclass(frozen=True, slots=True)
class Pose:
    """Device → station at up to 1 kHz: where the handle tip is and how it is held.

    Attributes:
        t_us: device clock, µs (u32, wraps after ~71 min).
        x, y, z: handle tip position, mm; x right, y toward the user, z up
            from the table plane.
        q: orientation as a unit quaternion (w, x, y, z); identity = handle upright.
        buttons: bit set of pressed buttons.
        flags: :data:`POSE_ENABLED`, :data:`POSE_WATCHDOG`, :data:`POSE_CLAMPED`.
    """

    TYPE: ClassVar[int] = 0x02
    _S: ClassVar[struct.Struct] = struct.Struct("<I7fHB")

    t_us: int
    x: float
    y: float
    z: float
    q: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    buttons: int = 0
    flags: int = 0

    def payload(self) -> bytes:
        return self._S.pack(self.t_us, self.x, self.y, self.z, *self.q, self.buttons, self.flags)

    @classmethod
    def parse(cls, data: bytes) -> Pose:
        if len(data) != cls._S.size:
            raise ProtocolError(f"pose payload of {len(data)} bytes, need {cls._S.size}")
        t, x, y, z, qw, qx, qy, qz, buttons, flags = cls._S.unpack(data)
        if not _finite(x, y, z, qw, qx, qy, qz) or max(abs(x), abs(y), abs(z)) > 1e4:
            raise ProtocolError("pose position not finite or beyond 10 m")
        norm = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
        if not 0.9 < norm < 1.1:
            raise ProtocolError(f"pose orientation is not a unit quaternion (|q| = {norm:.3g})")
        if flags & ~0x07:
            raise ProtocolError(f"unknown pose flags {flags:#x}")
        return cls(t, x, y, z, (qw / norm, qx / norm, qy / norm, qz / norm), buttons, flags)


POSE_ENABLED, POSE_WATCHDOG, POSE_CLAMPED = 0x01, 0x02, 0x04

# Device error codes (DeviceError.code).
ERR_BAD_FRAME, ERR_WATCHDOG, ERR_OVER_LIMIT, ERR_VERSION, ERR_NOT_ENABLED, ERR_FAULT = range(1, 7)
ERROR_NAMES = {ERR_BAD_FRAME: "bad-frame", ERR_WATCHDOG: "watchdog",
               ERR_OVER_LIMIT: "over-limit", ERR_VERSION: "version",
               ERR_NOT_ENABLED: "not-enabled", ERR_FAULT: "fault"}  # fmt: skip


@dataclass(frozen=True, slots=True)
class DeviceError:
    """Device → station: something went wrong on the device (code + ≤ 64 bytes of text)."""

    TYPE: ClassVar[int] = 0x03

    code: int
    text: str = ""

    @property
    def name(self) -> str:
        return ERROR_NAMES.get(self.code, f"error-{self.code}")

    def payload(self) -> bytes:
        return bytes([self.code]) + _pack_text(self.text, 64)

    @classmethod
    def parse(cls, data: bytes) -> DeviceError:
        if not data:
            raise ProtocolError("error payload without a code")
        text, at = _text(data, 1, 64, "error text")
        if at != len(data):
            raise ProtocolError("stray bytes after error text")
        return cls(data[0], text)


@dataclass(frozen=True, slots=True)
class HelloRequest:
    """Station → device: open a session; the device answers :class:`Hello`."""

    TYPE: ClassVar[int] = 0x81
    _S: ClassVar[struct.Struct] = struct.Struct("<BB")

    major: int = PROTOCOL_MAJOR
    minor: int = PROTOCOL_MINOR

    def payload(self) -> bytes:
        return self._S.pack(self.major, self.minor)

    @classmethod
    def parse(cls, data: bytes) -> HelloRequest:
        if len(data) != cls._S.size:
            raise ProtocolError(f"hello request of {len(data)} bytes, need {cls._S.size}")
        return cls(*cls._S.unpack(data))


@dataclass(frozen=True, slots=True)
class Force:
    """Station → device: the force (N) and torque (N·m) to render from now on."""

    TYPE: ClassVar[int] = 0x82
    _S: ClassVar[struct.Struct] = struct.Struct("<6f")

    fx: float = 0.0
    fy: float = 0.0
    fz: float = 0.0
    tx: float = 0.0
    ty: float = 0.0
    tz: float = 0.0

    @property
    def vector(self) -> tuple[float, float, float]:
        return (self.fx, self.fy, self.fz)

    @property
    def magnitude(self) -> float:
        return math.sqrt(self.fx * self.fx + self.fy * self.fy + self.fz * self.fz)

    def payload(self) -> bytes:
        return self._S.pack(self.fx, self.fy, self.fz, self.tx, self.ty, self.tz)

    @classmethod
    def parse(cls, data: bytes) -> Force:
        if len(data) != cls._S.size:
            raise ProtocolError(f"force payload of {len(data)} bytes, need {cls._S.size}")
        values = cls._S.unpack(data)
        if not _finite(*values):
            raise ProtocolError("force not finite")
        return cls(*values)


@dataclass(frozen=True, slots=True)
class Vibration:
    """Station → device: a vibration along the handle axis (amplitude N, Hz, ms)."""

    TYPE: ClassVar[int] = 0x83
    _S: ClassVar[struct.Struct] = struct.Struct("<ffH")

    amplitude: float = 0.0
    frequency_hz: float = 0.0
    duration_ms: int = 0

    def payload(self) -> bytes:
        return self._S.pack(self.amplitude, self.frequency_hz, self.duration_ms)

    @classmethod
    def parse(cls, data: bytes) -> Vibration:
        if len(data) != cls._S.size:
            raise ProtocolError(f"vibration payload of {len(data)} bytes, need {cls._S.size}")
        a, f, d = cls._S.unpack(data)
        if not _finite(a, f) or a < 0 or not 0 <= f <= 10000:
            raise ProtocolError("vibration amplitude/frequency out of range")
        return cls(a, f, d)


@dataclass(frozen=True, slots=True)
class Enable:
    """Station → device: motors on (1) or off (0); a device starts disabled."""

    TYPE: ClassVar[int] = 0x84

    on: bool

    def payload(self) -> bytes:
        return bytes([1 if self.on else 0])

    @classmethod
    def parse(cls, data: bytes) -> Enable:
        if len(data) != 1 or data[0] > 1:
            raise ProtocolError("enable payload must be one byte 0 or 1")
        return cls(bool(data[0]))


@dataclass(frozen=True, slots=True)
class Heartbeat:
    """Station → device: "still here" (station clock, µs); resets the device watchdog."""

    TYPE: ClassVar[int] = 0x85
    _S: ClassVar[struct.Struct] = struct.Struct("<I")

    t_us: int = 0

    def payload(self) -> bytes:
        return self._S.pack(self.t_us & 0xFFFFFFFF)

    @classmethod
    def parse(cls, data: bytes) -> Heartbeat:
        if len(data) != cls._S.size:
            raise ProtocolError(f"heartbeat payload of {len(data)} bytes, need {cls._S.size}")
        return cls(*cls._S.unpack(data))


Message = Hello | Pose | DeviceError | HelloRequest | Force | Vibration | Enable | Heartbeat
MESSAGE_TYPES: dict[int, type[Message]] = {
    m.TYPE: m for m in (Hello, Pose, DeviceError, HelloRequest, Force, Vibration, Enable, Heartbeat)
}
DEVICE_TYPES = frozenset({Hello.TYPE, Pose.TYPE, DeviceError.TYPE})
STATION_TYPES = frozenset({HelloRequest.TYPE, Force.TYPE, Vibration.TYPE, Enable.TYPE,
                           Heartbeat.TYPE})


# -- frames -------------------------------------------------------------------------
def encode_frame(message: Message, seq: int) -> bytes:
    """One complete frame on the wire (COBS-stuffed, with its trailing delimiter)."""
    body = HEADER.pack(PROTOCOL_MAJOR, message.TYPE, seq & 0xFFFF) + message.payload()
    body += crc16(body).to_bytes(2, "big")
    if len(body) > MAX_BODY:
        raise ProtocolError(f"{type(message).__name__} frame of {len(body)} bytes exceeds "
                            f"{MAX_BODY}")
    return cobs_encode(body) + b"\x00"


def decode_body(encoded: bytes, accept: frozenset[int] | None = None) -> tuple[int, Message]:
    """(seq, message) of one frame without its delimiter; :class:`ProtocolError` if it is bad.

    ``accept`` limits the message types (a station accepts only device types).
    """
    if len(encoded) > MAX_ENCODED:
        raise ProtocolError(f"frame of {len(encoded)} bytes is too long")
    body = cobs_decode(encoded)
    if len(body) < HEADER.size + CRC_SIZE:
        raise ProtocolError(f"frame of {len(body)} bytes is shorter than header + CRC")
    if crc16(body[:-CRC_SIZE]) != int.from_bytes(body[-CRC_SIZE:], "big"):
        raise ProtocolError("CRC mismatch")
    version, kind, seq = HEADER.unpack_from(body)
    if version != PROTOCOL_MAJOR:
        raise ProtocolError(f"protocol version {version} (this station speaks {PROTOCOL_MAJOR})")
    cls = MESSAGE_TYPES.get(kind)
    if cls is None or (accept is not None and kind not in accept):
        raise ProtocolError(f"unexpected message type {kind:#04x}")
    return seq, cls.parse(body[HEADER.size : -CRC_SIZE])


@dataclass
class DecoderStats:
    """Counts of a :class:`FrameDecoder`: frames decoded, bad frames (by reason), lost ones."""

    frames: int = 0
    bad_frames: int = 0
    bad_reasons: Counter[str] = field(default_factory=Counter)
    lost: int = 0
    """Frames missing from the sequence (gaps in the sender's sequence numbers)."""
    bytes: int = 0
    last_error: str = ""


class FrameDecoder:
    """Splits a byte stream at delimiters and decodes each frame.

    A bad frame (COBS, CRC, length, version, type or value) is counted in
    :attr:`stats` and dropped, never raised; the stream resynchronises at the
    next zero byte.  With ``synced=False`` (a port opened mid-stream) the
    bytes before the first delimiter are a frame only if they decode; if not
    they are the tail of one sent before the port was opened and are dropped
    without being counted as bad.
    """

    def __init__(self, accept: frozenset[int] | None = None, synced: bool = True) -> None:
        self.accept = accept
        self.stats = DecoderStats()
        self._buf = bytearray()
        self._synced = synced
        self._overflow = False
        self._next_seq: int | None = None

    def feed(self, data: bytes) -> list[tuple[int, Message]]:
        out: list[tuple[int, Message]] = []
        self.stats.bytes += len(data)
        start = 0
        while True:
            end = data.find(b"\x00", start)
            if end < 0:
                self._append(data[start:])
                return out
            self._append(data[start:end])
            frame, overflow = bytes(self._buf), self._overflow
            self._buf.clear()
            self._overflow = False
            start = end + 1
            if not frame and not overflow:
                continue  # back-to-back delimiters: an idle line, not a frame
            if overflow:
                if self._synced:
                    self._bad("frame too long")
                self._synced = True
                continue
            try:
                seq, message = decode_body(frame, self.accept)
            except ProtocolError as exc:
                if self._synced:
                    self._bad(str(exc))
                self._synced = True  # before the first delimiter: a partial frame, not bad
                continue
            self._synced = True
            self._count(seq)
            out.append((seq, message))

    def _append(self, chunk: bytes) -> None:
        if self._overflow:
            return
        self._buf += chunk
        if len(self._buf) > MAX_ENCODED:
            self._buf.clear()
            self._overflow = True

    def _bad(self, reason: str) -> None:
        self.stats.bad_frames += 1
        key = reason.split("(")[0].split(" of ")[0].strip()[:40]
        self.stats.bad_reasons[key] += 1
        self.stats.last_error = reason

    def _count(self, seq: int) -> None:
        self.stats.frames += 1
        if self._next_seq is not None and seq != self._next_seq:
            self.stats.lost += (seq - self._next_seq) & 0xFFFF
        self._next_seq = (seq + 1) & 0xFFFF


class Sequencer:
    """The sender's u16 sequence numbers."""

    def __init__(self) -> None:
        self._seq = 0

    def next(self) -> int:
        seq = self._seq
        self._seq = (self._seq + 1) & 0xFFFF
        return seq

    def frame(self, message: Message) -> bytes:
        return encode_frame(message, self.next())
