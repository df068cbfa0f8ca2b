"""The haptic serial protocol, the safety filter and the contact model, without any port."""

from __future__ import annotations

import itertools
import math
import random
import struct

import pytest
from station.drivers.haptic.contact import (
    BrushState,
    FrameInterpolator,
    RoundBrushContact,
    paper_grain,
    pressure_from_force,
)
from station.drivers.haptic.safety import ForceLimits, SafetyFilter
from station.drivers.serial.protocol import (
    DEVICE_TYPES,
    HEADER,
    DeviceError,
    Enable,
    Force,
    FrameDecoder,
    Heartbeat,
    Hello,
    HelloRequest,
    Pose,
    ProtocolError,
    Vibration,
    cobs_decode,
    cobs_encode,
    crc16,
    decode_body,
    encode_frame,
)

HELLO = Hello(1, 0, 0x1209, 0x4A50, 1000, 2, 2, 3, (2.5, 2.5, 3.0), 0.0, (160.0, 120.0, 70.0),
              "SN42", "Test pen")
MESSAGES = [
    HELLO,
    Pose(123456, 1.5, -2.25, 7.0, (1.0, 0.0, 0.0, 0.0), 3, 1),
    DeviceError(2, "watchdog"),
    HelloRequest(),
    Force(0.5, -0.25, 1.5, 0.0, 0.0, 0.0),
    Vibration(0.3, 250.0, 40),
    Enable(True),
    Heartbeat(99),
]


def test_cobs_known_vectors_and_round_trip() -> None:
    # the examples of Cheshire & Baker's paper (and Wikipedia's table)
    assert cobs_encode(b"\x00") == b"\x01\x01"
    assert cobs_encode(b"\x00\x00") == b"\x01\x01\x01"
    assert cobs_encode(b"\x11\x22\x00\x33") == b"\x03\x11\x22\x02\x33"
    assert cobs_encode(b"\x11\x22\x33\x44") == b"\x05\x11\x22\x33\x44"
    assert cobs_encode(bytes(range(1, 255))) == b"\xff" + bytes(range(1, 255)) + b"\x01"
    rng = random.Random(7)
    for n in [0, 1, 253, 254, 255, 508, 600] + [rng.randrange(300) for _ in range(300)]:
        data = bytes(rng.choice([0, 0, 1, 255, rng.randrange(256)]) for _ in range(n))
        enc = cobs_encode(data)
        assert 0 not in enc
        assert len(enc) <= n + n // 254 + 1
        assert cobs_decode(enc) == data
    with pytest.raises(ProtocolError):
        cobs_decode(b"\x05\x11\x22")  # block runs past the end
    with pytest.raises(ProtocolError):
        cobs_decode(b"\x03\x11\x00")


def test_crc16_is_ccitt_false() -> None:
    assert crc16(b"123456789") == 0x29B1


@pytest.mark.parametrize("message", MESSAGES, ids=lambda m: type(m).__name__)
def test_frame_round_trip(message) -> None:
    frame = encode_frame(message, 0xFFFE)
    assert frame.endswith(b"\x00") and 0 not in frame[:-1]
    seq, back = decode_body(frame[:-1])
    assert seq == 0xFFFE and type(back) is type(message)
    for name in message.__dataclass_fields__:
        a, b = getattr(message, name), getattr(back, name)
        if isinstance(a, (float, tuple)):
            assert b == pytest.approx(a, rel=1e-6)
        else:
            assert a == b


def test_decoder_rejects_what_is_not_v1() -> None:
    def body(version: int, kind: int, payload: bytes) -> bytes:
        raw = HEADER.pack(version, kind, 0) + payload
        return cobs_encode(raw + crc16(raw).to_bytes(2, "big"))

    good = Force(1, 2, 3).payload()
    decode_body(body(1, 0x82, good))
    cases = {
        "version": body(2, 0x82, good),
        "unknown type": body(1, 0x7F, good),
        "short": body(1, 0x82, good[:-1]),
        "nan": body(1, 0x82, struct.pack("<6f", math.nan, 0, 0, 0, 0, 0)),
        "quaternion": body(1, 0x02, struct.pack("<I7fHB", 0, 0, 0, 0, 2.0, 0, 0, 0, 0, 0)),
        "pose flags": body(1, 0x02, struct.pack("<I7fHB", 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 0x80)),
        "hello rate": body(1, 0x01, HELLO.payload()[:6] + b"\x00\x00" + HELLO.payload()[8:]),
    }
    for what, enc in cases.items():
        with pytest.raises(ProtocolError):
            decode_body(enc)
        assert what
    # a station accepts only what a device sends
    with pytest.raises(ProtocolError, match="unexpected message type"):
        decode_body(encode_frame(Force(), 0)[:-1], DEVICE_TYPES)


