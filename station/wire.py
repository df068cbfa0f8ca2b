"""The bus wire format, version 1 (documented in docs/wire-format.md).

A bus message is two ZeroMQ frames: the topic (UTF-8, e.g. ``pen.mock-0``)
and a payload that starts with a 20-byte header::

    offset size  field
    0      2     magic  b"ST"
    2      1     version (1)
    3      1     kind: 1 pen, 2 cmd, 3 status, 4 haptic, 5 pen batch, 6 heartbeat,
                 7 haptic force
    4      1     flags: bit 0 = replayed (sent again for a late joiner)
    5      3     reserved, zero
    8      4     publisher id (u32, random per publisher instance)
    12     8     sequence number (u64, per publisher and topic, contiguous)

All integers little-endian.  The pen body is a fixed 104-byte struct (see
``_PEN``); a pen batch is a u16 count followed by that many pen bodies, the
header's sequence number being the first one's (the batch takes ``count``
consecutive numbers); cmd and status bodies are UTF-8 JSON objects; the haptic
and heartbeat bodies are fixed structs.  Heartbeats (kind 6, topic
``hb.<device>``) were added compatibly: a version-1 subscriber of ``pen.``/``cmd``
never receives them (ZeroMQ filters topics at the publisher).  Decoding
validates everything: a message that is not exactly this raises
:class:`WireError` and the subscriber counts and drops it.
"""

from __future__ import annotations

import json
import math
import struct
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, NoReturn

from station.errors import EventError, WireError
from station.events import TOOL_CODES, Command, PenSample

MAGIC = b"ST"
VERSION = 1
KIND_PEN, KIND_CMD, KIND_STATUS, KIND_HAPTIC, KIND_PEN_BATCH = 1, 2, 3, 4, 5
KIND_HEARTBEAT = 6
KIND_HAPTIC_FORCE = 7
KIND_NAMES = {KIND_PEN: "pen", KIND_CMD: "cmd", KIND_STATUS: "status", KIND_HAPTIC: "haptic",
              KIND_PEN_BATCH: "pen", KIND_HEARTBEAT: "heartbeat", KIND_HAPTIC_FORCE: "haptic"}
MAX_HAPTIC_FORCE = 1000.0  # N: far beyond any device; the driver clamps to its own limits
MAX_HEARTBEAT_INTERVAL = 60.0
MAX_BATCH = 512  # samples per batch message (53 KiB)
FLAG_REPLAY = 0x01
MAX_JSON_BODY = 64 * 1024

_HEADER = struct.Struct("<2sBBB3xIQ")
HEADER_SIZE = _HEADER.size  # 20

# t, t_mono, tool, flags, buttons, tool_id, serial, seq,
# x, y, pressure, tilt_x, tilt_y, rotation, distance, wheel
_PEN = struct.Struct("<ddBBHIQQdddddddd")
PEN_SIZE = _PEN.size  # 104

_PF_PROXIMITY, _PF_TOUCHING, _PF_SERIAL, _PF_TOOL_ID = 1, 2, 4, 8
_PF_ROTATION, _PF_DISTANCE, _PF_WHEEL = 16, 32, 64
_TOOL_INDEX = {tool: i for i, tool in enumerate(TOOL_CODES)}

_HAPTIC = struct.Struct("<dddd")
_HEARTBEAT = struct.Struct("<dQ")  # interval_s, last sequence number sent on pen.<device>
_HAPTIC_FORCE = struct.Struct("<dddd")  # t, fx, fy, fz


@dataclass(frozen=True, slots=True)
class Haptic:
    """A force/vibration request for a haptic device (the back-channel).

    Attributes:
        t: seconds since the session start.
        amplitude: vibration or force amplitude in ``[0, 1]`` of the device maximum.
        frequency_hz: vibration frequency in Hz (0 = constant force), ``[0, 10000]``.
        duration_s: seconds the request lasts, ``[0, 60]``.
    """

    t: float
    amplitude: float
    frequency_hz: float = 0.0
    duration_s: float = 0.0

    def __post_init__(self) -> None:
        for name, lo, hi in (
            ("t", 0.0, 1e12),
            ("amplitude", 0.0, 1.0),
            ("frequency_hz", 0.0, 1e4),
            ("duration_s", 0.0, 60.0),
        ):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or math.isnan(v) or not lo <= v <= hi:
                raise EventError(f"haptic {name}={v!r} outside [{lo}, {hi}]")


