"""Pen handling as libinput does it (issue 8, item 6) — part of the fault matrix.

* libinput's forced proximity-out timer (evdev-tablet.c / the tablet proximity
  timer plugin): 50 ms after the last event, but re-armed while the tool touches
  or a button is held, and unloaded for good once the device sends a real
  proximity-out.  A 200 ms USB or Bluetooth stall mid-stroke keeps one stroke.
* A tip switch rules contact: its first contact sample is never dropped for a
  pressure under the hysteresis threshold; the pressure grows from 0 there.
* Device → canvas mapping keeps the tablet's aspect ratio by default: a circle
  on the tablet paints a circle (``--mapping stretch`` fills the canvas instead).
"""

from __future__ import annotations

import math
from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest
from station.drivers import synth
from station.drivers.normalise import Normaliser, NormaliserConfig
from station.drivers.raw import Axis, AxisRanges, RawSample
from station.drivers.traces.replay import iter_trace_samples

from station.cli import main
from station.events import Button, PenSample

RANGES = AxisRanges(x=Axis(0, 1000, 10.0), y=Axis(0, 500, 10.0), pressure=Axis(0, 1000))


def strokes(samples: list[PenSample]) -> int:
    """Contact runs: a stroke starts at every touching sample after a non-touching one."""
    first = 1 if samples and samples[0].touching else 0
    return first + sum(1 for a, b in pairwise(samples) if b.touching and not a.touching)


def graphire_stroke_with_stall(bluetooth: bool, stall: float = 0.2) -> synth.RecordedDevice:
    """Hover, a 40-report stroke that stalls ``stall`` s after its 20th report, hover, out."""
    reports: list[tuple[float, bytes]] = []
    t = 0.0
    for i in range(50):
        touching = 5 <= i < 45
        reports.append((t, synth.graphire_report(2000 + 150 * i, 6000, 300 if touching else 0,
                                                 tip=touching, bluetooth=bluetooth)))
        t += stall if i == 24 else 0.01  # the stall: nothing arrives for 200 ms
    reports.append((t, synth.graphire_report(0, 0, prox=False, bluetooth=bluetooth)))
    return synth.RecordedDevice("Wacom Graphire", 0x056A, 0x0081,
                                synth.wacom_protocol_descriptor(7), reports,
                                bus=5 if bluetooth else 3)


@pytest.mark.parametrize("bus", ["usb", "bluetooth"])
def test_200ms_stall_mid_stroke_keeps_one_stroke(bus: str, tmp_path: Path) -> None:
    path = tmp_path / f"stall-{bus}.hid"
    synth.write_hid_recorder([graphire_stroke_with_stall(bus == "bluetooth")], path)
    samples = list(iter_trace_samples(path))
    assert strokes(samples) == 1
    touching = [s for s in samples if s.touching]
    assert len(touching) == 40  # every contact report became a sample, none lost
    assert [s.proximity for s in samples].count(False) == 1  # only the real out, at the end
    assert not samples[-1].proximity
    gaps = [b.t - a.t for a, b in pairwise(touching)]
    assert max(gaps) == pytest.approx(0.2)  # the stall is inside the one stroke


def live_feed(n: Normaliser, raws: list[RawSample], tick_every: float = 0.005
              ) -> list[PenSample]:
    """Feed raw samples as a live driver does: tick() while no report arrives."""
    out: list[PenSample] = []
    for a, b in pairwise([*raws, None]):
        out += n.feed(a)
        if b is None:
            break
        t = a.time + tick_every
        while t < b.time:
            out += n.tick(t)
            t += tick_every
    return out


def raw(t: float, p: int = 0, **kw: object) -> RawSample:
    args: dict[str, object] = dict(time=t, proximity=True, x=500, y=250, pressure=p)
    args.update(kw)
    return RawSample(**args)  # type: ignore[arg-type]


def test_the_timer_is_rearmed_while_touching_or_a_button_is_held() -> None:
    n = Normaliser(RANGES, config=NormaliserConfig(worn_nib=False))
    times = [0.0, 0.01, 0.02, 0.22, 0.23]  # 200 ms of silence after 0.02
    touching = live_feed(n, [raw(t, 500) for t in times])
    assert [s.touching for s in touching] == [True] * 5 and n.stats.forced_out == 0
    # hovering with the barrel button held: re-armed as well
    held = live_feed(n, [raw(1.0 + t, 0, buttons=int(Button.STYLUS)) for t in times])
    assert all(s.proximity for s in held) and n.stats.forced_out == 0
    # hovering, nothing held: the 50 ms timeout forces the tool out (then back in)
    hover = live_feed(n, [raw(2.0 + t, 0) for t in times])
    assert [s.proximity for s in hover] == [True, True, True, False, True, True]
    assert n.stats.forced_out == 1
    assert hover[3].t == pytest.approx(2.02 + 0.05)


def test_a_real_proximity_out_unloads_the_timer() -> None:
    n = Normaliser(RANGES)
    n.feed(raw(0.0))
    (out,) = n.feed(RawSample(time=0.01, proximity=False, valid=False))  # the device says so
    assert not out.proximity
    samples = live_feed(n, [raw(1.0), raw(1.01), raw(1.3), raw(1.31)])  # a 290 ms hover gap
    assert all(s.proximity for s in samples) and n.stats.forced_out == 0


