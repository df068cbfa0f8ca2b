"""The kiosk's deferred undo checkpoints: a step copies only what a step writes
(``STEP_FIELDS``), the paper and the dried layers stay shared until a command or a tool
comes, all-zero arrays cost no memory, and undo stays exact (issue 26, item 3)."""

from __future__ import annotations

import io
import json
import threading
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from test_kiosk_latency import _replay as _replay_canvas  # the same 96x64 session replay

from station.backends.factory import make_backend
from station.canvas.palette import default_palette
from station.canvas.state import ARRAY_FIELDS, STEP_FIELDS, CanvasState, quick_npz
from station.events import Command, PenSample, Tool
from station.kiosk.session import KioskSession, frozen_copy, held_bytes
from station.sessionlog import read_session
from station.sim import live as live_mod
from station.sim.live import LiveConfig
from station.sim.player import SessionPlayer
from station.sim.undo import UndoHistory

W, H = 96, 64
STEADY = [n for n in ARRAY_FIELDS if n not in STEP_FIELDS]


def _pen(t: float, x: float, y: float = 0.5, touching: bool = True) -> PenSample:
    return PenSample(t=t, device="p", tool=Tool.PEN, x=x, y=y, pressure=0.8,
                     touching=touching, t_mono=1.0 + t)


def _stroke(t0: float, x0: float, y: float, n: int = 8) -> list[PenSample]:
    out = [_pen(t0 + 0.01 * i, x0 + 0.02 * i, y) for i in range(n)]
    return [*out, _pen(t0 + 0.01 * n, x0 + 0.02 * n, y, touching=False)]


def _cmd(t: float, name: str, **args: Any) -> Command:
    return Command(t=t, cmd=name, args=args)


@pytest.mark.parametrize("backend", ["numpy", "cpu"])
def test_a_step_writes_only_the_step_fields(backend: str) -> None:
    """Every writer a step runs (brush sources, beads, a deformable brush's pick-ups, the
    hair dryer, the kernel) leaves the other arrays bit for bit as they were: what lets
    a checkpoint share them across steps."""
    made, _ = make_backend(backend, W, H, "watercolor", 0)
    canvas: Any = made  # the CPU backends' live_state (the protocol does not say)
    player = SessionPlayer(made, W, H, "watercolor", rate=30.0, pigments=default_palette())
    st = canvas.live_state
    changed: set[str] = set()
    steps = 0
    real_step, real_flush = player.step, player.flush_sources

    def held(fn: Any) -> Any:
        def run(*a: Any, **kw: Any) -> None:
            nonlocal steps
            before = {n: getattr(canvas.live_state, n).copy() for n in ARRAY_FIELDS}
            fn(*a, **kw)
            now = canvas.live_state
            for n in ARRAY_FIELDS:
                if not np.array_equal(getattr(now, n), before[n]):
                    changed.add(n)
            steps += 1
        return run

    player.step = held(real_step)  # type: ignore[method-assign]
    player.flush_sources = held(real_flush)  # type: ignore[method-assign]
    recs: list[PenSample | Command] = [
        _cmd(0.0, "mask", x=0.7, y=0.3, size=10),  # a tool: mask, not during a step
        _cmd(0.01, "brush", size=10, water=1.0, pigment={"French Ultramarine": 0.6}),
        *_stroke(0.05, 0.1, 0.3),
        _cmd(0.4, "hairdryer", x=0.3, y=0.3, seconds=0.3, radius=12),
        _cmd(0.5, "brush", kind="round3d", size=10, water=0.3,
             pigment={"Quinacridone Rose": 0.5}),
        *_stroke(0.55, 0.15, 0.35),
        *_stroke(0.75, 0.2, 0.3),
        _cmd(1.2, "new_layer"),
        _cmd(1.25, "brush", kind="round", size=8, water=1.0, pigment={"Hansa Yellow": 0.6}),
        *_stroke(1.3, 0.1, 0.6),
        _cmd(2.0, "wait", seconds=0.5),
    ]
    player.play(recs)
    player.advance_to(2.6)
    assert steps > 60
    # the writers did run: water, pigment, the dryer's evaporation, pick-ups
    assert {"w", "p", "vx", "evaporated", "removed_w"} <= changed
    assert float(st.mask.sum()) > 0 and float(np.abs(st.r_composed - 1).sum()) > 0
    assert changed <= STEP_FIELDS, sorted(changed - STEP_FIELDS)


