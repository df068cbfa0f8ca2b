"""The normaliser: hysteresis, worn-nib offset, tilt, curve, forced proximity-out, identity."""

from __future__ import annotations

import math

import pytest
from station.drivers.normalise import (
    Normaliser,
    NormaliserConfig,
    NormaliserConfigError,
)
from station.drivers.raw import Axis, AxisRanges, RawSample

from station.errors import EventError
from station.events import Tool
from station.pressure import BezierCurve

RANGES = AxisRanges(
    x=Axis(0, 1000, 100.0), y=Axis(0, 500, 100.0), pressure=Axis(0, 1000),
    tilt_x=Axis(-64, 63, None), tilt_y=Axis(-64, 63, 1.0), distance=Axis(0, 63),
    rotation=Axis(-900, 899, None), wheel=Axis(0, 1023),
)  # fmt: skip


def raw(t: float, p: int | None = 0, **kw: object) -> RawSample:
    args: dict[str, object] = dict(time=t, proximity=True, x=500, y=250, pressure=p)
    args.update(kw)
    return RawSample(**args)


def feed_pressures(n: Normaliser, pressures: list[int], t0: float = 0.0):
    out = []
    for i, p in enumerate(pressures):
        (s,) = n.feed(raw(t0 + i * 0.005, p))
        out.append(s)
    return out


def test_tip_hysteresis_down_5_up_1_and_renormalised() -> None:
    n = Normaliser(RANGES, config=NormaliserConfig(worn_nib=False))
    s = feed_pressures(n, [0, 49, 50, 525, 1000, 11, 10, 9, 30, 49, 50])
    touching = [x.touching for x in s]
    assert touching == [False, False, True, True, True, True, True, False, False, False, True]
    assert s[2].pressure == 0.0  # the down threshold maps to 0
    assert s[3].pressure == pytest.approx(475 / 950)
    assert s[4].pressure == 1.0
    assert s[5].pressure == 0.0 and s[5].touching  # between up and down: in contact, zero
    for x in s:
        if not x.touching:
            assert x.pressure == 0.0


def test_hysteresis_thresholds_are_configurable() -> None:
    n = Normaliser(RANGES, config=NormaliserConfig(tip_down=0.2, tip_up=0.1, worn_nib=False))
    s = feed_pressures(n, [199, 200, 600, 101, 99])
    assert [x.touching for x in s] == [False, True, True, True, False]
    assert s[2].pressure == pytest.approx(400 / 800)
    with pytest.raises(NormaliserConfigError):
        NormaliserConfig(tip_down=0.01, tip_up=0.05)


def test_worn_nib_offset_on_proximity_in() -> None:
    n = Normaliser(RANGES)
    # proximity-in resting at 10 % of the range: that becomes the zero
    s = feed_pressures(n, [100, 144, 145, 573, 1000])
    assert n.stats.nib_offsets == 1
    assert n.tools[(Tool.PEN, None, None)].pressure_offset == 100
    # down = 100 + 5 % of 900 = 145; pressure = (p - 145) / (1000 - 145)
    assert [x.touching for x in s] == [False, False, True, True, True]
    assert s[3].pressure == pytest.approx((573 - 145) / 855)
    assert s[4].pressure == 1.0
    # up threshold = 100 + 1 % of 900 = 109
    (a,) = n.feed(raw(0.03, 110))
    (b,) = n.feed(raw(0.035, 108))
    assert a.touching and not b.touching
    # leaving and coming back resting lower: the offset follows (kept per tool)
    n.feed(RawSample(time=0.04, proximity=False, valid=False))
    feed_pressures(n, [60, 60], t0=0.06)
    assert n.tools[(Tool.PEN, None, None)].pressure_offset == 60
    # proximity-in already pressing hard (> 50 %): not an offset, previous one kept
    n.feed(RawSample(time=0.08, proximity=False, valid=False))
    (c,) = n.feed(raw(0.1, 700))
    assert n.tools[(Tool.PEN, None, None)].pressure_offset == 60
    assert c.touching and c.pressure == pytest.approx((700 - 60 - 0.05 * 940) / (1000 - 60 - 47))


def test_worn_nib_not_taken_while_tip_down() -> None:
    n = Normaliser(RANGES)
    (s,) = n.feed(raw(0.0, 300, tip=True))
    assert n.tools[(Tool.PEN, None, None)].pressure_offset == 0
    # the tip switch rules contact: pressure counts from zero, not from the 5 % threshold
    assert s.touching and s.pressure == pytest.approx(300 / 1000)


def test_tilt_rotation_distance_wheel() -> None:
    n = Normaliser(RANGES)
    n.feed(raw(0.0, tilt_x=-63))  # the axis moves: its minimum is a real value from now
    (s,) = n.feed(raw(0.0, tilt_x=-64, tilt_y=-30, rotation=0, distance=63, wheel=1023))
    assert s.tilt_x == -64.0  # no resolution: range → ±64°
    assert s.tilt_y == -30.0  # resolution 1 unit per degree
    assert s.rotation == pytest.approx(900 / 1799 * 360 - 180)
    assert s.distance == 1.0 and s.wheel == 1.0
    (s,) = n.feed(raw(0.005, tilt_x=63, tilt_y=63))
    assert s.tilt_x == 64.0 and s.tilt_y == 63.0