def test_tip_switch_rules_contact_and_pressure_grows_from_zero() -> None:
    n = Normaliser(RANGES, config=NormaliserConfig(worn_nib=False))
    # the first contact report carries 2 % pressure, under the 5 % hysteresis threshold
    got = [n.feed(raw(0.01 * i, p, tip=tip))[0] for i, (p, tip) in
           enumerate([(0, False), (20, True), (40, True), (80, True), (30, True), (10, False)])]
    assert [s.touching for s in got] == [False, True, True, True, True, False]
    assert [s.pressure for s in got] == pytest.approx([0.0, 0.02, 0.04, 0.08, 0.03, 0.0])
    # without a tip switch the pressure is 0 at the down threshold and grows continuously
    m = Normaliser(RANGES, config=NormaliserConfig(worn_nib=False))
    p = [m.feed(raw(0.01 * i, v))[0] for i, v in enumerate([49, 50, 51, 60])]
    assert [s.touching for s in p] == [False, True, True, True]
    assert [s.pressure for s in p] == pytest.approx([0.0, 0.0, 1 / 950, 10 / 950])


def circle_raws(ranges: AxisRanges, radius_mm: float, n: int = 72) -> list[RawSample]:
    cx, cy = ranges.x.span / 2, ranges.y.span / 2
    rx, ry = ranges.x.resolution or 1.0, ranges.y.resolution or 1.0
    return [RawSample(time=0.01 * i, proximity=True, tip=True, pressure=500,
                      x=round(cx + radius_mm * rx * math.cos(a)),
                      y=round(cy + radius_mm * ry * math.sin(a)))
            for i, a in enumerate(np.linspace(0, 2 * math.pi, n, endpoint=False))]


@pytest.mark.parametrize("canvas", [(800, 600), (600, 800), (1920, 1080)])
def test_fit_maps_a_circle_on_the_tablet_to_a_circle_on_the_canvas(canvas: tuple[int, int]
                                                                   ) -> None:
    # 224 x 140 mm with different x/y resolutions (Intuos-Pro-like, 1.6:1)
    ranges = AxisRanges(x=Axis(0, 44800, 200.0), y=Axis(0, 14000, 100.0),
                        pressure=Axis(0, 1000))
    w, h = canvas

    def radii(mapping: str) -> tuple[float, float, tuple[float, float]]:
        n = Normaliser(ranges, config=NormaliserConfig(mapping=mapping, canvas=canvas))
        pts = np.array([(s.x * w, s.y * h) for r in circle_raws(ranges, 50.0)
                        for s in n.feed(r)])
        centre = pts.mean(axis=0)
        return (float(np.ptp(pts[:, 0])) / 2, float(np.ptp(pts[:, 1])) / 2,
                (float(centre[0]), float(centre[1])))

    rx, ry, centre = radii("fit")
    assert rx == pytest.approx(ry, rel=0.003)  # a circle
    assert centre == pytest.approx((w / 2, h / 2), abs=0.5)  # centred
    sx, sy, _ = radii("stretch")
    assert sx / sy == pytest.approx((w / h) / 1.6, rel=0.003)  # stretched by the aspect ratio
    # the whole tablet inside the canvas, touching two opposite sides
    n = Normaliser(ranges, config=NormaliserConfig(mapping="fit", canvas=canvas))
    corners = [n.feed(RawSample(time=0.01 * i, proximity=True, x=x, y=y, pressure=0))[0]
               for i, (x, y) in enumerate([(0, 0), (44800, 14000)])]
    span = (corners[1].x - corners[0].x) * w, (corners[1].y - corners[0].y) * h
    assert span[0] / span[1] == pytest.approx(1.6)
    assert max(span[0] / w, span[1] / h) == pytest.approx(1.0)


def test_station_paint_of_a_traced_circle_paints_a_round_ring(tmp_path: Path) -> None:
    """End to end: an Intuos Pro M (1.6:1) trace of a circle, painted on 4:3."""
    mx, my = 44704, 27940
    reports = [(0.0, synth.intuos_prox_in(0x802, 0x1234))]
    for i, a in enumerate(np.linspace(0, 2 * math.pi, 120)):
        x, y = round(mx / 2 + 0.3 * my * math.cos(a)), round(my / 2 + 0.3 * my * math.sin(a))
        reports.append((0.005 + 0.008 * i, synth.intuos_pen(x, y, 1500, distance=0)))
    reports.append((1.0, synth.intuos_prox_out()))
    dev = synth.RecordedDevice("Wacom Intuos Pro M", 0x056A, 0x0315,
                               synth.wacom_protocol_descriptor(9), reports)
    trace = tmp_path / "circle.hid"
    synth.write_hid_recorder([dev], trace)
    aspect = {}
    for mapping in ("fit", "stretch"):
        state = tmp_path / f"{mapping}.npz"
        rc = main(["paint", str(trace), "-o", str(tmp_path / f"{mapping}.png"), "--size",
                   "160x120", "--backend", "numpy", "--mapping", mapping, "--state",
                   str(state)])
        assert rc == 0
        with np.load(state) as st:
            painted = np.argwhere(st["w"] > 0)  # the water the brush put down
        assert len(painted) > 50
        (y0, x0), (y1, x1) = painted.min(axis=0), painted.max(axis=0)
        aspect[mapping] = (x1 - x0 + 1) / (y1 - y0 + 1)
    assert aspect["fit"] == pytest.approx(1.0, abs=0.08)
    assert aspect["stretch"] == pytest.approx((4 / 3) / 1.6, abs=0.08)  # an ellipse