@dataclass(frozen=True, slots=True)
class HapticForce:
    """The canvas's reaction on the brush, for a haptic device (kind 7, ``haptic.<device>``).

    Added to version 1 compatibly (docs/wire-format.md).  The driver adds friction
    and paper grain at its own rate and passes the sum through its safety layer.

    Attributes:
        t: seconds on the publisher's clock when the force held (frames are
            interpolated by these stamps).
        fx, fy, fz: N in the canvas frame (x right, y toward the user, z up from
            the paper), each within ``±MAX_HAPTIC_FORCE``.
    """

    t: float
    fx: float
    fy: float
    fz: float

    def __post_init__(self) -> None:
        for name, lo, hi in (("t", 0.0, 1e12), ("fx", -MAX_HAPTIC_FORCE, MAX_HAPTIC_FORCE),
                             ("fy", -MAX_HAPTIC_FORCE, MAX_HAPTIC_FORCE),
                             ("fz", -MAX_HAPTIC_FORCE, MAX_HAPTIC_FORCE)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v) \
                    or not lo <= v <= hi:
                raise EventError(f"haptic force {name}={v!r} outside [{lo}, {hi}]")


@dataclass(frozen=True, slots=True)
class Heartbeat:
    """A publisher's "still here" for one device (topic ``hb.<device>``).

    Attributes:
        interval_s: seconds between this publisher's heartbeats, ``(0, 60]``; a
            subscriber calls the device silent after a few intervals without one.
        pen_seq: the last sequence number the publisher sent on ``pen.<device>``
            (0: none yet), so a subscriber also notices samples lost at the end
            of a stream, when no later sample shows the gap.
    """

    interval_s: float
    pen_seq: int = 0

    def __post_init__(self) -> None:
        v = self.interval_s
        if (isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v)
                or not 0.0 < v <= MAX_HEARTBEAT_INTERVAL):
            raise EventError(f"heartbeat interval_s={v!r} outside (0, {MAX_HEARTBEAT_INTERVAL}]")
        if isinstance(self.pen_seq, bool) or not isinstance(self.pen_seq, int) \
                or not 0 <= self.pen_seq < 2**64:
            raise EventError(f"heartbeat pen_seq={self.pen_seq!r} is not a u64")


@dataclass(frozen=True, slots=True)
class Envelope:
    """A decoded message: what it is, who sent it, in which order."""

    topic: str
    kind: str
    publisher: int
    seq: int
    replay: bool
    value: Any  # PenSample | Command | dict | Haptic | HapticForce | Heartbeat | list[PenSample]

    @property
    def count(self) -> int:
        """How many sequence numbers the message takes (a batch takes one per sample)."""
        return len(self.value) if isinstance(self.value, list) else 1


def encode_header(kind: int, publisher: int, seq: int, flags: int = 0) -> bytes:
    return _HEADER.pack(MAGIC, VERSION, kind, flags, publisher, seq)


def encode_pen(sample: PenSample) -> bytes:
    """The pen body (without header)."""
    flags = (_PF_PROXIMITY if sample.proximity else 0) | (_PF_TOUCHING if sample.touching else 0)
    if sample.serial is not None:
        flags |= _PF_SERIAL
    if sample.tool_id is not None:
        flags |= _PF_TOOL_ID
    if sample.rotation is not None:
        flags |= _PF_ROTATION
    if sample.distance is not None:
        flags |= _PF_DISTANCE
    if sample.wheel is not None:
        flags |= _PF_WHEEL
    return _PEN.pack(
        sample.t, sample.t_mono, _TOOL_INDEX[sample.tool], flags, sample.buttons,
        sample.tool_id or 0, sample.serial or 0, sample.seq,
        sample.x, sample.y, sample.pressure, sample.tilt_x, sample.tilt_y,
        sample.rotation or 0.0, sample.distance or 0.0, sample.wheel or 0.0,
    )  # fmt: skip


