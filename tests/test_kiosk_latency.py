"""Kiosk latency parts: the simulation thread (replays exactly), deferred undo checkpoints,
pen prediction, damage-rectangle compositing, and the latency bench's JSON."""

from __future__ import annotations

import json
import math
import os
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from station.brush import sources as sources_mod
from station.canvas.palette import default_palette
from station.canvas.state import STEP_FIELDS, CanvasState
from station.events import PenSample, Tool
from station.kiosk.compose import Compositor, canvas_box, union
from station.kiosk.niced import NicedRunner
from station.kiosk.predict import (
    PenPredictor,
    PredictConfig,
    perceived_lag,
    prediction_errors,
)
from station.kiosk.session import KioskSession
from station.kiosk.views import Viewport, make_camera
from station.sessionlog import read_session
from station.sim import journal as journal_mod
from station.sim.live import LiveConfig
from station.sim.paint import make_backend
from station.sim.player import SessionPlayer
from station.sim.undo import UndoHistory

W, H = 96, 64


class _Gate:
    """The canvas backend, its step held until the test opens the gate."""

    def __init__(self, backend: Any) -> None:
        self._backend = backend
        self.entered = threading.Event()
        self.open = threading.Event()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._backend, name)

    def step(self, *a: Any, **kw: Any) -> None:
        self.entered.set()
        assert self.open.wait(20), "the test never opened the gate"
        self._backend.step(*a, **kw)


def _egl_context() -> Any:
    """A headless EGL context (moderngl is an optional extra), or skip: no EGL here."""
    try:
        import moderngl

        return moderngl.create_context(standalone=True, backend="egl")  # type: ignore[arg-type]
    except Exception as exc:
        pytest.skip(f"no EGL context: {exc}")


def _session(tmp_path: Path) -> KioskSession:
    cfg = LiveConfig(bus=f"ipc://{tmp_path}/bus", width=W, height=H, backend="cpu",
                     status="none", cmd="none", log_path=str(tmp_path / "s.jsonl"),
                     autosave=0)
    return KioskSession(cfg)


def _pen(i: int, x: float, touching: bool = True) -> PenSample:
    return PenSample(t=0.005 * i, device="p", tool=Tool.PEN, x=x, y=0.5, pressure=0.8,
                     touching=touching, t_mono=1.0 + i)


def _step_in_thread(s: KioskSession, gate: _Gate) -> threading.Thread:
    """One step as the simulation thread runs it (lock held, released for the kernel),
    stopped in its kernel until ``gate.open``."""
    def one() -> None:
        with s.lock:
            s._step_unlocked()

    gate.entered.clear()
    gate.open.clear()
    th = threading.Thread(target=one)
    th.start()
    assert gate.entered.wait(20)
    return th


def _replay(log: Path) -> Any:
    _header, records = read_session(log)
    canvas, _ = make_backend("cpu", W, H, "watercolor", 0)
    player = SessionPlayer(canvas, W, H, "watercolor", rate=30.0, pigments=default_palette())
    UndoHistory(player)
    player.play(records)
    return canvas


@pytest.mark.parametrize("kind", ["round", "round3d"])
def test_samples_applied_while_a_step_runs_replay_exactly(tmp_path: Path, kind: str) -> None:
    s = _session(tmp_path)
    real = s.player.backend
    gate = _Gate(real)
    s.player.backend = gate
    try:
        s.command("brush", kind=kind, size=8, water=1.0,
                  pigment={"French Ultramarine": 0.5})
        k = 0
        for stroke in range(3):
            for _ in range(4 if stroke < 2 else 0):  # between steps: the lock is free
                s.handle("pen", _pen(k, 0.2 + 0.01 * k))
                k += 1
            th = _step_in_thread(s, gate)  # the last stroke starts during the kernel
            assert s.inflight
            before = s.samples_during_steps
            for _ in range(5):  # during the kernel: brush samples go straight on
                s.handle("pen", _pen(k, 0.2 + 0.01 * k))
                k += 1
            assert s.samples_during_steps == before + 5
            # a command waits for the kernel: it is applied only after the gate opens
            done = threading.Event()

            def dry(done: threading.Event = done) -> None:
                s.command("dry")
                done.set()

            waiter = threading.Thread(target=dry)
            if stroke == 0:  # (then wet paint again, under the last stroke)
                waiter.start()
                assert not done.wait(0.3)  # held while the kernel runs
            gate.open.set()
            th.join(20)
            if stroke == 0:  # (then wet paint again, under the last stroke)
                assert done.wait(120)  # (a cold numba cache compiles dry first)
                waiter.join()
            s.handle("pen", _pen(k, 0.2 + 0.01 * k, touching=False))  # the stroke ends
            k += 1
            with s.lock:  # a step between strokes (the gate is open)
                s.step()
        # undoes the last stroke, from the checkpoint finished after the kernel it began in
        s.command("undo")
        gate.open.set()
        for _ in range(3):
            s.step()
        assert s.player.counters.commands.get("undo") == 1
        assert s.history.undone == 1
        live = s.canvas.state()
    finally:
        s.player.backend = real
        s.shutdown()
    replay = _replay(tmp_path / "s.jsonl").state()
    assert replay.step_count == live.step_count
    arrays = [k for k, v in vars(live).items() if isinstance(v, np.ndarray)]
    assert len(arrays) > 5
    for name in arrays:
        assert np.array_equal(getattr(replay, name), getattr(live, name)), name
    assert float(live.p.sum() + live.q.sum()) > 0.0  # two strokes are left on the canvas