def test_coordinates_clamped_to_active_area() -> None:
    n = Normaliser(RANGES, config=NormaliserConfig(area=(100, 100, 600, 400)))
    pts = [(50, 50), (350, 250), (600, 400), (1000, 500)]
    got = [n.feed(raw(i * 0.005, x=x, y=y))[0] for i, (x, y) in enumerate(pts)]
    assert [(s.x, s.y) for s in got] == [(0.0, 0.0), (0.5, 0.5), (1.0, 1.0), (1.0, 1.0)]


def test_bezier_pressure_curve() -> None:
    identity = BezierCurve(1 / 3, 1 / 3, 2 / 3, 2 / 3)
    for p in (0.0, 0.1, 0.3, 0.77, 1.0):
        assert identity(p) == pytest.approx(p, abs=1e-4)
    soft = BezierCurve(0.0, 0.5, 0.5, 1.0)
    assert soft(0.3125) == pytest.approx(0.6875, abs=1e-4)  # s = 0.5 on the curve
    n = Normaliser(RANGES, config=NormaliserConfig(worn_nib=False, pressure_curve=(0, .5, .5, 1)))
    (s,) = n.feed(raw(0.0, p=round(50 + 0.3125 * 950)))
    assert s.pressure == pytest.approx(0.6875, abs=2e-3)
    with pytest.raises(NormaliserConfigError):
        NormaliserConfig(pressure_curve=(0.0, 1.2, 0.5, 1.0))


def test_forced_proximity_out_after_50_ms_on_tick_and_on_next_report() -> None:
    n = Normaliser(RANGES)
    n.feed(raw(10.000))
    n.feed(raw(10.005, 30))  # hovering: 3 % of the range is under the contact threshold
    assert n.tick(10.054) == []  # 49 ms: still in proximity
    (out,) = n.tick(10.0551)
    assert not out.proximity and not out.touching and out.pressure == 0.0
    assert out.t == pytest.approx(0.055)  # timeout after the last report, transport time
    assert n.tick(11.0) == [] and n.stats.forced_out == 1
    # a report after a gap: forced out first, then proximity-in again
    n.feed(raw(12.0))
    first, second = n.feed(raw(12.2))
    assert (first.proximity, second.proximity) == (False, True)
    assert first.t == pytest.approx(2.05) and second.t == pytest.approx(2.2)
    assert n.stats.forced_out == 2
    m = Normaliser(RANGES, config=NormaliserConfig(proximity_timeout=None))
    m.feed(raw(0.0))
    assert m.tick(100.0) == []


def test_smoothing_is_a_time_constant_in_ms() -> None:
    n = Normaliser(RANGES, config=NormaliserConfig(smoothing_ms=10.0))
    n.feed(raw(0.0, x=0))
    (s,) = n.feed(raw(0.010, x=1000))
    assert s.x == pytest.approx(1 - math.exp(-1))
    (s,) = n.feed(raw(0.020, x=1000))
    assert s.x == pytest.approx(1 - math.exp(-2))
    off = Normaliser(RANGES)
    off.feed(raw(0.0, x=0))
    assert off.feed(raw(0.010, x=1000))[0].x == 1.0


def test_tool_identity_kept_across_reports_and_proximity() -> None:
    n = Normaliser(RANGES)
    assert n.feed(RawSample(time=0.0, proximity=True, valid=False, tool=Tool.PENCIL,
                            serial=0xABC, tool_id=0x812)) == []
    (s,) = n.feed(raw(0.005))
    assert (s.tool, s.serial, s.tool_id) == (Tool.PENCIL, 0xABC, 0x812)
    (out,) = n.feed(RawSample(time=0.01, proximity=False, valid=False))
    assert (out.tool, out.serial, out.proximity) == (Tool.PENCIL, 0xABC, False)
    (back,) = n.feed(raw(0.5))
    assert (back.tool, back.serial) == (Tool.PENCIL, 0xABC)
    # Flipped to the eraser end in proximity: the pencil leaves first (kernel hid-input
    # releases the old tool in a frame of its own; libinput reports proximity out + in).
    (gone, er) = n.feed(raw(0.505, eraser=True))
    assert (gone.tool, gone.proximity) == (Tool.PENCIL, False)
    assert er.tool is Tool.ERASER and er.proximity and n.stats.tool_changes == 1
    assert [x.seq for x in (s, out, back, gone, er)] == [1, 2, 3, 4, 5]


def test_transform_hook_last_and_device_samples_kept() -> None:
    device: list = []
    n = Normaliser(RANGES, transform=lambda s: s.with_(x=1.0 - s.x),
                   on_device_sample=device.append)
    (s,) = n.feed(raw(0.0, x=250))
    assert s.x == 0.75 and device[0].x == 0.25
    bad = Normaliser(RANGES, transform=lambda s: s.with_(x=s.x + 2.0))
    assert bad.feed(raw(0.0)) == []
    assert bad.stats.rejected == 1 and bad.stats.samples == 0