def _session(tmp_path: Path) -> KioskSession:
    cfg = LiveConfig(bus=f"ipc://{tmp_path}/bus", width=W, height=H, backend="cpu",
                     status="none", cmd="none", log_path=str(tmp_path / "s.jsonl"),
                     autosave=0)
    return KioskSession(cfg)


def _feed(s: KioskSession, recs: Sequence[PenSample | Command]) -> None:
    """Each record at its time, the due steps first (as the window and the thread do)."""
    for r in recs:
        while s.player.steps_due(r.t) > s.player.counters.steps:
            s.step()
        if isinstance(r, Command):
            s.handle("cmd", r)
        else:
            s.handle("pen", r)


def test_a_step_copies_only_what_it_writes_and_shares_the_paper_and_the_dried_layers(
        tmp_path: Path) -> None:
    s = _session(tmp_path)
    try:
        # a blank sheet's checkpoint costs nothing: every array is zero or shared
        _feed(s, [_cmd(0.0, "brush", size=10, water=1.0, pigment={"Hansa Yellow": 0.6}),
                  *_stroke(0.02, 0.1, 0.4)])
        assert s.checkpoint_bytes_copied == 0
        _feed(s, _stroke(0.2, 0.1, 0.5)[:3])  # a second stroke, over wet paint
        assert len(s._lazy) == 2
        cp = s._lazy[1].cp
        assert cp is not None
        s.step()
        s.step()
        live = s.cpu_state
        # the steps' fields are the checkpoint's own now; the rest is the live canvas's
        for n in STEP_FIELDS:
            assert not np.shares_memory(getattr(cp.state, n), getattr(live, n)), n
        for n in STEADY:
            assert np.shares_memory(getattr(cp.state, n), getattr(live, n)), n
        # nothing was removed yet: those are zero views, no memory
        assert held_bytes(cp.state.removed_p) == held_bytes(cp.state.removed_w) == 0
        assert not cp.state.removed_p.flags.writeable
        plane = W * H * 4
        used = len(cp.state.slots) or 1
        assert 0 < s.checkpoint_bytes_copied <= plane * (6 + 2 * used) + live.tile_ttl.nbytes
        whole = sum(getattr(cp.state, n).nbytes for n in ARRAY_FIELDS)
        assert s.checkpoint_bytes_copied < 0.5 * whole  # r_composed alone is 3-12 planes
        # an undo brings the canvas back exactly, zero views and all
        before = cp.state.copy()
        _feed(s, [*_stroke(0.2, 0.1, 0.5)[3:]])
        s.command("undo")
        assert s.history.undone == 1
        back = s.cpu_state
        assert back.removed_p.flags.writeable and back.removed_p.shape[0] == live.p.shape[0]
        assert np.array_equal(before.h, back.h) and np.array_equal(before.fibre, back.fibre)
    finally:
        s.shutdown()


def _replay(log: Path) -> CanvasState:
    return _replay_canvas(log).state()