def test_a_stroke_starting_during_the_kernel_does_not_wait_and_its_checkpoint_is_after_the_step(
        tmp_path: Path) -> None:
    s = _session(tmp_path)
    real = s.player.backend
    gate = _Gate(real)
    s.player.backend = gate
    try:
        s.command("brush", size=8, water=1.0, pigment={"Hansa Yellow": 0.6})
        s.handle("pen", _pen(0, 0.3))  # a stroke starts: its checkpoint shares the canvas
        assert len(s._lazy) == 1
        cp = s._lazy[0].cp
        assert cp is not None
        live = s.cpu_state
        assert np.shares_memory(cp.state.w, live.w)
        w_before = live.w.copy()
        th = _step_in_thread(s, gate)  # the step copies it first (lock released meanwhile)
        # a step copies what it writes; the paper and the dried layers stay shared
        assert not s.pending_bytes(STEP_FIELDS) and not np.shares_memory(cp.state.w, live.w)
        assert np.shares_memory(cp.state.r_composed, live.r_composed)
        assert np.array_equal(cp.state.w, w_before)
        s.handle("pen", _pen(1, 0.31, touching=False))
        steps = s.player.counters.steps
        # a new stroke while the kernel runs: taken at once, no wait for the kernel
        s.handle("pen", _pen(2, 0.5))
        assert s.inflight and len(s._lazy) == 2 and len(s._mid_step) == 1
        mid = s._lazy[1].cp
        assert mid is not None
        assert s.player.brush.pending > 0  # its stamps wait for the next step
        # an eraser sample (a canvas read) waits for the kernel
        started, applied = threading.Event(), threading.Event()

        def erase() -> None:
            started.set()
            s.handle("pen", PenSample(t=0.011, device="e", tool=Tool.ERASER, x=0.9, y=0.9,
                                      pressure=0.0, touching=False, t_mono=5.0))
            applied.set()

        t2 = threading.Thread(target=erase)
        t2.start()
        assert started.wait(5) and not applied.wait(0.3)
        gate.open.set()
        th.join(20)
        assert applied.wait(20)
        t2.join()
        # the step is over: the checkpoint is the canvas as the step left it
        assert not s._mid_step and s.player.counters.steps == steps + 1
        assert mid.player["counters"].steps == steps + 1
        assert mid.state.step_count == live.step_count == steps + 1
        assert mid.state.sim_time == live.sim_time
        # the eraser's sample copied it (a tool may change the canvas): the step's numbers
        assert not s._lazy and not np.shares_memory(mid.state.w, live.w)
        assert not np.shares_memory(mid.state.r_composed, live.r_composed)
        w_after = live.w.copy()
        assert np.array_equal(mid.state.w, w_after)
        with s.lock:
            s._step_unlocked()
        assert np.array_equal(mid.state.w, w_after)
        assert not np.array_equal(live.w, w_after)  # (the stroke's stamps went in)
    finally:
        gate.open.set()
        s.player.backend = real
        s.shutdown()


def _assert_replays(log: Path, live: CanvasState) -> None:
    """The session's log, painted again, gives the live canvas bit for bit."""
    replay = _replay(log).state()
    assert replay.step_count == live.step_count
    for name, v in vars(live).items():
        if isinstance(v, np.ndarray):
            assert np.array_equal(getattr(replay, name), v), name


def test_samples_during_the_checkpoint_copy_paint_in_that_step_and_replay_exactly(
        tmp_path: Path) -> None:
    s = _session(tmp_path)
    copying, go = threading.Event(), threading.Event()
    real_copy = s.materialize_checkpoints

    # hold the step's copy (lock released) until the test says
    def slow_copy(fields: frozenset[str] | None = None) -> None:
        if s._copying:
            copying.set()
            assert go.wait(20)
        real_copy(fields)

    def one_step() -> None:
        with s.lock:
            s._step_unlocked()

    s.materialize_checkpoints = slow_copy  # type: ignore[method-assign]
    try:
        s.command("brush", size=8, water=1.0, pigment={"French Ultramarine": 0.5})
        k = 0
        for _ in range(3):
            s.handle("pen", _pen(k, 0.2 + 0.02 * k))  # a stroke starts: a lazy checkpoint
            k += 1
            copying.clear()
            go.clear()
            th = threading.Thread(target=one_step)
            s._worker = th  # the copy is made with the lock released in the sim thread only
            th.start()
            assert copying.wait(20)
            steps = s.player.counters.steps
            for _ in range(4):  # during the copy: straight on, into this step
                s.handle("pen", _pen(k, 0.2 + 0.02 * k))
                k += 1
            go.set()
            th.join(20)
            s._worker = None
            assert s.player.counters.steps == steps + 1
            # the step took the copy-time stamps' shares due before it (each stamp is
            # spread over the two steps around its time: what is left is the next step's)
            assert s.player.brush.take(steps) is None
            s.handle("pen", _pen(k, 0.2 + 0.02 * k, touching=False))
            k += 1
            with s.lock:
                s.step()
        s.command("undo")
        for _ in range(2):
            s.step()
        assert s.history.undone == 1
        live = s.canvas.state()
    finally:
        go.set()
        s.shutdown()
    _assert_replays(tmp_path / "s.jsonl", live)
    assert float(live.p.sum() + live.q.sum()) > 0.0