def test_degenerate_axes_never_crash_or_publish_out_of_range() -> None:
    flat = AxisRanges(x=Axis(5, 5), y=Axis(0, 10), pressure=Axis(0, 0), tilt_x=Axis(0, 0))
    n = Normaliser(flat)
    for i, (x, p) in enumerate([(5, 0), (99999, 99999), (-5, -5)]):
        for s in n.feed(RawSample(time=i * 0.005, proximity=True, x=x, y=-3, pressure=p,
                                  tilt_x=7)):
            assert 0.0 <= s.x <= 1.0 and 0.0 <= s.y <= 1.0 and 0.0 <= s.pressure <= 1.0
            assert -90 <= s.tilt_x <= 90


def test_no_pressure_axis_uses_tip_bit() -> None:
    n = Normaliser(AxisRanges(x=Axis(0, 100), y=Axis(0, 100)))
    a, b = n.feed(raw(0.0, None, tip=False))[0], n.feed(raw(0.005, None, tip=True))[0]
    assert (a.touching, a.pressure, b.touching, b.pressure) == (False, 0.0, True, 1.0)
    assert not n.can_map_mm


def test_time_counts_from_first_report_and_never_goes_back() -> None:
    n = Normaliser(RANGES)
    a = n.feed(raw(1000.25))[0]
    b = n.feed(raw(1000.24))[0]  # a transport glitch
    assert a.t == 0.0 and b.t == 0.0 and n.stats.time_backwards == 1
    with pytest.raises(EventError):
        a.with_(x=float("nan"))


def test_fast_sample_path_equals_the_validating_constructor() -> None:
    fast = Normaliser(RANGES)
    slow = Normaliser(RANGES, config=NormaliserConfig(validate=True))
    raws = [raw(i * 0.005, (i * 37) % 1200, x=(i * 71) % 1300 - 100, y=(i * 13) % 600,
                tilt_x=(i % 128) - 64, tilt_y=(i % 100) - 50, rotation=(i * 9) % 1800 - 900,
                distance=i % 64, wheel=(i * 5) % 1024, buttons=i % 4, serial=i // 50,
                tool_id=0x802)
            for i in range(600)]
    a = [s for r in raws for s in fast.feed(r)]
    b = [s for r in raws for s in slow.feed(r)]
    # the serial changes every 50 reports: each new pen makes the old one leave first
    assert fast.stats.tool_changes == slow.stats.tool_changes == 11
    assert a == b and len(a) == 600 + 11
    assert [s.to_record() for s in a] == [s.to_record() for s in b]


def test_fast_path_still_refuses_bad_values() -> None:
    from station.drivers.normalise import _checked_sample

    good = Normaliser(RANGES).feed(raw(0.0))[0].to_record()
    values = {k: v for k, v in good.items() if k != "type"}
    values.update(rotation=None, distance=None, wheel=None, tool_id=None, seq=1, t_mono=0.0)
    assert _checked_sample(dict(values)).x == 0.5
    for name, bad in (("x", float("nan")), ("y", 1.5), ("pressure", -0.1), ("t", float("inf")),
                      ("tilt_x", 91.0), ("serial", -1)):
        with pytest.raises(EventError):
            _checked_sample({**values, name: bad})
    with pytest.raises(EventError):
        _checked_sample({**values, "proximity": False, "touching": True})


def test_a_tilt_axis_stuck_at_its_minimum_is_absent_not_a_full_slant(
        caplog: pytest.LogCaptureFixture) -> None:
    """The DTK-2241's pen sends tilt bytes of 0 = the axis minimum: the kernel and the
    station used to say -64 degrees, and a brush following tilt painted fully slanted."""
    n = Normaliser(RANGES)
    got = [n.feed(raw(i * 0.005, tilt_x=-64, tilt_y=-64))[0] for i in range(50)]
    assert all(s.tilt_x == 0.0 and s.tilt_y == 0.0 for s in got)
    assert n.stats.absent_axes == ["tilt_x", "tilt_y"]
    said = [r for r in caplog.records if "stays at its minimum" in r.getMessage()]
    assert len(said) == 2  # once per axis, not once per sample
    (s,) = n.feed(raw(0.25, tilt_x=-40, tilt_y=-64))  # it moves after all: a real axis
    assert s.tilt_x == pytest.approx(-40 / 63.5 * 64, abs=1.5) and s.tilt_y == 0.0
    assert n.stats.absent_axes == ["tilt_y"]
    (s,) = n.feed(raw(0.255, tilt_x=-64))
    assert s.tilt_x == -64.0  # once alive, the minimum is a real value
    # an Art Pen barrel that never turned: no rotation, not -180 degrees
    r = Normaliser(RANGES)
    assert [r.feed(raw(i * 0.005, rotation=-900))[0].rotation for i in range(3)] == [None] * 3
    assert r.feed(raw(0.02, rotation=0))[0].rotation == pytest.approx(900 / 1799 * 360 - 180)