def test_decoder_counts_lost_frames_and_resyncs_mid_stream() -> None:
    frames = [encode_frame(Pose(i, 0, 0, 1), i) for i in range(10)]
    stream = b"".join(frames[:3] + frames[5:])  # 3 and 4 lost on the line
    dec = FrameDecoder(accept=DEVICE_TYPES, synced=False)
    got = dec.feed(stream[7:])  # opened mid-frame: the partial first frame is not "bad"
    assert [seq for seq, _ in got] == [1, 2, 5, 6, 7, 8, 9]
    assert dec.stats.bad_frames == 0 and dec.stats.lost == 2


def test_fuzzed_decoder_counts_and_drops_every_bad_frame() -> None:
    """Thousands of seeded streams: valid frames mixed with garbage, truncated and corrupted
    ones, fed in random chunk sizes.  Never an exception; every intact frame comes out in
    order; every damaged frame is counted as bad (a flipped bit never passes the CRC)."""
    rng = random.Random(20261124)
    total_bad = total_good = 0
    for _round in range(2000):
        dec = FrameDecoder(accept=DEVICE_TYPES)
        stream = bytearray(b"\x00")
        want: list[int] = []
        bad = 0
        for i in range(rng.randrange(1, 12)):
            frame = bytearray(encode_frame(rng.choice(MESSAGES[:3]), i))
            kind = rng.random()
            if kind < 0.5:
                want.append(i)
            elif kind < 0.7:  # one flipped bit, never making a delimiter
                j = rng.randrange(len(frame) - 1)
                flipped = frame[j] ^ (1 << rng.randrange(8))
                if flipped == 0:
                    want.append(i)
                else:
                    frame[j] = flipped
                    bad += 1
            elif kind < 0.85:  # truncated: the line dropped its tail
                frame = frame[: rng.randrange(1, len(frame) - 1)] + b"\x00"
                bad += 1
            else:  # garbage without delimiters, then a delimiter: one bad frame
                frame = bytearray(rng.randrange(1, 256) for _ in range(rng.randrange(1, 300)))
                frame.append(0)
                bad += 1
            stream += frame
        got: list[int] = []
        at = 0
        while at < len(stream):
            n = rng.randrange(1, 64)
            got += [seq for seq, _ in dec.feed(bytes(stream[at : at + n]))]
            at += n
        assert got == want
        assert dec.stats.bad_frames == bad
        total_bad += bad
        total_good += len(want)
    assert total_bad > 2000 and total_good > 2000
    # pure noise (zeros included): no crash, and (CRC-16) essentially nothing decodes
    dec = FrameDecoder()
    for _ in range(2000):
        dec.feed(bytes(rng.randrange(256) for _ in range(rng.randrange(0, 200))))
    assert dec.stats.bad_frames > 500 and dec.stats.frames <= 2


def test_safety_clamps_rate_limits_and_watchdogs() -> None:
    limits = ForceLimits.from_device((2.5, 2.5, 3.0), configured=2.0, rate_n_per_s=100.0)
    assert limits.axis == (2.0, 2.0, 2.0) and limits.magnitude == 2.0
    f = SafetyFilter(limits, max_step_s=0.002)
    t = 0.0
    out = f.apply((0.0, 0.0, 10.0), t, t)
    assert out == (0.0, 0.0, 0.0)  # first tick: dt 0, nothing may change yet
    seen = []
    for _ in range(40):
        t += 0.001
        seen.append(f.apply((5.0, 5.0, 10.0), t, t))
    steps = [abs(b[2] - a[2]) for a, b in itertools.pairwise(seen)]
    assert max(steps) <= 0.1 + 1e-9  # 100 N/s at 1 ms
    assert all(limits.within(v) for v in seen)
    assert math.sqrt(sum(v * v for v in seen[-1])) == pytest.approx(2.0, rel=1e-5)
    # the float32 a frame carries stays inside the limits too
    back = Force.parse(Force(*seen[-1]).payload())
    assert limits.within(back.vector)
    # watchdog: inputs 51 ms old -> zero at once (not rate-limited)
    assert f.apply((0.0, 0.0, 1.0), t + 0.051, t) == (0.0, 0.0, 0.0)
    assert f.stats.watchdog_trips == 1
    # a trip zeroes the next tick; the force then ramps up again from zero
    t += 0.06
    f.apply((0.0, 0.0, 1.0), t, t)
    f.trip("bad frame")
    assert f.apply((0.0, 0.0, 1.0), t + 0.001, t + 0.001) == (0.0, 0.0, 0.0)
    assert f.apply((0.0, 0.0, 1.0), t + 0.002, t + 0.002)[2] == pytest.approx(0.1)
    assert f.apply((math.nan, 0.0, 1.0), t + 0.003, t + 0.003) == (0.0, 0.0, 0.0)