def test_a_stroke_starting_during_the_copy_is_copied_with_the_lock_released_too(
        tmp_path: Path) -> None:
    """The checkpoint of a stroke that starts while the step copies another's is copied
    before the kernel with the lock released as well (a whole canvas's copy under the
    lock holds every pen sample), and the session still replays exactly."""
    s = _session(tmp_path)
    copying, go = threading.Event(), threading.Event()
    owned: list[bool] = []
    real_copy = s.materialize_checkpoints

    # the first copy takes until the test says
    def slow_copy(fields: frozenset[str] | None = None) -> None:
        if s._copying:
            owned.append(s.lock._is_owned())  # type: ignore[attr-defined]
        real_copy(fields)
        if s._copying and not copying.is_set():
            copying.set()
            assert go.wait(20)

    def one_step() -> None:
        with s.lock:
            s._step_unlocked()

    s.materialize_checkpoints = slow_copy  # type: ignore[method-assign]
    try:
        s.command("brush", size=8, water=1.0, pigment={"French Ultramarine": 0.5})
        s.handle("pen", _pen(0, 0.2))  # stroke 1 starts: a lazy checkpoint
        s.handle("pen", _pen(1, 0.25))
        th = threading.Thread(target=one_step)
        s._worker = th
        th.start()
        assert copying.wait(20)
        s.handle("pen", _pen(2, 0.3, touching=False))
        s.handle("pen", _pen(3, 0.6))  # stroke 2 starts during the copy
        assert len(s._lazy) == 2 and s._lazy[0].pending.isdisjoint(STEP_FIELDS)
        go.set()
        th.join(20)
        s._worker = None
        # both copies unlocked; the dried layers are still shared
        assert not s.pending_bytes(STEP_FIELDS) and owned == [False, False]
        s.handle("pen", _pen(4, 0.65, touching=False))
        for _ in range(3):
            s.step()
        s.command("undo")
        s.step()
        assert s.history.undone == 1
        live = s.canvas.state()
    finally:
        go.set()
        s.shutdown()
    _assert_replays(tmp_path / "s.jsonl", live)
    assert float(live.p.sum() + live.q.sum()) > 0.0  # stroke 1 is left


def test_the_simulation_thread_keeps_time_and_stops(tmp_path: Path) -> None:
    s = _session(tmp_path)
    try:
        s.start_worker()
        s.command("brush", size=8, water=1.0, pigment={"French Ultramarine": 0.5})
        t0 = time.monotonic()
        for i in range(40):
            s.handle("pen", _pen(i, 0.2 + 0.01 * i))
            time.sleep(0.01)
        s.handle("pen", _pen(41, 0.6, touching=False))
        time.sleep(0.2)
        s.check_worker()
        s.stop_worker()
        wall = time.monotonic() - t0
        steps = s.player.counters.steps
        assert steps >= 0.5 * 30 * wall  # the thread ran the due steps
        assert s.player.brush.stamps > 0 and s.sim_seconds > 0
    finally:
        s.stop_worker()
        s.shutdown()
    replay = _replay(tmp_path / "s.jsonl")
    assert np.array_equal(replay.render(), s.canvas.render())


def _nice_of_this_thread() -> tuple[int, int]:
    tid = threading.get_native_id()
    return tid, os.getpriority(os.PRIO_PROCESS, tid)


def test_only_the_kernel_runs_niced_and_only_the_take_holds_the_lock(
        tmp_path: Path) -> None:
    """The step's kernel runs ``nice`` steps down; the part of the step that holds the
    lock every pen sample needs (taking the stamps) runs at the window's priority, so a
    busy machine cannot park the lock's holder behind other processes (priority
    inversion); so does the stamps' add, with the lock released (it holds the
    interpreter's lock between numpy's calls)."""
    s = _session(tmp_path)
    base = os.getpriority(os.PRIO_PROCESS, 0)
    nice = min(3, 19 - base)
    if nice <= 0:
        pytest.skip("already at the lowest priority")
    kernel: list[tuple[int, int, bool]] = []
    added: list[tuple[int, int, bool]] = []
    locked: list[tuple[int, int, bool]] = []
    real_backend, real_take = s.player.backend, s.player.take_step

    def owned() -> bool:
        return bool(s.lock._is_owned())  # type: ignore[attr-defined]

    class Recording:
        def __getattr__(self, name: str) -> Any:
            return getattr(real_backend, name)

        def step(self, *a: Any, **kw: Any) -> None:
            kernel.append((*_nice_of_this_thread(), owned()))
            real_backend.step(*a, **kw)

        def add_sources(self, *a: Any, **kw: Any) -> None:
            if threading.current_thread() is not threading.main_thread():  # a step's
                added.append((*_nice_of_this_thread(), owned()))
            real_backend.add_sources(*a, **kw)

    def take() -> Any:
        if threading.current_thread() is not threading.main_thread():  # a step's
            locked.append((*_nice_of_this_thread(), owned()))
        return real_take()

    s.player.backend = Recording()
    s.player.take_step = take  # type: ignore[method-assign]
    try:
        s.command("brush", size=8, water=1.0, pigment={"French Ultramarine": 0.5})
        s.start_worker(nice)
        for i in range(10):
            s.handle("pen", _pen(i, 0.2 + 0.02 * i))
        deadline = time.monotonic() + 120
        while (len(kernel) < 3 or len(locked) < 3 or not added) and \
                time.monotonic() < deadline:
            time.sleep(0.01)
        s.check_worker()
        runner = getattr(s, "_runner", None)  # (main had none)
        s.stop_worker()
    finally:
        s.stop_worker()
        s.player.backend = real_backend
        s.shutdown()
    assert len(kernel) >= 3 and len(locked) >= 3 and added
    assert {(ni, own) for _, ni, own in kernel} == {(base + nice, False)}
    assert {(ni, own) for _, ni, own in locked} == {(base, True)}
    assert {(ni, own) for _, ni, own in added} == {(base, False)}
    assert {tid for tid, _, _ in kernel}.isdisjoint({tid for tid, _, _ in locked})
    assert runner is not None and s._runner is None  # stopped with the worker
    assert not runner._thread.is_alive()