def decode_pen(device: str, body: bytes) -> PenSample:
    if len(body) != PEN_SIZE:
        raise WireError(f"pen body is {len(body)} bytes, expected {PEN_SIZE}")
    (t, t_mono, tool, flags, buttons, tool_id, serial, seq,
     x, y, pressure, tilt_x, tilt_y, rotation, distance, wheel) = _PEN.unpack(body)  # fmt: skip
    if tool >= len(TOOL_CODES):
        raise WireError(f"unknown tool code {tool}")
    if flags & 0x80:
        raise WireError(f"unknown pen flags {flags:#x}")
    try:
        return PenSample(
            t=t, t_mono=t_mono, device=device, tool=TOOL_CODES[tool],
            proximity=bool(flags & _PF_PROXIMITY), touching=bool(flags & _PF_TOUCHING),
            buttons=buttons,
            tool_id=tool_id if flags & _PF_TOOL_ID else None,
            serial=serial if flags & _PF_SERIAL else None,
            seq=seq, x=x, y=y, pressure=pressure, tilt_x=tilt_x, tilt_y=tilt_y,
            rotation=rotation if flags & _PF_ROTATION else None,
            distance=distance if flags & _PF_DISTANCE else None,
            wheel=wheel if flags & _PF_WHEEL else None,
        )  # fmt: skip
    except EventError as exc:
        raise WireError(f"invalid pen sample: {exc}") from None


_COUNT = struct.Struct("<H")


def encode_pen_batch(
    topic: str, samples: list[PenSample], publisher: int, seq: int, flags: int = 0
) -> list[bytes]:
    """One message carrying ``samples`` (1..MAX_BATCH) with sequence numbers seq, seq+1, …"""
    if not 0 < len(samples) <= MAX_BATCH:
        raise WireError(f"a pen batch holds 1..{MAX_BATCH} samples, not {len(samples)}")
    body = b"".join([_COUNT.pack(len(samples)), *map(encode_pen, samples)])
    return [topic.encode(), encode_header(KIND_PEN_BATCH, publisher, seq, flags) + body]


def _decode_pen_batch(device: str, body: bytes) -> list[PenSample]:
    if len(body) < _COUNT.size:
        raise WireError("pen batch without a count")
    (count,) = _COUNT.unpack_from(body)
    if not 0 < count <= MAX_BATCH or len(body) != _COUNT.size + count * PEN_SIZE:
        raise WireError(f"pen batch of {len(body)} bytes does not hold {count} samples")
    return [
        decode_pen(device, body[off : off + PEN_SIZE])
        for off in range(_COUNT.size, len(body), PEN_SIZE)
    ]


def _encode_json(obj: Mapping[str, object]) -> bytes:
    data = json.dumps(obj, separators=(",", ":"), allow_nan=False).encode()
    if len(data) > MAX_JSON_BODY:
        raise WireError(f"message body {len(data)} bytes exceeds {MAX_JSON_BODY}")
    return data


def _decode_json(body: bytes) -> dict[str, Any]:
    if len(body) > MAX_JSON_BODY:
        raise WireError(f"message body {len(body)} bytes exceeds {MAX_JSON_BODY}")
    try:
        obj = json.loads(body.decode("utf-8"), parse_constant=_no_constant)
    except (UnicodeDecodeError, ValueError) as exc:
        raise WireError(f"body is not UTF-8 JSON: {exc}") from None
    if not isinstance(obj, dict):
        raise WireError("body must be a JSON object")
    return obj


def _no_constant(name: str) -> NoReturn:
    raise ValueError(f"{name} is not allowed")


def encode(topic: str, value: object, publisher: int, seq: int, flags: int = 0) -> list[bytes]:
    """Both frames of a message carrying ``value`` on ``topic``."""
    if isinstance(value, PenSample):
        kind, body = KIND_PEN, encode_pen(value)
    elif isinstance(value, Command):
        kind, body = KIND_CMD, _encode_json(value.to_record())
    elif isinstance(value, Haptic):
        kind = KIND_HAPTIC
        body = _HAPTIC.pack(value.t, value.amplitude, value.frequency_hz, value.duration_s)
    elif isinstance(value, HapticForce):
        kind = KIND_HAPTIC_FORCE
        body = _HAPTIC_FORCE.pack(value.t, value.fx, value.fy, value.fz)
    elif isinstance(value, Heartbeat):
        kind, body = KIND_HEARTBEAT, _HEARTBEAT.pack(value.interval_s, value.pen_seq)
    elif isinstance(value, dict):
        kind, body = KIND_STATUS, _encode_json(value)
    else:
        raise TypeError(f"cannot encode {type(value).__name__} for the bus")
    return [topic.encode(), encode_header(kind, publisher, seq, flags) + body]