def test_undo_across_a_new_layer_and_a_mask_restores_the_dried_layers_exactly(
        tmp_path: Path) -> None:
    """Two strokes share the dried layers; ``new_layer`` writes them in place: first the
    checkpoints get one copy between them; undoing back across the layer gives the
    canvas a session without those strokes would have, bit for bit."""
    s = _session(tmp_path)
    try:
        _feed(s, [_cmd(0.0, "brush", size=10, water=1.0, pigment={"Hansa Yellow": 0.6}),
                  *_stroke(0.02, 0.1, 0.3), *_stroke(0.2, 0.2, 0.6)])
        cps = [e.cp for e in s._lazy]
        assert len(cps) == 2 and all(c is not None for c in cps)
        dried = s.cpu_state.r_composed.copy()
        _feed(s, [_cmd(0.5, "new_layer")])
        live = s.cpu_state
        assert not np.array_equal(live.r_composed, dried)  # the layer was written in
        a, b = (c.state.r_composed for c in cps if c is not None)
        assert a is b and not np.shares_memory(a, live.r_composed)  # one copy for both
        assert np.array_equal(a, dried)
        _feed(s, [_cmd(0.55, "brush", size=8, water=1.0, pigment={"French Ultramarine": 0.5}),
                  *_stroke(0.6, 0.15, 0.45),
                  _cmd(0.8, "mask", x=0.8, y=0.8, size=8),  # a tool dab writes the mask
                  *_stroke(0.85, 0.5, 0.7)])
        for _ in range(3):
            s.step()
        for _ in range(3):  # the last stroke, the mask, the stroke on the new layer
            s.command("undo")
        s.command("undo")  # the second stroke of the first layer, back across new_layer
        s.command("redo")
        s.command("undo")
        for _ in range(2):
            s.step()
        assert s.history.undone == 5 and s.history.redone == 1
        live = s.canvas.state()
    finally:
        s.shutdown()
    replay = _replay(tmp_path / "s.jsonl")
    assert replay.step_count == live.step_count
    for n in ARRAY_FIELDS:
        assert np.array_equal(getattr(replay, n), getattr(live, n)), n
    assert float(live.mask.sum()) == 0.0  # the mask's dab was undone


def test_frozen_copy_is_bit_exact_and_made_in_pieces() -> None:
    a = np.zeros((3, 40, 50), np.float32)
    z = frozen_copy(a)
    assert held_bytes(z) == 0 and z.shape == a.shape and not z.flags.writeable
    a[2, 39, 49] = -0.0  # a negative zero is not all zero bits: copied as it is
    n = [0]

    def pause() -> None:
        n[0] += 1

    c = frozen_copy(a, pause, piece=4096)
    assert np.signbit(c[2, 39, 49]) and held_bytes(c) == a.nbytes
    assert n[0] == a.nbytes // 4096 - (a.nbytes % 4096 == 0) and not np.shares_memory(c, a)
    b = np.random.default_rng(1).random((7, 9)).astype(np.float32)
    assert np.array_equal(frozen_copy(b, pause, piece=12), b)