def test_the_niced_runner_hands_back_what_its_job_raised() -> None:
    runner = NicedRunner(1, 1)
    try:
        seen: list[int] = []
        runner.run(lambda: seen.append(threading.get_native_id()))
        assert seen == [runner.native_id] and seen[0] != threading.get_native_id()

        def boom() -> None:
            raise ValueError("in the kernel")

        with pytest.raises(ValueError, match="in the kernel"):
            runner.run(boom)
        runner.run(lambda: seen.append(2))  # it goes on after a failed job
        assert seen[-1] == 2
    finally:
        runner.close()
    with pytest.raises(RuntimeError, match="closed"):
        runner.run(lambda: None)


# -- prediction ------------------------------------------------------------------------
def test_constant_velocity_is_predicted_and_clamped() -> None:
    pred = PenPredictor(PredictConfig(horizon_s=0.02, max_speed=1000.0))
    for i in range(10):
        pred.add(i * 0.005, 100 + 500 * i * 0.005, 50.0, True, True)  # 500 px/s along x
    x, y = pred.predict(age=0.001) or (0, 0)
    assert x == pytest.approx(100 + 500 * 0.045 + 500 * 0.02, abs=1e-6)
    assert y == pytest.approx(50.0)
    fast = PenPredictor(PredictConfig(horizon_s=0.02, max_speed=1000.0))
    for i in range(10):
        fast.add(i * 0.005, 5000 * i * 0.005, 0.0, True, True)  # 5000 px/s: clamped
    vx, _vy = fast.velocity()
    assert vx == pytest.approx(1000.0)
    # a pen held still (last sample 60 ms old) and a lift are not extrapolated
    assert pred.predict(age=0.06) == pytest.approx((100 + 500 * 0.045, 50.0))
    pred.add(0.05, 130.0, 50.0, True, False)
    assert pred.predict(age=0.0) == (130.0, 50.0)
    pred.add(0.055, 131.0, 50.0, False, False)
    assert pred.predict() is None


def test_prediction_beats_holding_the_last_sample_on_a_circle() -> None:
    t = np.arange(0, 2.0, 0.005)
    xy = np.column_stack([400 + 150 * np.cos(2 * t), 300 + 150 * np.sin(2 * t)])
    strokes = np.zeros(t.size, int)
    held = prediction_errors(t, xy, strokes, PredictConfig(horizon_s=0.0))
    hold_err = [math.hypot(*(xy[i + 4] - xy[i])) for i in range(t.size - 4)]  # 20 ms on
    err = prediction_errors(t, xy, strokes, PredictConfig(horizon_s=0.02))
    assert held.max() == 0.0  # horizon 0: the last sample is where the pen is
    assert np.percentile(err, 50) < 0.1 * np.percentile(hold_err, 50)
    # the shadow 20 ms behind the pen reads as 20 ms of lag; predicted, close to none
    frames_t = t[10:-10:3] + 0.02
    late = np.array([xy[i] for i in range(10, t.size - 10, 3)])
    ahead = late + 0.02 * np.column_stack([-300 * np.sin(2 * t[10:-10:3]),
                                           300 * np.cos(2 * t[10:-10:3])])
    lag_late = perceived_lag(t, xy, frames_t, late)
    lag_pred = perceived_lag(t, xy, frames_t, ahead)
    assert np.median(lag_late) == pytest.approx(0.02, abs=1e-3)
    assert abs(np.median(lag_pred)) < 0.002


# -- compositing -----------------------------------------------------------------------
def test_canvas_box_covers_the_projected_cells() -> None:
    area = Viewport(300, 0, 724, 768)
    cam = make_camera("2d", area, 800 / 600)
    x0, y0, x1, y1 = canvas_box(cam, (0, 600, 0, 800), 800, 600) or (0, 0, 0, 0)
    tl = cam.world_to_screen(cam.canvas_to_world(0, 0))
    br = cam.world_to_screen(cam.canvas_to_world(1, 1))
    assert tl is not None and br is not None
    assert x0 <= tl[0] and y0 <= tl[1] and x1 >= br[0] and y1 >= br[1]
    small = canvas_box(cam, (100, 116, 200, 216), 800, 600)
    assert small is not None and (small[2] - small[0]) < 30 and (small[3] - small[1]) < 30
    assert union(None, small) == small and union(small, (0, 0, 1, 1)) == (0, 0, small[2],
                                                                           small[3])


