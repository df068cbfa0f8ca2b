"""A bus flood leaves the sim's memory flat (issue 25 item 3): the undo history keeps
at most its record cap, the bus subscriber a bounded table of streams, and every
sample is accounted for (painted, dropped by the flood gate, or refused: counted)."""

from __future__ import annotations

import time
import tracemalloc
from pathlib import Path

import pytest

from station.events import Command, PenSample, Tool
from station.sim.live import LiveConfig, LiveCore
from station.sim.undo import UndoHistory


def _core(tmp_path: Path) -> LiveCore:
    core = LiveCore(LiveConfig(bus=None, width=24, height=16, backend="numpy", rate=40.0,
                               log_path=str(tmp_path / "s.jsonl"), autosave=0.0))
    core.flood_rate, core.flood_burst = 1e9, 1e9  # all of it reaches the undo history
    return core


def test_an_endless_stroke_keeps_the_undo_history_at_its_cap(tmp_path: Path) -> None:
    core = _core(tmp_path)
    cap = 1000
    hist = UndoHistory(core.player, max_records=cap)
    core.history = hist
    n = 12_000  # 12x the cap: one stroke that never lifts (a flooding "pen")
    sizes: list[int] = []
    tracemalloc.start()
    try:
        for i in range(n):
            core.handle("pen", PenSample(t=i * 1e-4, device="flood", tool=Tool.PEN,
                                         x=0.3 + 0.4 * (i % 97) / 97, y=0.5, pressure=0.5,
                                         proximity=True, touching=True, seq=i + 1))
            if i % 200 == 199:
                core.step()
            if i % 1000 == 999:
                sizes.append(len(hist._recs))
            if i == 3000:
                mem_early = tracemalloc.get_traced_memory()[0]
        mem_late = tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
    c = core.counters
    # every sample is accounted for: painted, or dropped by the gate, or refused
    assert c.samples + c.flood_dropped + c.bad_samples == n, c
    assert c.samples == n  # the gate is open here: all painted, all in the history first
    # 9,000 samples more than at i=3000 hold no more memory (uncapped, as on main: 3.7 MB more)
    assert mem_late - mem_early < 1_000_000, (mem_early, mem_late)
    assert max(sizes) <= cap and len(hist._unit_of) <= cap and len(hist._order) <= cap, sizes
    st = hist.status()
    assert st["records"] + st["forgotten_records"] == n, st  # none lost uncounted
    assert st["let_go"]["records"] >= 1 and st["undo_depth"] == 0, st
    # the undo that is no longer possible says so, and why
    core.feed_command(Command(t=0.0, cmd="undo", args={}))
    assert "nothing left to undo" in hist.last and f"{cap} records" in hist.last, hist.last
    assert core.player.counters.skipped_commands.get("undo") == 1
    core.journal.sync()
    lines = (tmp_path / "s.jsonl").read_text().splitlines()
    assert sum('"type": "pen"' in ln or '"type":"pen"' in ln for ln in lines) == n


def test_strokes_beyond_the_cap_let_the_oldest_go_and_newer_ones_still_undo(
        tmp_path: Path) -> None:
    core = _core(tmp_path)
    hist = UndoHistory(core.player, max_records=400)
    core.history = hist
    t = 0.0
    for stroke in range(40):  # 40 strokes of 30 samples: 1200 records, cap 400
        for i in range(30):
            t += 1e-3
            core.handle("pen", PenSample(t=t, device="pen", tool=Tool.PEN, x=0.2 + i / 60,
                                         y=0.2 + stroke / 60, pressure=0.6, proximity=True,
                                         touching=i < 29, seq=stroke * 30 + i + 1))
        core.step()
        assert len(hist._recs) <= 400
    st = hist.status()
    assert st["let_go"]["records"] >= 1 and 1 <= st["undo_depth"] <= 20, st
    assert st["records"] + st["forgotten_records"] == 1200, st
    assert hist.undo() and hist.last.startswith("undone")  # the newest still undoes


def test_the_bus_subscriber_follows_a_bounded_number_of_streams(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from station.bus import Publisher, Subscriber, pubsub

    monkeypatch.setattr(pubsub, "MAX_STREAMS", 64)
    ep = f"ipc://{tmp_path}/flood.sock"
    with Subscriber("@" + ep, topics=("status",)) as sub, \
            Publisher(">" + ep, replay=False) as pub:
        deadline = time.monotonic() + 30
        while not pub.wait_for_subscribers(1, timeout=0.05):
            sub.recv(0)  # a bound socket takes its new peer when its thread looks
            assert time.monotonic() < deadline
        n = 500  # topics an attacker names: one stream each
        for k in range(n):
            pub.publish_status({"k": k}, topic=f"status.x{k}")
        got, deadline = 0, time.monotonic() + 30
        while got < n and time.monotonic() < deadline:
            if sub.recv(100) is not None:
                got += 1
        assert got == n
        assert len(sub._last) <= 64 and sub.stats.streams_forgotten == n - 64
        assert len(sub.stats.started_at) <= pubsub.MAX_STARTED_AT
        assert sub.stats.as_dict()["streams_forgotten"] == n - 64


def test_samples_still_queued_when_the_sim_stops_are_counted(tmp_path: Path) -> None:
    from station.bus import Publisher
    from station.sim.live_bus import LiveSim

    bus = f"ipc://{tmp_path}/bus"
    with Publisher("@" + bus, replay=False) as pub:
        sim = LiveSim(LiveConfig(bus=bus, width=16, height=16, backend="numpy",
                                 log_path=str(tmp_path / "s.jsonl"), status="none",
                                 autosave=0.0, cmd="none"))
        try:
            deadline = time.monotonic() + 60
            while not pub.wait_for_subscribers(1, timeout=0.05):
                sim.sub.sock.poll(0)  # the connecting sim's subscription goes out
                assert time.monotonic() < deadline
            n = 300  # the sim's loop never runs: all of them wait in its queue
            for i in range(n):
                pub.publish_pen(PenSample(t=i * 1e-3, device="pen", tool=Tool.PEN, x=0.5,
                                          y=0.5, pressure=0.5, proximity=True,
                                          touching=True, seq=i + 1))
            while sim.counters.unread_at_stop < n and time.monotonic() < deadline:
                sim._count_unread()  # what shutdown does, until all of it has arrived
        finally:
            final = sim.shutdown()
    assert final["unread_at_stop"] == n and final["samples"] == 0, final


def test_refused_curve_keys_are_named_up_to_a_bound(tmp_path: Path) -> None:
    """Any client may try any key: the table of refused keys stays bounded, every
    refusal is still counted."""
    import secrets

    from station.bus import keys as bus_keys

    (tmp_path / "authorized").mkdir()
    check = bus_keys.KeyCheck(tmp_path / "authorized")
    n = 400
    for _ in range(n):
        assert check.callback("d", secrets.token_hex(20).encode()) is False
    assert len(check.rejected) == bus_keys.MAX_REJECTED_KEYS
    assert check.refused == n and check.unnamed == n - bus_keys.MAX_REJECTED_KEYS