def test_the_autosave_compresses_and_writes_with_the_lock_released(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A 1920×1080 autosave took seconds under the lock (every pen sample held): now only
    the log's sync and the session's data are taken under it; the canvas is shared, and
    the file still holds the canvas as it was, whatever the pen did meanwhile."""
    cfg = LiveConfig(bus=f"ipc://{tmp_path}/bus", width=W, height=H, backend="cpu",
                     status="none", cmd="none", log_path=str(tmp_path / "s.jsonl"),
                     autosave=0.001)
    s = KioskSession(cfg)
    entered, go = threading.Event(), threading.Event()
    real_write = live_mod.atomic_write

    def gated(*a: Any, **kw: Any) -> None:
        entered.set()
        assert go.wait(20), "the test never let the write go"
        real_write(*a, **kw)

    monkeypatch.setattr(live_mod, "atomic_write", gated)
    try:
        _feed(s, [_cmd(0.0, "brush", size=10, water=1.0, pigment={"Hansa Yellow": 0.6}),
                  *_stroke(0.02, 0.1, 0.4)])
        for _ in range(3):
            s.step()
        assert s.sim.autosave_due()
        live = s.cpu_state
        at_save = {n: getattr(live, n).copy() for n in ARRAY_FIELDS}
        steps = s.player.counters.steps

        def save() -> None:
            with s.lock:
                s._maybe_autosave()

        th = threading.Thread(target=save)
        s._worker = th  # the lock is released only in the simulation thread
        th.start()
        assert entered.wait(20)
        assert s.inflight and not s.kernel_running  # tiles render; commands wait
        done = threading.Event()

        def pen() -> None:
            s.handle("pen", _pen(0.3, 0.5, 0.6))  # a stroke starts during the write
            done.set()

        feeder = threading.Thread(target=pen)
        feeder.start()
        applied = done.wait(10)
        go.set()
        th.join(20)
        feeder.join(20)
        s._worker = None
        assert applied and s.sim.counters.autosaves == 1 and not s.inflight
        # the stroke belongs to the step about to run: its checkpoint is not a mid-step one
        assert not s._mid_step and s.player.counters.steps == steps
        saved = CanvasState.load(s.autosave_path)
        for n in ARRAY_FIELDS:
            assert np.array_equal(getattr(saved, n), at_save[n]), n
    finally:
        go.set()
        s._worker = None
        s.shutdown()


def _eraser(t0: float, x0: float, y: float, n: int = 4) -> list[PenSample]:
    out = [PenSample(t=t0 + 0.01 * i, device="p", tool=Tool.ERASER, x=x0 + 0.02 * i, y=y,
                     pressure=0.8, touching=True, t_mono=1.0) for i in range(n)]
    return [*out, PenSample(t=t0 + 0.01 * n, device="p", tool=Tool.ERASER, x=x0, y=y,
                            pressure=0.0, touching=False, t_mono=1.0)]


def test_checkpoints_between_steady_writes_share_one_copy_of_the_steady_arrays() -> None:
    """A plain player's undo history (``station paint``, an undo's replay) holds one copy
    of the paper, mask, blocking and dried layers for all the checkpoints with no
    command or tool dab between them, and a fresh one after such a write: each checkpoint
    holds exactly the arrays the canvas had when it was taken."""
    made, _ = make_backend("cpu", W, H, "watercolor", 0)
    canvas: Any = made
    player = SessionPlayer(made, W, H, "watercolor", rate=30.0, pigments=default_palette())
    hist = UndoHistory(player, budget=1 << 40)
    taken: list[Any] = []
    real = hist._checkpoint

    def checked() -> Any:
        cp = real()
        live = canvas.live_state
        for n in STEADY:  # what the canvas holds now, shared or not
            assert np.array_equal(getattr(cp.state, n), getattr(live, n)), n
        taken.append(cp)
        return cp

    hist._checkpoint = checked  # type: ignore[method-assign]
    player.play([
        _cmd(0.0, "brush", size=10, water=1.0, pigment={"Hansa Yellow": 0.6}),
        *_stroke(0.02, 0.1, 0.3), *_stroke(0.2, 0.2, 0.6),  # 0, 1: one epoch
        _cmd(0.4, "mask", x=0.8, y=0.2, size=8),  # 2: a dab (a unit; writes the mask)
        _cmd(0.42, "brush", size=10),  # (the brush back in hand)
        *_stroke(0.45, 0.3, 0.4),  # 3
        _cmd(0.6, "brush", size=8, water=1.0, pigment={"French Ultramarine": 0.5}),
        *_stroke(0.65, 0.1, 0.5),  # 4: a brush swap writes nothing steady
        *_eraser(0.85, 0.2, 0.3),  # 5: the eraser's stroke
        *_stroke(1.0, 0.4, 0.6),  # 6
        _cmd(1.2, "new_layer"),
        *_stroke(1.3, 0.2, 0.7),  # 7
        _cmd(1.5, "undo"), _cmd(1.6, "undo"),  # 7, then 6 (across new_layer)
        *_stroke(1.7, 0.5, 0.5)])
    player.advance_to(2.0)
    assert hist.undone == 2 and len(taken) == 9
    first = {c.epoch: c for c in reversed(taken)}  # the first checkpoint of each epoch

    def shares(a: Any, b: Any) -> bool:
        return all(getattr(a.state, n) is getattr(b.state, n) for n in STEADY)

    assert shares(taken[1], taken[0]) and taken[1].epoch == taken[0].epoch
    assert taken[1].epoch == taken[2].epoch != taken[3].epoch  # before the dab, after it
    assert shares(taken[4], taken[3])  # across a brush swap
    assert taken[5].epoch == taken[4].epoch != taken[6].epoch  # the eraser writes
    assert taken[7].epoch != taken[6].epoch  # new_layer wrote the dried layers
    for c in taken:  # one copy per epoch
        assert shares(c, first[c.epoch])
    assert len(first) < len(taken) - 2
    kept = [c for c in (hist._units[u].checkpoint for u in hist._done) if c is not None]
    assert len(kept) == 7 and len({c.epoch for c in kept}) == 3  # 0-2, 3-5, 8
    own = sum(c.nbytes - c.steady_bytes for c in kept)
    assert hist.held_bytes() == own + 3 * kept[0].steady_bytes < sum(c.nbytes for c in kept)


def _replay_with(log: Path, budget: int) -> tuple[CanvasState, UndoHistory]:
    _header, records = read_session(log)
    canvas, _ = make_backend("cpu", W, H, "watercolor", 0)
    player = SessionPlayer(canvas, W, H, "watercolor", rate=30.0, pigments=default_palette())
    hist = UndoHistory(player, budget=budget)
    player.play(records)
    return canvas.state(), hist


def test_the_undo_budget_counts_shared_arrays_once_and_a_replay_lets_the_same_go(
        tmp_path: Path) -> None:
    """At 1920×1080 a checkpoint's own arrays are ~68 MiB but the packed state 270 MiB:
    counted whole, only one or two strokes fitted the 512 MiB budget.  The steady arrays
    of checkpoints with no command or dab between them are counted once, so a budget of
    one whole checkpoint and four checkpoints' own arrays keeps five strokes; a replay of
    the log (a plain player, the same budget) counts the same and undoes the same."""
    s = _session(tmp_path)
    try:
        _feed(s, [_cmd(0.0, "brush", size=10, water=1.0, pigment={"Hansa Yellow": 0.6}),
                  *_stroke(0.02, 0.1, 0.2)])
        cp = s.history._units[s.history._done[0]].checkpoint
        assert cp is not None
        own = cp.nbytes - cp.steady_bytes
        assert cp.steady_bytes > 0.3 * cp.nbytes  # (paper, mask, blocking, dried layers)
        budget = cp.nbytes + 4 * own + own // 2
        s.history.budget = budget  # (the kiosk's is 512 MiB: the same rule)
        _feed(s, [r for i in range(5) for r in _stroke(0.2 + 0.15 * i, 0.1 + 0.05 * i,
                                                       0.3 + 0.1 * i)])
        assert s.history.undo_depth() == 5 and s.history.dropped["budget"] == 1
        assert s.history.held_bytes() <= budget < 3 * cp.nbytes
        for i in range(5):
            _feed(s, [_cmd(1.2 + 0.05 * i, "undo")])
        _feed(s, [_cmd(1.5, "wait", seconds=0.1)])
        assert s.history.undone == 5
        live = s.canvas.state()
    finally:
        s.shutdown()
    replay, hist = _replay_with(tmp_path / "s.jsonl", budget)
    assert hist.undone == 5 and hist.dropped == {"limit": 0, "budget": 1, "records": 0}
    assert replay.step_count == live.step_count
    for n in ARRAY_FIELDS:
        assert np.array_equal(getattr(replay, n), getattr(live, n)), n
    assert float(live.p.sum()) > 0.0  # the first stroke (let go by the budget) is left


def test_a_quick_archive_stores_what_hardly_compresses_and_loads_bit_for_bit(
        tmp_path: Path) -> None:
    """The autosave's archive (``quick_npz``): a 1920×1080 wet canvas's deflate took 8 s,
    most of it on float noise that deflates to 0.8-0.9 of its size (velocities, water,
    pigment): those planes are stored, the rest deflated at level 1."""
    rng = np.random.default_rng(3)
    arrays = {"noise": rng.random((H, W), dtype=np.float32),
              "zero": np.zeros((H, W), np.float32), "steps": np.arange(5000, dtype=np.int64),
              "meta": np.array(json.dumps({"a": [1, 2]}))}
    data = quick_npz(arrays)
    with zipfile.ZipFile(io.BytesIO(data)) as z:
        kinds = {i.filename: i.compress_type for i in z.infolist()}
        sizes = {i.filename: i.compress_size for i in z.infolist()}
    assert kinds["noise.npy"] == zipfile.ZIP_STORED
    assert kinds["zero.npy"] == kinds["steps.npy"] == zipfile.ZIP_DEFLATED
    assert sizes["zero.npy"] < 0.05 * arrays["zero"].nbytes
    path = tmp_path / "a.npz"
    path.write_bytes(data)
    with np.load(path, allow_pickle=False) as back:
        for k, v in arrays.items():
            assert np.array_equal(back[k], v) and back[k].dtype == v.dtype, k
        assert json.loads(str(back["meta"])) == {"a": [1, 2]}
