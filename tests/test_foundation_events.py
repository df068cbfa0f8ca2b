"""The pen-event model: validation and conversions."""

from __future__ import annotations

import math

import pytest

from station.errors import EventError
from station.events import Button, Command, PenSample, Tool


def sample(**kw: object) -> PenSample:
    base: dict[str, object] = dict(t=0.125, device="mock-0", tool="pen", x=0.41, y=0.52,
                                   pressure=0.37, tilt_x=12.0, tilt_y=-4.5, proximity=True,
                                   touching=True, buttons=0)
    base.update(kw)
    return PenSample(**base)  # type: ignore[arg-type]


def test_valid_sample_round_trips_through_record() -> None:
    s = sample(serial=0x1234, rotation=45.0, distance=0.2, wheel=0.7, seq=9, tool_id=0x802)
    rec = s.to_record()
    assert rec["type"] == "pen" and rec["tool"] == "pen" and rec["serial"] == 0x1234
    back = PenSample.from_record(rec)
    assert back == s
    assert back.tool is Tool.PEN


def test_interfaces_example_record_parses() -> None:
    rec = {"type": "pen", "t": 0.125, "device": "mock-0", "tool": "pen", "serial": None,
           "x": 0.41, "y": 0.52, "pressure": 0.37, "tilt_x": 12.0, "tilt_y": -4.5,
           "proximity": True, "touching": True, "buttons": 0}
    s = PenSample.from_record(rec)
    assert (s.x, s.y, s.pressure, s.tilt_x) == (0.41, 0.52, 0.37, 12.0)
    assert s.to_record() == rec


@pytest.mark.parametrize(
    ("field", "value", "needle"),
    [
        ("x", 1.0001, "x=1.0001 outside"),
        ("y", -0.01, "y=-0.01 outside"),
        ("pressure", math.nan, "pressure is nan"),
        ("x", math.inf, "x is inf"),
        ("tilt_x", 91.0, "tilt_x=91.0 outside"),
        ("tilt_y", -90.5, "tilt_y=-90.5 outside"),
        ("tool", "crayon", "unknown tool 'crayon'"),
        ("buttons", -1, "buttons"),
        ("buttons", True, "buttons"),
        ("x", "0.5", "x must be a number"),
        ("device", "a.b", "must not hold dots"),
        ("device", "", "device must be a name"),
        ("serial", -3, "serial"),
        ("t", -1.0, "t=-1.0 outside"),
        ("proximity", 1, "proximity must be true or false"),
        ("distance", 1.5, "distance=1.5 outside"),
        ("seq", -1, "seq"),
    ],
)
def test_invalid_values_are_rejected(field: str, value: object, needle: str) -> None:
    with pytest.raises(EventError, match=None) as info:
        sample(**{field: value})
    assert needle in str(info.value)


def test_touching_without_proximity_is_rejected() -> None:
    with pytest.raises(EventError, match="touching requires proximity"):
        sample(proximity=False, touching=True)


def test_integers_become_floats_and_bool_flags_stay_typed() -> None:
    s = sample(x=1, y=0, pressure=1, tilt_x=0)
    assert type(s.x) is float and s.x == 1.0 and type(s.pressure) is float
    assert Button.STYLUS | Button.STYLUS2 == 3


def test_record_missing_keys_names_them_and_where() -> None:
    with pytest.raises(EventError, match=r"f\.jsonl:3: pen record lacks x, pressure"):
        PenSample.from_record({"type": "pen", "t": 0, "device": "d", "tool": "pen", "y": 0.5,
                               "proximity": True, "touching": False}, "f.jsonl:3")


def test_unknown_keys_are_reported_not_fatal() -> None:
    unknown: list[str] = []
    rec = sample().to_record() | {"colour": "red"}
    PenSample.from_record(rec, unknown=unknown)
    assert unknown == ["colour"]


def test_command_validation() -> None:
    c = Command(t=0.5, cmd="brush", args={"size": 24})
    assert c.known and Command.from_record(c.to_record()) == c
    assert not Command(t=0, cmd="future_tool").known
    with pytest.raises(EventError):
        Command(t=0, cmd="not a name")
    with pytest.raises(EventError):
        Command(t=0, cmd="dry", args=[1, 2])  # type: ignore[arg-type]
    with pytest.raises(EventError):
        Command(t=math.nan, cmd="dry")
