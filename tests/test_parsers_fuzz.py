"""Robustness: random and mutated input into every parser only yields samples or typed errors."""

from __future__ import annotations

import random

from station.drivers import registry
from station.drivers import synth as S
from station.drivers.hid.descriptor import parse_descriptor
from station.drivers.hid.errors import DescriptorError, ReportError
from station.drivers.hid.pen import GenericPenParser
from station.drivers.raw import RawSample

from station.events import Tool

ROUNDS = 3000


def _parsers():
    out = [
        registry.parser_for(0x056A, 0x0315, None),
        registry.parser_for(0x056A, 0x00B8, None),
        registry.parser_for(0x056A, 0x030E, None),
        registry.parser_for(0x056A, 0x00D4, None),
        registry.parser_for(0x056A, 0x0081, None, bus=3),
        registry.parser_for(0x056A, 0x0081, None, bus=5),
    ]
    for raw in (S.pth660_like_descriptor(), S.huion_like_descriptor(),
                S.ntrig_like_descriptor()):  # fmt: skip
        out.append(GenericPenParser(parse_descriptor(raw)))
    return out


def _check_sample(s: RawSample) -> None:
    assert isinstance(s, RawSample)
    assert isinstance(s.x, int) and isinstance(s.y, int)
    assert isinstance(s.proximity, bool) and isinstance(s.valid, bool)
    assert s.tool is None or isinstance(s.tool, Tool)
    assert s.pressure is None or s.pressure >= 0
    assert 0 <= s.buttons <= 0xFFFF
    assert s.serial is None or s.serial >= 0


def _plausible(parser) -> list[tuple[int, int]]:
    """(report ID, length) pairs the parser accepts."""
    if isinstance(parser, GenericPenParser):
        return list(parser.lengths.items())
    name = parser.name
    if name == "wacom-intuos":
        return [(2, 10), (16, 10)]
    if name == "wacom-bamboo":
        return [(2, 9), (2, 10)]
    return [(3 if name.endswith("-bt") else 2, 8)]


def _random_report(rng: random.Random, parser) -> bytes:
    if rng.random() < 0.6:  # plausible ID and length, random content
        rid, n = rng.choice(_plausible(parser))
        return bytes([rid] + [rng.getrandbits(8) for _ in range(n - 1)])
    n = rng.choice([0, 1, 2, 8, 9, 10, 11, 15, 20, 64, rng.randrange(0, 70)])
    data = bytearray(rng.getrandbits(8) for _ in range(n))
    if data and rng.random() < 0.7:
        data[0] = rng.choice([1, 2, 3, 5, 10, 12, 16, 17])
    return bytes(data)


def test_random_reports_into_every_parser():
    rng = random.Random(1234)
    parsers = _parsers()
    counts = {"samples": 0, "errors": 0, "empty": 0}
    for _ in range(ROUNDS):
        p = rng.choice(parsers)
        report = _random_report(rng, p)
        try:
            out = p.parse(report, rng.random())
        except ReportError:
            counts["errors"] += 1
            continue
        assert isinstance(out, list)
        counts["samples" if out else "empty"] += 1
        for s in out:
            _check_sample(s)
    # the loop exercised all three outcomes
    assert counts["samples"] > 100 and counts["errors"] > 100 and counts["empty"] > 10


def test_valid_length_random_payloads_decode():
    rng = random.Random(99)
    p = registry.parser_for(0x056A, 0x0315, None)
    p.parse(S.intuos_prox_in(0x802, 1), 0.0)
    for _ in range(500):
        payload = bytes([2, rng.choice([0xE0, 0xE1, 0xE2, 0xE6, 0xEA, 0xF4, 0xEC, 0xF0])]
                        + [rng.getrandbits(8) for _ in range(8)])  # fmt: skip
        for s in p.parse(payload, 0.0):
            _check_sample(s)
            assert -64 <= (s.tilt_x or 0) <= 63 and 0 <= (s.distance or 0) <= 63
            assert s.rotation is None or -900 <= s.rotation <= 899
            assert s.wheel is None or 0 <= s.wheel <= 1023
            assert 0 <= s.x < 1 << 17 and 0 <= s.y < 1 << 17
            assert s.pressure is None or 0 <= s.pressure <= 2047


def test_random_and_mutated_descriptors():
    rng = random.Random(7)
    seeds = [S.pth660_like_descriptor(), S.huion_like_descriptor(), S.ntrig_like_descriptor(),
             S.touch_descriptor(), S.wacom_protocol_descriptor()]  # fmt: skip
    ok = bad = 0
    for i in range(1500):
        raw: bytes
        if i % 3 == 0:
            raw = bytes(rng.getrandbits(8) for _ in range(rng.randrange(0, 120)))
        else:
            mutated = bytearray(rng.choice(seeds))
            for _ in range(rng.randrange(1, 4)):
                op = rng.random()
                if op < 0.4 and mutated:
                    mutated[rng.randrange(len(mutated))] = rng.getrandbits(8)
                elif op < 0.7 and mutated:
                    del mutated[rng.randrange(len(mutated)):]
                else:
                    mutated.insert(rng.randrange(len(mutated) + 1), rng.getrandbits(8))
            raw = bytes(mutated)
        try:
            d = parse_descriptor(raw)
        except DescriptorError as exc:
            bad += 1
            assert exc.offset is not None and 0 <= exc.offset <= len(raw)
            continue
        ok += 1
        parser = GenericPenParser(d)
        for rid in list(parser.lengths)[:3]:
            n = parser.lengths[rid]
            report = bytes([rid] if d.numbered else []) + bytes(
                rng.getrandbits(8) for _ in range(n - (1 if d.numbered else 0)))
            try:
                for s in parser.parse(report, 0.0):
                    _check_sample(s)
            except ReportError:
                pass
    assert ok > 100 and bad > 100