def test_damaged_rectangles_give_the_same_picture_as_a_full_redraw() -> None:
    ctx = _egl_context()
    size = (160, 120)
    comp = Compositor(ctx, size)
    cam = make_camera("2d", Viewport(40, 0, 120, 120), 4 / 3)
    colour: dict[str, tuple[float, float, float]] = {"c": (0.2, 0.4, 0.6)}
    ui: dict[str, Any] = {"hash": 1, "box": (0, 0, 40, 120)}

    def scene(box: tuple[int, int, int, int]) -> None:
        ctx.scissor = (box[0], size[1] - box[3], box[2] - box[0], box[3] - box[1])
        ctx.clear(*colour["c"])

    def panel(box: tuple[int, int, int, int]) -> None:
        x0, y0, x1, y1 = ui["box"]
        bx = (max(x0, box[0]), max(y0, box[1]), min(x1, box[2]), min(y1, box[3]))
        if bx[2] > bx[0] and bx[3] > bx[1]:
            ctx.scissor = (bx[0], size[1] - bx[3], bx[2] - bx[0], bx[3] - bx[1])
            ctx.clear(0.9, 0.1, 0.1)

    def near(px: np.ndarray, rgb: tuple[int, int, int]) -> bool:
        return bool(np.abs(px[:3].astype(int) - np.array(rgb)).max() <= 1)

    try:
        fbo = ctx.simple_framebuffer(size)
        fbo.use()
        comp.update(cam, [], (80, 60), ui["hash"], ui["box"], scene, panel)
        assert comp.pixels_redrawn == size[0] * size[1]  # the first frame: everything
        colour["c"] = (0.9, 0.9, 0.2)  # the scene changes everywhere, only cells are damaged
        comp.update(cam, [(10, 20, 10, 20)], (80, 60), ui["hash"], ui["box"], scene, panel)
        assert 0 < comp.pixels_redrawn < size[0] * size[1] // 4
        img = np.frombuffer(comp.texture.read(), np.uint8).reshape(size[1], size[0], 4)
        box = canvas_box(cam, (10, 20, 10, 20), 80, 60)
        assert box is not None
        # inside the damage: the new scene; far outside it: the old one, untouched
        yy = size[1] - (box[1] + box[3]) // 2 - 1
        xx = (box[0] + box[2]) // 2
        assert near(img[yy, xx], (230, 230, 51))
        assert near(img[2, 150], (51, 102, 153))
        ui["hash"], ui["box"] = 2, (0, 0, 60, 120)  # the panel grows over the scene
        comp.update(cam, [], (80, 60), ui["hash"], ui["box"], scene, panel)
        img = np.frombuffer(comp.texture.read(), np.uint8).reshape(size[1], size[0], 4)
        assert near(img[60, 50], (230, 26, 26))
        ui["hash"], ui["box"] = 3, (0, 0, 40, 120)  # and shrinks: the scene comes back
        comp.update(cam, [], (80, 60), ui["hash"], ui["box"], scene, panel)
        img = np.frombuffer(comp.texture.read(), np.uint8).reshape(size[1], size[0], 4)
        assert near(img[60, 50], (230, 230, 51))
    finally:
        comp.release()
        ctx.release()


# -- the bench -------------------------------------------------------------------------
def test_latency_bench_reports_goals_prediction_and_load(tmp_path: Path) -> None:
    from tests.kiosk_harness import station, xvfb

    with xvfb() as display:
        proc = station("bench", "latency", "--json", "--seconds", "1.5", "--size", "160x120",
                       "--predict-ms", "12", "--brush", "round3d", "--wet", display=display)
        out, err = proc.communicate(timeout=240)
    assert proc.returncode == 0, err[-2000:]
    r = json.loads(out)
    # --wet: the whole sky wet under the pen, still mostly wet when the run ends
    assert r["wet_share"]["start"] == 1.0 and r["wet_share"]["end"] > 0.5
    assert r["latency"]["n"] > 10 and r["latency"]["p99_ms"] > 0
    # the deformable brush painted (its samples go on while a step's kernel runs too)
    assert r["tablet"]["brush"] == "round3d" and r["tablet"]["stamps"] > 10
    assert r["frames"]["fps"] > 0 and r["frames"]["sim_steps_per_s"] > 5
    assert set(r["frames"]["share"]) == {"wait", "input", "sim", "render", "ui", "present"}
    pr = r["present"]
    assert pr["asked"] == "auto" and pr["mode"] in ("partial", "swap")
    assert pr["partial_frames"] + pr["whole_frames"] >= r["frames"]["frames"] > 0
    lat = r["latency"]
    assert 0 < lat["latch_to_shown"]["p50_ms"] <= lat["latch_to_shown"]["max_ms"]
    assert lat["latch_to_shown"]["p50_ms"] <= lat["max_ms"]
    assert 0.0 <= lat["latched_late_share"] <= 1.0
    # the simulation thread needs a thread-safe numba layer (omp, tbb; `make` installs
    # libgomp1); without one the kiosk steps in its frame loop, and says so
    from station.kiosk.app import numba_threadsafe

    assert 0 < r["frames"]["sim_busy_share"] <= 1.0
    assert r["sim"] == ("thread" if numba_threadsafe() else "frame loop")
    assert r["prediction"]["horizon_ms"] == 12.0
    assert r["prediction"]["error_px_at_horizon"]["n"] > 10
    assert r["prediction"]["shadow_lag_ms"]["with"]["n"] > 0
    assert len(r["load_avg"]) == 3
    for goal in r["goals"].values():
        assert goal["flag"] in ("PASS", "MISS")
        ok = (goal["measured"] <= goal["goal"]) if goal is r["goals"]["latency_p99_ms"] \
            else (goal["measured"] >= goal["goal"])
        assert (goal["flag"] == "PASS") == ok


def test_the_display_spreads_a_whole_canvas_over_frames_within_its_budget(
        tmp_path: Path) -> None:
    from station.kiosk.display import CpuDisplay
    from station.kiosk.subcell import REACH

    ctx = _egl_context()
    s = _session(tmp_path)
    try:
        s.command("brush", size=12, water=1.0, pigment={"Hansa Yellow": 0.6})
        for i in range(8):
            s.handle("pen", _pen(i, 0.2 + 0.08 * i))
        for _ in range(4):
            s.step()
        budget = 1500
        disp = CpuDisplay(ctx, s, max_cells=budget)
        s.mark_all_dirty()
        frames = 0
        ts = int(s.canvas.params.tile_size)
        while True:
            cells = disp.update()
            frames += 1
            # a run of tiles (grown by its contour level's reach) may end past the budget
            assert cells <= budget + (W + 2 * REACH) * (ts + 2 * REACH)
            if not disp.behind():
                break
            assert frames < 50
        assert frames >= (W * H) // (budget + W * ts)  # spread over several frames
        tex = disp.read()
        assert np.abs(tex - disp.expected()).max() < 2e-6  # every tile got there
    finally:
        s.shutdown()
        ctx.release()


