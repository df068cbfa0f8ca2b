"""Device data tells the truth about the pen (issue 24.7): the DTK-2241 has no tilt."""

from __future__ import annotations

from station.drivers.mock.tablet import MockTablet
from station.drivers.normalise import Normaliser
from station.drivers.registry import PARSERS, find_device, parser_for


def _zero_tilt_reports(model: dict) -> list[tuple[float, bytes]]:
    """A mock DTK-2241 stroke with every pen packet's tilt bits zeroed, as the real pen
    sends them (d[7] low 5 bits, d[8]; pressure's bits in d[7] kept)."""
    tablet = MockTablet(model, script="line", reports=30)
    for feature in tablet.init_features:
        tablet.feature(feature)
    out = []
    for r in tablet.timed_reports():
        d = bytearray(r.data)
        if len(d) >= 10 and d[0] == 2 and not d[1] & 0x18 and (d[1] & 0xFC) not in (
                0xC0, 0x80) and d[1] & 0x40:
            d[7] &= 0xC0
            d[8] = 0
        out.append((r.time, bytes(d)))
    return out


def _samples(model: dict, parser: object) -> list:
    norm = Normaliser(parser.ranges, device="dtk")  # type: ignore[attr-defined]
    out = []
    for t, data in _zero_tilt_reports(model):
        for raw in parser.parse(data, t):  # type: ignore[attr-defined]
            out += norm.feed(raw)
    return [s for s in out if s.touching]


def test_the_dtk2241_data_claims_no_tilt() -> None:
    model = find_device(0x056A, 0x0057)
    assert model is not None and model["tilt"] is False
    assert "no-tilt" in model["protocol_quirks"]
    assert all("tilt" not in s["axes"] for s in model["styli"])
    assert "tilt bytes are 0" in model["provenance"]["measured"]
    parser = parser_for(0x056A, 0x0057, None)
    assert parser.ranges.tilt_x is None and parser.ranges.tilt_y is None


def test_the_dtk2241s_zero_tilt_bytes_never_reach_a_brush_as_a_slant() -> None:
    model = find_device(0x056A, 0x0057)
    assert model is not None
    # the corrected data: the parser reads no tilt at all
    new = _samples(model, parser_for(0x056A, 0x0057, None))
    assert len(new) > 10 and all(s.tilt_x == 0.0 and s.tilt_y == 0.0 for s in new)
    # the old data (tilt claimed): the bytes decode to the axis minimum, -64 -64, which
    # the normaliser now takes as an absent axis instead of a full slant
    old_model = {**model, "tilt": True, "protocol_quirks": []}
    old = _samples(old_model, PARSERS[old_model["parser"]](old_model, None))
    assert len(old) > 10 and all(s.tilt_x == 0.0 and s.tilt_y == 0.0 for s in old)
