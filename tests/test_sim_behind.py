"""A live simulation behind its rate (``LiveCore._compressed``): the samples that arrive
while a step runs belong to the next step's slot; their device times span the step's wall
time, longer than the slot. Clamped into the slot they all took its last instant, so a
step's stamps landed at once (issue 21 item 8's arcs at a busy kiosk; a dry tuft's speed
unknown). Now they keep their spacing, scaled into the slot. A process that keeps up logs
what it always did."""

from __future__ import annotations

import itertools
from pathlib import Path

from station.events import PenSample, Tool
from station.sim.live import LiveCore
from station.sim.live_config import LiveConfig

RATE = 40.0  # a slot: 25 ms


def _run(tmp_path: Path, wall_per_step: float, steps: int = 10
         ) -> dict[int, list[float]]:
    """Steps that each take ``wall_per_step`` s of a fake wall clock; a 200 Hz pen's
    samples arrive as they are made; returns the logged times per step they precede."""
    core = LiveCore(LiveConfig(bus=None, width=40, height=32, backend="numpy", rate=RATE,
                               log_path=str(tmp_path / "s.jsonl"), autosave=0))
    clock = [0.0]
    core.now = lambda: clock[0]  # type: ignore[method-assign]
    logged: dict[int, list[float]] = {}
    apply = core.player.apply

    def spy(rec: object) -> None:
        if isinstance(rec, PenSample):
            logged.setdefault(core.player.counters.steps, []).append(rec.t)
        apply(rec)  # type: ignore[arg-type]

    core.player.apply = spy  # type: ignore[method-assign,assignment]
    per = round(wall_per_step / 0.005)
    for i in range(steps):
        clock[0] = wall_per_step * (i + 1)  # step i is due at (i + 1) / RATE
        core.step()
        for j in range(per):
            clock[0] = wall_per_step * (i + 1) + 0.005 * j + 0.0025
            core.feed_sample(PenSample(t=clock[0], device="d", tool=Tool.PEN,
                                       x=0.1 + 0.002 * (i * per + j), y=0.5, pressure=0.6,
                                       touching=True, seq=i * per + j + 1))
    return logged


def test_a_slot_behind_keeps_its_samples_spacing(tmp_path: Path) -> None:
    slot = 1.0 / RATE
    logged = _run(tmp_path, 0.1)  # a step takes four slots of wall time
    for k in range(3, 10):
        ts = logged[k]
        assert len(ts) == 20
        lo, hi = k * slot, (k + 1) * slot
        assert all(lo - 1e-6 <= t < hi for t in ts), (k, ts)
        assert len(set(ts)) == len(ts), (k, ts)  # before: 20 samples on one instant
        assert max(ts) - min(ts) >= 0.7 * slot, (k, ts)
        gaps = [b - a for a, b in itertools.pairwise(ts)]
        assert max(gaps) <= 2.5 * min(gaps), (k, gaps)  # evenly, as they were made


def test_a_sim_that_keeps_up_logs_the_devices_times(tmp_path: Path) -> None:
    logged = _run(tmp_path, 1.0 / RATE)
    for k in range(2, 10):
        ts = logged[k]
        assert len(ts) == 5
        assert all(abs(t - k / RATE - 0.005 * j - 0.0025) < 2e-6
                   for j, t in enumerate(ts)), (k, ts)
