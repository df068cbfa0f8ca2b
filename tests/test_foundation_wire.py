"""The bus wire format: round trips, versions, garbage."""

from __future__ import annotations

import math
import random
import struct

import pytest

from station import wire
from station.errors import WireError
from station.events import Command, PenSample, Tool
from station.wire import Haptic


def pen(**kw: object) -> PenSample:
    base: dict[str, object] = dict(t=1.5, device="intuos-0", tool=Tool.ERASER, x=0.25,
                                   y=0.75, pressure=0.5, tilt_x=-30.0, tilt_y=12.5,
                                   touching=True, buttons=3, seq=42, t_mono=1234.5)
    base.update(kw)
    return PenSample(**base)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "value",
    [
        pen(),
        pen(serial=0xDEADBEEF12, tool_id=0x10804, rotation=-123.5, distance=0.25, wheel=1.0),
        pen(proximity=False, touching=False, pressure=0.0),
        Command(t=2.0, cmd="brush", args={"size": 24, "pigment": {"Black": 0.5}}),
        {"steps": 10, "fps": 59.5, "lost": 0},
        Haptic(t=3.0, amplitude=0.5, frequency_hz=180.0, duration_s=0.02),
    ],
)
def test_round_trip(value: object) -> None:
    topic = "pen.intuos-0" if isinstance(value, PenSample) else "cmd"
    frames = wire.encode(topic, value, publisher=0xABCDEF01, seq=7)
    env = wire.decode(frames)
    assert env.value == value and env.seq == 7 and env.publisher == 0xABCDEF01
    assert not env.replay


def test_pen_message_is_compact() -> None:
    frames = wire.encode("pen.a", pen(), 1, 1)
    assert len(frames[1]) == wire.HEADER_SIZE + wire.PEN_SIZE == 124


def test_version_mismatch_is_named() -> None:
    topic, payload = wire.encode("pen.a", pen(), 1, 1)
    bad = payload[:2] + bytes([2]) + payload[3:]
    with pytest.raises(WireError, match="wire version 2"):
        wire.decode([topic, bad])


@pytest.mark.parametrize(
    ("frames", "needle"),
    [
        ([b"pen.a"], "expected 2 frames"),
        ([b"pen.a", b"ST"], "shorter than the header"),
        ([b"pen.a", b"XX" + bytes(18) + bytes(104)], "foreign message"),
        ([b"\xff\xfe", bytes(20)], "not ASCII"),
    ],
)
def test_garbage_frames(frames: list[bytes], needle: str) -> None:
    with pytest.raises(WireError, match=needle):
        wire.decode(frames)


def test_pen_body_with_nan_or_out_of_range_is_rejected() -> None:
    topic, payload = wire.encode("pen.a", pen(), 1, 1)
    body = bytearray(payload[wire.HEADER_SIZE:])
    x_off = 8 + 8 + 1 + 1 + 2 + 4 + 8 + 8
    for bad in (math.nan, 1.5, -0.1):
        struct.pack_into("<d", body, x_off, bad)
        with pytest.raises(WireError, match="invalid pen sample"):
            wire.decode([topic, payload[: wire.HEADER_SIZE] + bytes(body)])


def test_wrong_topic_kind_and_tool_code() -> None:
    _, payload = wire.encode("pen.a", pen(), 1, 1)
    with pytest.raises(WireError, match="pen message on topic 'cmd'"):
        wire.decode([b"cmd", payload])
    body = bytearray(payload)
    body[wire.HEADER_SIZE + 16] = 200  # tool code
    with pytest.raises(WireError, match="unknown tool code"):
        wire.decode([b"pen.a", bytes(body)])
    bad_kind = bytearray(payload)
    bad_kind[3] = 99
    with pytest.raises(WireError, match="unknown message kind"):
        wire.decode([b"pen.a", bytes(bad_kind)])


def test_random_bytes_never_crash_the_decoder() -> None:
    rng = random.Random(1234)
    good = wire.encode("pen.a", pen(), 1, 1)[1]
    decoded = 0
    for i in range(3000):
        if i % 2:
            payload = bytes(rng.getrandbits(8) for _ in range(rng.randrange(0, 200)))
        else:  # mutate a valid message: the harder case
            payload = bytearray(good)
            for _ in range(rng.randrange(1, 4)):
                payload[rng.randrange(len(payload))] = rng.getrandbits(8)
            payload = bytes(payload)
        try:
            env = wire.decode([b"pen.a", payload])
        except WireError:
            continue
        decoded += 1
        assert isinstance(env.value, PenSample)
        assert 0.0 <= env.value.x <= 1.0 and 0.0 <= env.value.pressure <= 1.0
    assert decoded > 0  # some mutations leave a valid sample: those must be valid


def test_pen_batch_round_trip_and_sequence_span() -> None:
    samples = [pen(seq=i, x=i / 10) for i in range(1, 8)]
    frames = wire.encode_pen_batch("pen.intuos-0", samples, publisher=5, seq=100)
    env = wire.decode(frames)
    assert env.kind == "pen" and env.value == samples
    assert env.seq == 100 and env.count == 7


@pytest.mark.parametrize("cut", [1, wire.PEN_SIZE // 2, wire.PEN_SIZE])
def test_pen_batch_with_wrong_count_or_length_is_rejected(cut: int) -> None:
    topic, payload = wire.encode_pen_batch("pen.a", [pen(), pen()], 1, 1)
    with pytest.raises(WireError, match="pen batch"):
        wire.decode([topic, payload[:-cut]])
    bad_count = bytearray(payload)
    bad_count[wire.HEADER_SIZE] = 0
    with pytest.raises(WireError, match="does not hold 0 samples"):
        wire.decode([topic, bytes(bad_count)])


def test_pen_batch_size_limits() -> None:
    with pytest.raises(WireError):
        wire.encode_pen_batch("pen.a", [], 1, 1)
    with pytest.raises(WireError):
        wire.encode_pen_batch("pen.a", [pen()] * (wire.MAX_BATCH + 1), 1, 1)