def test_a_frame_handles_the_bus_for_a_bounded_time_and_loses_nothing(tmp_path: Path) -> None:
    from station.bus import Message
    from station.kiosk import session as session_mod

    s = _session(tmp_path)
    real_sub = s.sub
    queue = [Message(topic="pen.p", kind="pen", value=_pen(i, 0.2 + 0.001 * i), publisher=1,
                     seq=i, replay=False) for i in range(400)]

    class Queue:
        def recv(self, timeout_ms: int | None = 0) -> Message | None:
            return queue.pop(0) if queue else None

    slow = s.handle

    def handle(*a: Any, **kw: Any) -> None:
        time.sleep(0.001)  # a slow machine: a millisecond a message
        slow(*a, **kw)

    s.sim.sub = Queue()  # type: ignore[assignment]
    s.handle = handle  # type: ignore[method-assign]
    try:
        s.command("brush", size=8, water=1.0, pigment={"French Ultramarine": 0.5})
        t0 = time.perf_counter()
        s.drain(0)
        took = time.perf_counter() - t0
        first = s.counters.samples
        # one frame's worth, not the whole queue: the window draws, then goes on
        assert 1 <= first <= 1 + session_mod.DRAIN_BUDGET_S / 0.001 + 2
        assert took < session_mod.DRAIN_BUDGET_S + 0.05
        frames = 1
        while queue:
            s.drain(0)
            frames += 1
        assert s.counters.samples == 400 and frames > 10  # every sample, over many frames
    finally:
        s.sim.sub = real_sub
        s.shutdown()


def test_the_auto_horizon_follows_the_measured_lag() -> None:
    from station.kiosk.predict import LagEstimate

    est = LagEstimate(initial=0.008)
    for _ in range(60):
        est.add(0.004)
    assert abs(est.value - 0.004) < 2e-4 and est.frames == 60
    est.add(10.0)  # a frame that stalled: clamped, and moves the estimate a little
    assert est.value < 0.004 + 0.1 * 0.05 + 1e-9
    for _ in range(60):
        est.add(-1.0)  # a clock oddity never makes a negative horizon
    assert 0.0 <= est.value < 1e-3


def test_a_window_that_stalls_mid_stroke_never_ends_the_stroke(tmp_path: Path) -> None:
    """A kiosk that reads nothing for longer than the driver's silence timeout (a loaded
    machine, a long frame) while the pen goes on painting: the samples wait on the bus,
    so the stroke is not ended by a synthesised pen-up (on a loaded fresh machine the
    mock line was broken mid-line this way); a device really silent still is."""
    from station.bus import Publisher

    s = _session(tmp_path)
    pub = Publisher(f"ipc://{tmp_path}/bus", heartbeat=0.2)
    n = 0

    def send(touching: bool = True) -> None:
        nonlocal n
        pub.publish_pen(PenSample(t=0.01 * n, device="p", tool=Tool.PEN, x=0.1 + 0.004 * n,
                                  y=0.5, pressure=0.8 * touching, touching=touching, seq=n + 1))
        n += 1

    def take(count: int) -> None:
        deadline = time.monotonic() + 60
        while s.counters.samples < count:
            assert time.monotonic() < deadline, (s.counters.samples, count)
            s.drain(50)

    try:
        assert pub.wait_for_subscribers(1, 30)
        s.command("brush", size=6, water=1.0, pigment={"French Ultramarine": 0.5})
        for _ in range(10):
            send()
        take(10)
        timeout = s.sim.devices["p"].timeout()
        assert timeout is not None and timeout < 1.0
        stall_end = time.monotonic() + timeout + 0.6  # the window reads nothing meanwhile
        while time.monotonic() < stall_end:
            send()  # the pen paints on (heartbeats go with the samples)
            time.sleep(0.02)
        s.housekeeping()  # the kiosk's check for silent devices, after its stalled frame
        assert s.counters.synthetic_pen_ups == 0 and not s.sim.silent_devices()
        take(n)
        send(touching=False)
        take(n)
        s.journal.sync()
        _header, records = read_session(s.log_path)
        pens = [r for r in records if isinstance(r, PenSample)]
        touching = [p.touching for p in pens]
        assert len(pens) == n and all(touching[:-1]) and not touching[-1]  # one stroke
        # a device that really falls silent mid-stroke (its heartbeats stop while the
        # window reads the bus) still has its stroke ended
        send()
        take(n)
        deadline = time.monotonic() + 30
        while s.counters.synthetic_pen_ups == 0:
            assert time.monotonic() < deadline, "a silent device was never noticed"
            s.drain(20)
            s.housekeeping()
        assert s.sim.silent_devices() == ["p"]
    finally:
        pub.close()
        s.shutdown()


class _Tearing(_Gate):
    """A kernel caught half way: cells of a blank corner hold values that are not the
    step's result until the gate opens (then the real step runs)."""

    def __init__(self, backend: Any, state: Any) -> None:
        super().__init__(backend)
        self.state = state

    def step(self, *a: Any, **kw: Any) -> None:
        st = self.state
        corner = (slice(0, 8), slice(W - 16, W))
        saved = st.p[(slice(None), *corner)].copy()
        st.p[(0, *corner)] = 0.5  # half written
        self.entered.set()
        assert self.open.wait(20), "the test never opened the gate"
        st.p[(slice(None), *corner)] = saved
        self._backend.step(*a, **kw)