def pen_header(frames: list[bytes]) -> tuple[int, int, int] | None:
    """``(publisher, seq, samples)`` of a pen message read from its header alone, or
    ``None`` for other kinds and what is not wire format: counting a queue (and the
    gaps in it) without decoding it."""
    if len(frames) != 2 or len(frames[1]) < HEADER_SIZE:
        return None
    magic, _version, kind, _flags, publisher, seq = _HEADER.unpack_from(frames[1])
    if magic != MAGIC:
        return None
    if kind == KIND_PEN:
        return publisher, seq, 1
    if kind == KIND_PEN_BATCH and len(frames[1]) >= HEADER_SIZE + _COUNT.size:
        return publisher, seq, int(_COUNT.unpack_from(frames[1], HEADER_SIZE)[0])
    return None


def decode(frames: list[bytes]) -> Envelope:
    """Decode a message; :class:`WireError` for anything that is not wire format v1."""
    if len(frames) != 2:
        raise WireError(f"expected 2 frames, got {len(frames)}")
    raw_topic, payload = frames
    try:
        topic = raw_topic.decode("ascii")
    except UnicodeDecodeError:
        raise WireError("topic is not ASCII") from None
    if len(payload) < HEADER_SIZE:
        raise WireError(f"payload of {len(payload)} bytes is shorter than the header")
    magic, version, kind, flags, publisher, seq = _HEADER.unpack_from(payload)
    if magic != MAGIC:
        raise WireError(f"foreign message (magic {magic!r})")
    if version != VERSION:
        raise WireError(f"wire version {version} (this station speaks {VERSION})")
    if flags & ~FLAG_REPLAY:
        raise WireError(f"unknown header flags {flags:#x}")
    body = payload[HEADER_SIZE:]
    replay = bool(flags & FLAG_REPLAY)
    prefix, _, suffix = topic.partition(".")
    if kind in (KIND_PEN, KIND_PEN_BATCH):
        if prefix != "pen" or not suffix:
            raise WireError(f"pen message on topic {topic!r}")
        value: Any = (decode_pen(suffix, body) if kind == KIND_PEN
                      else _decode_pen_batch(suffix, body))
    elif kind == KIND_CMD:
        try:
            value = Command.from_record(_decode_json(body))
        except EventError as exc:
            raise WireError(f"invalid command: {exc}") from None
    elif kind == KIND_STATUS:
        value = _decode_json(body)
    elif kind == KIND_HAPTIC:
        if len(body) != _HAPTIC.size:
            raise WireError(f"haptic body is {len(body)} bytes, expected {_HAPTIC.size}")
        try:
            value = Haptic(*_HAPTIC.unpack(body))
        except EventError as exc:
            raise WireError(str(exc)) from None
    elif kind == KIND_HAPTIC_FORCE:
        if prefix != "haptic" or not suffix:
            raise WireError(f"haptic force on topic {topic!r}")
        if len(body) != _HAPTIC_FORCE.size:
            raise WireError(f"haptic force body is {len(body)} bytes, "
                            f"expected {_HAPTIC_FORCE.size}")
        try:
            value = HapticForce(*_HAPTIC_FORCE.unpack(body))
        except EventError as exc:
            raise WireError(str(exc)) from None
    elif kind == KIND_HEARTBEAT:
        if prefix != "hb" or not suffix:
            raise WireError(f"heartbeat on topic {topic!r}")
        if len(body) != _HEARTBEAT.size:
            raise WireError(f"heartbeat body is {len(body)} bytes, expected {_HEARTBEAT.size}")
        try:
            value = Heartbeat(*_HEARTBEAT.unpack(body))
        except EventError as exc:
            raise WireError(str(exc)) from None
    else:
        raise WireError(f"unknown message kind {kind}")
    return Envelope(topic, KIND_NAMES[kind], publisher, seq, replay, value)