def test_a_stalled_station_ramps_up_from_zero_not_from_its_last_force() -> None:
    """The station's loop held up past the watchdog: the device has zeroed itself, so the
    next force starts from zero whether or not the device's error report was read yet
    (seen under load: a 0.78 N kick as the first frame after a 150 ms hang)."""
    limits = ForceLimits.from_device((3.0, 3.0, 3.0), rate_n_per_s=200.0)
    f = SafetyFilter(limits, max_step_s=0.002)
    t = 0.0
    for _ in range(20):
        t += 0.001
        f.apply((0.0, 0.0, 1.0), t, t)
    assert f.last[2] == pytest.approx(1.0)
    t += 0.051  # one tick 51 ms late, its inputs fresh
    assert f.apply((0.0, 0.0, 1.0), t, t) == (0.0, 0.0, 0.0)
    assert f.stats.trips["station stalled"] == 1
    t += 0.001
    assert f.apply((0.0, 0.0, 1.0), t, t)[2] == pytest.approx(0.2)  # 200 N/s for 1 ms
    t += 0.049  # late, but within the watchdog: rate-limited from where it was
    assert f.apply((0.0, 0.0, 1.0), t, t)[2] == pytest.approx(0.6)
    assert f.stats.trips["station stalled"] == 1


def test_round_brush_spring_friction_and_grain() -> None:
    brush = RoundBrushContact(hair_mm=6.0, stiffness=0.5, grain=0.0)
    assert brush.contact_force(BrushState(0, (0, 0, 6.5))) == (0.0, 0.0, 0.0)
    fz = [brush.contact_force(BrushState(0, (0, 0, 6.0 - d)))[2] for d in (1, 2, 3)]
    assert fz == pytest.approx([0.5, 1.0, 1.5])
    assert brush.normal_force(-1.0) == pytest.approx(0.5 * 7 + 4.0)  # the ferrule hits paper
    fx, fy, fz1 = brush.contact_force(BrushState(0, (0, 0, 4.0), velocity=(30.0, 0.0, 0.0)))
    assert fx == pytest.approx(-0.15 * fz1) and fy == 0.0  # opposes the stroke
    grainy = RoundBrushContact(grain=0.1)
    along = [grainy.contact_force(BrushState(0, (x / 10, 0, 4.0)))[2] for x in range(200)]
    assert min(along) / 1.0 >= 0.9 and max(along) / 1.0 <= 1.1  # ±10 % of the 1 N spring
    assert max(along) - min(along) > 0.05  # the grain is felt
    assert all(-1.0 <= paper_grain(u / 7, u / 3) <= 1.0 for u in range(500))
    assert pressure_from_force(1.0, 2.0) == 0.5 and pressure_from_force(9.0, 2.0) == 1.0


def test_frame_interpolator_turns_a_30hz_staircase_into_ramps() -> None:
    interp = FrameInterpolator()
    frames = [(i / 30, (0.0, 0.0, float(i % 2))) for i in range(10)]
    out = []
    t = 0.0
    for ft, force in frames:
        interp.push(ft, force)
        while t < ft + 1 / 30:
            if t >= ft:
                out.append(interp.sample(t)[2])
            t += 0.001
    steps = [abs(b - a) for a, b in itertools.pairwise(out)]
    assert max(steps) < 0.05  # ≤ 1 N per 33 ms, never a 1 N step
    assert min(out) >= 0.0 and max(out) <= 1.0