def test_no_tile_is_drawn_from_a_state_a_kernel_is_writing(tmp_path: Path) -> None:
    """While a step's kernel runs (the window draws on, the lock released) the display
    renders no tile from the half-written state and spends no dirty mark: tiles drawn
    then, and left inactive by the step, kept a torn picture (a kiosk's screenshot
    showed a stroke broken, with a tile-edged block, while the painting was whole); the
    pen's preview stays on screen meanwhile; after the step the texture is the canvas."""
    from station.kiosk.display import CpuDisplay

    ctx = _egl_context()
    s = _session(tmp_path)
    gate = _Tearing(s.player.backend, s.cpu_state)
    s.player.backend = gate
    try:
        disp = CpuDisplay(ctx, s)
        s.command("brush", size=8, water=1.0, pigment={"French Ultramarine": 0.5})
        for i in range(6):
            s.handle("pen", _pen(i, 0.2 + 0.03 * i))
        for _ in range(100):  # the preview and every tile drawn
            disp.update()
            if not disp.behind():
                break
        shown = disp.read()
        s.mark_all_dirty()  # (an undo, a fresh canvas: every tile to draw again)
        disp.damage = []  # (composed by the window)
        th = _step_in_thread(s, gate)
        try:
            with s.lock:
                assert s.kernel_running
                assert disp.update_tiles() == 0 and not disp.damage
            # the stamps the step took stay on screen as they were previewed
            assert np.array_equal(disp.read(), shown)
        finally:
            gate.open.set()
            th.join(20)
        # each stamp is spread over the two steps around its time (issue 21 item 8): a
        # second step takes the shares still previewed, so the canvas alone is on screen
        with s.lock:
            s._step_unlocked()
        frames = 0
        while True:
            with s.lock:
                disp.update()
            frames += 1
            if not disp.behind() or frames > 200:
                break
        tex = disp.read()
        # the half-written corner was never shown; the texture is the canvas after the step
        assert np.abs(tex - disp.expected()).max() < 2e-6
    finally:
        s.shutdown()
        ctx.release()


def test_the_damage_of_every_tile_drawn_waits_for_the_window_to_compose_it(
        tmp_path: Path) -> None:
    """A screenshot renders the tiles in several calls before the window composes them:
    the damage of every call is kept (a list reset at each call lost the earlier calls'
    tiles, which stayed stale on screen: the mock line shown broken)."""
    from station.kiosk.display import CpuDisplay

    ctx = _egl_context()
    s = _session(tmp_path)
    try:
        disp = CpuDisplay(ctx, s, max_cells=1500)
        disp.damage = []
        s.mark_all_dirty()
        calls = 0
        while True:
            disp.update_tiles()
            calls += 1
            if not disp.behind() or calls > 100:
                break
        covered = np.zeros((H, W), bool)
        for y0, y1, x0, x1 in disp.damage:
            covered[y0:y1, x0:x1] = True
        assert calls >= 2 and covered.all(), (calls, covered.mean())
    finally:
        s.shutdown()
        ctx.release()


def test_only_texels_that_change_are_uploaded_and_redrawn(tmp_path: Path) -> None:
    """A wet tile is rendered at every step, but most of its texels are as they were:
    those are neither uploaded nor redrawn (main redrew every tile rendered), and the
    texture stays the full render."""
    from station.kiosk.display import CpuDisplay

    ctx = _egl_context()
    s = _session(tmp_path)
    try:
        s.command("brush", size=8, water=0.8, pigment={"French Ultramarine": 0.6})
        for i in range(6):
            s.handle("pen", _pen(i, 0.2 + 0.04 * i))
        s.handle("pen", _pen(7, 0.44, touching=False))
        for _ in range(3):
            s.step()
        disp = CpuDisplay(ctx, s)

        def draw_all() -> list[tuple[int, int, int, int]]:
            disp.damage = []
            while disp.update_tiles() or disp.behind():
                pass
            return disp.damage

        assert sum((y1 - y0) * (x1 - x0) for y0, y1, x0, x1 in draw_all()) >= W * H
        s.mark_all_dirty()  # everything rendered again, nothing changed
        assert draw_all() == []
        # a step of the wet stroke: the damage is where its paint moved, not every tile
        s.step()
        wet_tiles = int(s.dirty.sum())
        ts = int(s.cpu_state.params.tile_size)
        damage = draw_all()
        moved = sum((y1 - y0) * (x1 - x0) for y0, y1, x0, x1 in damage)
        assert wet_tiles > 0 and moved < 0.8 * (wet_tiles * ts * ts)
        assert np.abs(disp.read() - disp.expected()).max() < 1e-4
    finally:
        s.shutdown()
        ctx.release()


