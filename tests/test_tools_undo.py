"""Undo and redo under a live simulation (issue 14, item 7): checkpoints + replay give the
canvas as it would be had the stroke never been made, bit for bit."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from station.backends.factory import create_backend, numba_available
from station.canvas.state import CanvasState
from station.cli import main
from station.events import Command, PenSample
from station.sim.player import SessionPlayer
from station.sim.undo import UndoHistory

W, H = 40, 32
PIGMENTS = ("French Ultramarine", "Hansa Yellow", "Quinacridone Rose", "Burnt Umber")
FIELDS = ("w", "wc", "vx", "vy", "p", "q", "evaporated", "removed_w", "removed_p", "block",
          "mask", "tile_ttl")


def pen(t: float, x: float, y: float, touching: bool = True) -> PenSample:
    return PenSample(t=t, device="d", tool="pen", x=x, y=y,  # type: ignore[arg-type]
                     pressure=0.9 if touching else 0.0, touching=touching)


def stroke(k: int) -> list[PenSample | Command]:
    """Stroke k: a brush change (stays), hovering (stays) and the stroke itself (a unit)."""
    t = 0.3 * k
    y = 0.2 + 0.2 * k
    return [Command(t=t, cmd="brush", args={"size": 8, "pigment": {PIGMENTS[k]: 0.6}}),
            pen(t + 0.01, 0.1, y, touching=False),
            pen(t + 0.02, 0.15, y), pen(t + 0.1, 0.5, y + 0.05), pen(t + 0.2, 0.85, y),
            pen(t + 0.21, 0.85, y, touching=False)]


def session(skip: set[int] = frozenset(), dab: bool = True) -> list[PenSample | Command]:
    out: list[PenSample | Command] = []
    for k in range(4):
        recs = stroke(k)
        out += recs[:2] if k in skip else recs
    if dab and 4 not in skip:  # a tissue dab as a command: a unit too
        out.append(Command(t=1.25, cmd="tissue", args={"x": 0.5, "y": 0.45, "size": 10}))
    out.append(Command(t=1.28, cmd="brush", args={"size": 8}))  # puts the tissue down
    return out


def run(records: list[PenSample | Command], backend: str = "numpy", history: bool = False,
        end: float = 2.0, limit: int = 20) -> SessionPlayer:
    b = create_backend(backend, W, H, seed=5)
    p = SessionPlayer(b, W, H)
    if history:
        UndoHistory(p, limit=limit)
    p.play(records)
    p.advance_to(end)
    p.flush_sources()
    return p


def same(a: SessionPlayer, b: SessionPlayer) -> None:
    sa, sb = a.backend.state(), b.backend.state()
    assert sa.step_count == sb.step_count and sa.slots == sb.slots
    for name in FIELDS:
        assert getattr(sa, name).tobytes() == getattr(sb, name).tobytes(), name


def undo_at(t: float, n: int = 1) -> list[Command]:
    return [Command(t=t, cmd="undo", args={}) for _ in range(n)]


@pytest.mark.parametrize("backend", ["numpy", "cpu"])
def test_undo_of_strokes_of_any_age_is_bit_identical(backend: str) -> None:
    if backend == "cpu" and not numba_available():
        pytest.skip("numba missing")
    # the newest unit (the tissue dab), then strokes 3, 2, 1 (the oldest but one)
    for n, skip in ((1, {4}), (2, {4, 3}), (4, {4, 3, 2, 1})):
        undone = run(session() + undo_at(1.6, n), backend, history=True)
        never = run(session(skip), backend)
        same(undone, never)
        assert undone.history.undone == n
        full = run(session(), backend).backend.state()
        assert not np.array_equal(undone.backend.state().p, full.p)


def test_redo_restores_the_stroke_exactly() -> None:
    recs = session() + undo_at(1.5, 2) + [Command(t=1.55, cmd="redo", args={}),
                                          Command(t=1.6, cmd="redo", args={})]
    same(run(recs, history=True), run(session()))
    # redo after undo and a new stroke: the redo stack is gone
    p = run(session() + undo_at(1.5) + [pen(1.6, 0.2, 0.9), pen(1.62, 0.2, 0.9, False),
                                        Command(t=1.7, cmd="redo", args={})], history=True)
    assert p.history.redone == 0 and p.counters.skipped_commands.get("redo") == 1


def test_undo_limit_bounds_memory() -> None:
    p = run(session() + undo_at(1.6, 4), history=True, limit=2)
    h = p.history
    assert h.undone == 2 and not h.can_undo()
    assert p.counters.skipped_commands.get("undo") == 2
    same(p, run(session({4, 3})))
    st = h.status()
    assert st["redo_depth"] == 2 and st["limit"] == 2 and 0 < st["bytes"] <= 2 * (
        W * H * 4 * (13 + 3 * 8))


def test_undo_during_the_live_paint_keeps_the_paint_moving() -> None:
    # wet strokes keep flowing after the undo: the later stroke is simulated as it
    # would have been without the first one (not pasted from a picture)
    with_undo = run(session(dab=False) + undo_at(1.2, 4), history=True, end=3.0)
    never = run(session({0, 1, 2, 3}, dab=False), end=3.0)
    same(with_undo, never)


def test_logged_undo_replays_bit_identically(tmp_path: Path) -> None:
    recs = session() + undo_at(1.6, 2)
    log = tmp_path / "undo.jsonl"
    lines = [json.dumps({"format": "station-session", "version": 1,
                         "canvas": {"width": W, "height": H}, "profile": "watercolor",
                         "seed": 5})]
    for r in recs:
        if isinstance(r, PenSample):
            lines.append(json.dumps({"type": "pen", "t": r.t, "device": "d", "tool": "pen",
                                     "x": r.x, "y": r.y, "pressure": r.pressure,
                                     "proximity": True, "touching": r.touching}))
        else:
            lines.append(json.dumps({"type": "cmd", "t": r.t, "cmd": r.cmd, "args": r.args}))
    log.write_text("\n".join(lines) + "\n")
    out = tmp_path / "o.png"
    state = tmp_path / "s.npz"
    assert main(["paint", str(log), "-o", str(out), "--backend", "numpy", "--state",
                 str(state)]) == 0
    got = CanvasState.load(state)
    want = run(session({4, 3}), end=recs[-1].t).backend.state()
    assert got.step_count == want.step_count
    for name in FIELDS:
        assert getattr(got, name).tobytes() == getattr(want, name).tobytes(), name


def test_live_core_offers_undo_to_the_kiosk(tmp_path: Path) -> None:
    from station.sim.live import LiveConfig, LiveCore

    core = LiveCore(LiveConfig(bus=None, width=W, height=H, backend="numpy",
                               log_path=str(tmp_path / "live.jsonl"), autosave=0))
    assert not core.history.can_undo()
    core.player.advance_to(0.1)
    for r in stroke(0)[2:]:
        core.player.apply(r)
    assert core.history.can_undo() and core.status()["undo"]["undo_depth"] == 1
    assert core.feed_command(Command(t=0.0, cmd="undo", args={}))
    assert not core.history.can_undo() and core.history.can_redo()
    assert not core.player.backend.state().p.any()
    core.finish()
