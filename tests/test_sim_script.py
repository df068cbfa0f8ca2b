"""Scripted pen input: paths, pressure and tilt profiles, the samples a stroke makes."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import pytest

from station.events import Command, PenSample
from station.sessionlog import read_session
from station.sim.script import Script, catmull_rom, swell, taper, tilt_sweep


def test_catmull_rom_passes_through_its_points() -> None:
    pts = [(0.1, 0.2), (0.4, 0.5), (0.7, 0.3), (0.9, 0.8)]
    f = catmull_rom(pts)
    for i, p in enumerate(pts):
        got = f(i / (len(pts) - 1))
        assert got == pytest.approx(p, abs=1e-6)
    # smooth: no jump between neighbouring parameters
    steps = [f(k / 300) for k in range(301)]
    assert max(math.dist(a, b) for a, b in itertools.pairwise(steps)) < 0.01


def test_pressure_and_tilt_profiles() -> None:
    t = taper(0.9, start=0.3, end=0.1, attack=0.2, release=0.25)
    assert t(0.0) == pytest.approx(0.3) and t(0.5) == pytest.approx(0.9)
    assert t(1.0) == pytest.approx(0.1) and t(0.1) == pytest.approx(0.6)  # smoothstep midpoint
    sw = swell(0.2, 1.0, waves=2.0)
    assert sw(0.0) == pytest.approx(0.2) and sw(0.25) == pytest.approx(1.0)
    assert sw(0.5) == pytest.approx(0.2)
    ts = tilt_sweep((20.0, -10.0), (-20.0, 30.0))
    assert ts(0.5) == pytest.approx((0.0, 10.0))


def test_a_stroke_is_hover_touch_samples_lift() -> None:
    s = Script(100, 80, rate_hz=100.0)
    s.brush(size=5, water=0.5, pigment={"Black": 0.5})
    s.line((0.1, 0.5), (0.9, 0.5), duration=0.5, pressure=taper(0.8), tilt=(10.0, 5.0))
    recs = s.records
    assert isinstance(recs[0], Command) and recs[0].args["pigment"] == {"Black": 0.5}
    pens = [r for r in recs if isinstance(r, PenSample)]
    assert not pens[0].touching and pens[0].proximity and pens[0].pressure == 0.0
    assert not pens[-1].touching
    touching = [p for p in pens if p.touching]
    assert len(touching) == 51  # 100 Hz over 0.5 s, both ends
    assert touching[0].x == pytest.approx(0.1) and touching[-1].x == pytest.approx(0.9)
    assert touching[-1].t - touching[0].t == pytest.approx(0.5, abs=1e-3)
    assert all(b.t >= a.t for a, b in itertools.pairwise(recs))
    assert all(b.seq == a.seq + 1 for a, b in itertools.pairwise(pens))
    assert {(p.tilt_x, p.tilt_y) for p in pens} == {(10.0, 5.0)}
    assert max(p.pressure for p in touching) == pytest.approx(0.8)


def test_arc_and_dab_and_commands_round_trip(tmp_path: Path) -> None:
    s = Script(64, 64, seed=9, sim_rate=40.0)
    s.arc((0.5, 0.5), (0.25, 0.25), 0.0, 180.0, duration=0.3, pressure=0.6)
    s.dab((0.2, 0.2))
    s.wait(1.5)
    s.pause(0.25)
    s.new_layer()
    s.profile("ink")
    s.dry()
    s.clear()
    path = tmp_path / "s.jsonl"
    s.save(path)
    assert path.read_text() == s.text()
    header, records = read_session(path)
    assert (header.width, header.seed, header.extra["sim"]) == (64, 9, {"rate": 40.0})
    pens = [r for r in records if isinstance(r, PenSample) and r.touching]
    # the arc: every sample on the circle, from angle 0 to 180 degrees (y down)
    arc = [p for p in pens if (p.x, p.y) != (0.2, 0.2)]
    assert len(pens) - len(arc) == 7  # the dab: 0.05 s at 120 Hz, both ends
    for p in arc:
        assert math.hypot(p.x - 0.5, p.y - 0.5) == pytest.approx(0.25, abs=1e-4)
    assert (arc[0].x, arc[-1].x) == (pytest.approx(0.75), pytest.approx(0.25))
    assert all(p.y >= 0.5 - 1e-9 for p in arc)
    cmds = [(r.cmd, r.args) for r in records if isinstance(r, Command)]
    assert cmds == [("wait", {"seconds": 1.5}), ("new_layer", {}), ("profile", {"name": "ink"}),
                    ("dry", {}), ("clear", {})]
    new_layer_t = next(r.t for r in records if isinstance(r, Command) and r.cmd == "new_layer")
    wait_t = next(r.t for r in records if isinstance(r, Command) and r.cmd == "wait")
    assert new_layer_t - wait_t == pytest.approx(0.25)  # pause lets time pass, wait does not


def test_positions_are_clamped_and_rounded() -> None:
    s = Script(64, 64)
    s.line((-0.2, 0.5), (1.3, 0.123456789), duration=0.1)
    pens = [r for r in s.records if isinstance(r, PenSample)]
    assert min(p.x for p in pens) == 0.0 and max(p.x for p in pens) == 1.0
    assert all(round(p.y, 5) == p.y for p in pens)