def test_a_large_fresh_preview_is_drawn_by_the_tiles_budget_not_in_one_frame(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """While a wholly wet canvas steps slower than real time, stamps stay pending and a
    fresh preview spanned most of the stroke (main rendered 200 000-530 000 cells of it
    in one frame at 1920x1080). Past ``PREVIEW_CELLS`` its tiles are marked dirty and
    drawn, with the pending stamps, within the tiles' budget; the picture it ends at is
    the one a whole render of the state and the stamps gives."""
    from station.kiosk import display as D

    ctx = _egl_context()
    s = _session(tmp_path)
    try:
        disp = D.CpuDisplay(ctx, s)
        while disp.update() or disp.behind():  # the blank canvas, all drawn
            pass
        blank = disp.read()
        s.command("brush", size=8, water=1.0, pigment={"French Ultramarine": 0.6})
        for i in range(10):  # a stroke no step has taken: all of it pending
            s.handle("pen", _pen(i, 0.15 + 0.07 * i))
        monkeypatch.setattr(D, "PREVIEW_CELLS", 400)
        disp.damage = []
        assert disp.update_preview() == 0 and disp.behind() and not disp.damage
        frames = 0
        while disp.behind():
            disp.update()
            frames += 1
            assert frames < 100
        shown = disp.read()
        # every tile afresh, with the pending stamps (the tiles' render: a preview draws
        # no steps' contours, the tiles do)
        ref = D.CpuDisplay(ctx, s)
        while ref.update() or ref.behind():
            pass
        whole = ref.read()
        assert np.abs(whole - blank).max() > 0.05  # the stroke is on screen
        assert np.abs(shown - whole).max() < 1e-4
    finally:
        s.shutdown()
        ctx.release()


class _SumGate:
    """The next sum of a step's stamps (``station.brush.sources.accumulate``, when armed)
    held until the test opens the gate; whether the session's lock was free then."""

    def __init__(self, s: KioskSession, real: Any) -> None:
        self._s, self._real = s, real
        self.armed = False
        self.lock_free: bool | None = None
        self.entered = threading.Event()
        self.open = threading.Event()

    def __call__(self, *a: Any, **kw: Any) -> Any:
        if self.armed:
            self.armed = False
            got = self._s.lock.acquire(blocking=False)  # (a Condition: not reentrant here)
            if got:
                self._s.lock.release()
            self.lock_free = got and not self._s.lock._is_owned()  # type: ignore[attr-defined]
            self.entered.set()
            assert self.open.wait(20), "the test never opened the gate"
        return self._real(*a, **kw)


def test_the_step_sums_and_adds_its_stamps_with_the_lock_released_and_replays_exactly(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Under load a full-HD step's sum and add of its stamps held every pen sample for up
    to 150 ms.  Now the step only takes the stamps under the lock
    (:meth:`SessionPlayer.take_step`); the sum runs with the lock free, and samples that
    come meanwhile, a stroke's start included, paint at once (their stamps go to the next
    step, as in a replay); the log replays bit for bit, an undo of that stroke included."""
    s = _session(tmp_path)
    gate = _SumGate(s, sources_mod.accumulate)
    monkeypatch.setattr(sources_mod, "accumulate", gate)
    try:
        s.command("brush", size=8, water=1.0, pigment={"French Ultramarine": 0.5})
        k = 0
        for _ in range(4):
            s.handle("pen", _pen(k, 0.2 + 0.01 * k))
            k += 1
        gate.armed = True

        def one_step() -> None:  # as the simulation thread runs a step
            with s.lock:
                s._step_unlocked()

        th = threading.Thread(target=one_step)
        s._worker = th  # the lock is released only in the simulation thread
        th.start()
        assert gate.entered.wait(20)
        assert gate.lock_free  # the sum runs with the lock released
        assert s.inflight and s.kernel_running  # tiles wait; commands and tools too
        stamps, during = s.player.brush.stamps, s.samples_during_steps
        done = threading.Event()

        def samples() -> None:
            for i in range(3):
                s.handle("pen", _pen(k + i, 0.24 + 0.01 * i))
            s.handle("pen", _pen(k + 3, 0.3, touching=False))
            s.handle("pen", _pen(k + 4, 0.6))  # a stroke starts during the sum
            done.set()

        feeder = threading.Thread(target=samples)
        feeder.start()
        applied = done.wait(10)  # the lock held through the sum would hold them here
        assert applied and s.player.brush.stamps > stamps  # painted at once
        assert s.samples_during_steps == during + 5
        gate.open.set()
        th.join(20)
        feeder.join(20)
        s._worker = None
        k += 5
        s.handle("pen", _pen(k, 0.65, touching=False))
        for _ in range(3):
            s.step()
        s.command("undo")  # the stroke that started during the sum
        s.step()
        assert s.history.undone == 1
        live = s.canvas.state()
    finally:
        gate.open.set()
        s._worker = None
        s.shutdown()
    _assert_replays(tmp_path / "s.jsonl", live)
    assert float(live.p.sum() + live.q.sum()) > 0.0


def test_the_log_is_fsynced_by_the_simulation_thread_without_the_lock(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The log's fsync (every ``SYNC_EVERY_S``) ran in the window's thread, the lock held:
    a slow disk held the window's frame and the steps.  With the simulation thread running,
    the window's housekeeping only hands the records to the kernel; the simulation thread
    fsyncs, the lock free."""
    s = _session(tmp_path)
    synced: list[tuple[str, bool]] = []
    real_fsync = os.fsync

    def fsync(fd: int) -> None:
        synced.append((threading.current_thread().name,
                       bool(s.lock._is_owned())))  # type: ignore[attr-defined]
        real_fsync(fd)

    monkeypatch.setattr(journal_mod.os, "fsync", fsync)
    try:
        s.command("brush", size=8, water=1.0, pigment={"French Ultramarine": 0.5})
        s.start_worker(0)
        for i in range(6):
            s.handle("pen", _pen(i, 0.2 + 0.02 * i))
        s.journal._last_sync = -math.inf  # an fsync is due
        s.housekeeping()  # the window's pass
        assert not [t for t, _ in synced if t == threading.current_thread().name]
        deadline = time.monotonic() + 60
        while not synced and time.monotonic() < deadline:
            time.sleep(0.01)
        s.check_worker()
        s.stop_worker()
        assert synced and synced[0] == ("kiosk-sim", False)
        assert s.journal.size() > 0  # the records reached the file
    finally:
        s.stop_worker()
        s.shutdown()
