"""``station bench latency``: pen-to-screen latency and frame rate of the kiosk.

A mock tablet is read by a real ``station driver`` process (it stamps each
report with ``time.monotonic()`` as it reads it) and published on a private
bus; the kiosk window runs in this process on a canvas of ``--size`` and
paints the samples.  For every sample that made paint, the latency is the time
from the driver's read to the end of the present (swap or partial) of the first frame that
shows it (``glFinish`` then ``swap_buffers``; under Xvfb there is no scan-out,
so that is when the frame is complete).  Both processes read the same
system-wide monotonic clock.

The tablet draws spirals continuously (one live stroke at a time) through a
calibration that maps it onto the canvas.  Frames are not synchronised to a
display (no vsync) so frames/s is what the loop can do; the share of time in
simulation, canvas render (dirty tiles), UI (scene + ImGui) and presentation
is reported.  Without ``$DISPLAY`` a private Xvfb is started (it must be
installed).
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from station.bench._sim_driver import wash
from station.brush.stamp import brush_kinds
from station.calibration.area import AreaSettings, Rect
from station.calibration.files import write_file
from station.calibration.model import Calibration, DeviceId
from station.cli.argtypes import auto_or_ms
from station.drivers.pipeline import open_device
from station.errors import BadInput, StationError
from station.kiosk.app import KioskApp, KioskConfig
from station.kiosk.idle import IdleConfig
from station.kiosk.predict import PredictConfig, perceived_lag, prediction_errors
from station.kiosk.session import LockWaits
from station.sim.paint import parse_size

GOAL_P99_MS = 16.0
GOAL_FPS = 60.0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("latency", help="kiosk pen-to-screen latency and frame rate (JSON)")
    p.add_argument("--json", action="store_true", help="print JSON (the default output too)")
    p.add_argument("--size", default="800x600", help="canvas size (800x600)")
    p.add_argument("--backend", default="cpu", choices=("cpu", "numpy", "gl"),
                   help="canvas backend (cpu)")
    p.add_argument("--window", default="1024x768", metavar="WxH",
                   help="the kiosk's window in pixels (1024x768): the canvas is drawn at "
                        "this resolution; a private Xvfb's screen is made this size")
    p.add_argument("--seconds", type=float, default=8.0, help="measuring time (8 s)")
    p.add_argument("--rate", type=int, default=200, help="tablet reports per second (200)")
    p.add_argument("--model", default="intuos-pro-m", help="mock tablet model")
    p.add_argument("--script", default="arc", choices=("arc", "line", "spiral"),
                   help="the mock tablet's stroke, repeated (arc: a half circle, 2 s)")
    p.add_argument("--predict-ms", type=auto_or_ms, default=None, metavar="MS|auto",
                   help="pen prediction horizon of the shadow (auto: the measured lag, the "
                        "default; 0: none)")
    p.add_argument("--inline-sim", action="store_true",
                   help="run the steps in the frame loop, not in a thread of their own")
    p.add_argument("--present", default="auto", choices=("auto", "swap", "partial"),
                   help="how frames reach the screen (auto: only the changed rectangles on "
                        "a software rasteriser, station.kiosk.present)")
    p.add_argument("--brush", default="round", type=_brush_kind, metavar="KIND",
                   help="the brush the pen paints with: round (default) or a deformable "
                        "kind (round3d, flat, …), whose samples cost a spine solve each")
    p.add_argument("--wet", action="store_true",
                   help="the whole canvas wet under the pen (bench sim's wash: water, two "
                        "pigments, a slow swirl), as when a visitor wets a whole sky: the "
                        "sim steps every cell; reported as wet_share at start and end")
    p.add_argument("--sim-nice", type=int, default=KioskConfig.sim_nice, metavar="N",
                   help="how many nice steps the simulation's kernel thread runs below the "
                        f"window (the kiosk's default, {KioskConfig.sim_nice})")
    p.add_argument("--compare", action="store_true",
                   help="also measure the peer (steps in the frame loop) in the same run, "
                        "each for --seconds, and report the ratios")
    p.set_defaults(func=run)


def _brush_kind(text: str) -> str:
    kinds = brush_kinds()
    if text not in kinds:
        raise argparse.ArgumentTypeError(f"unknown brush {text!r}; one of {', '.join(kinds)}")
    return text


def _percentiles(xs: list[float] | np.ndarray) -> dict[str, float | int | None]:
    if len(xs) == 0:
        return {"n": 0, "p50_ms": None, "p95_ms": None, "p99_ms": None, "max_ms": None}
    a = np.asarray(xs) * 1000.0
    return {"n": int(a.size), "p50_ms": round(float(np.percentile(a, 50)), 2),
            "p95_ms": round(float(np.percentile(a, 95)), 2),
            "p99_ms": round(float(np.percentile(a, 99)), 2),
            "max_ms": round(float(a.max()), 2)}


def _px(xs: np.ndarray) -> dict[str, float | int | None]:
    if xs.size == 0:
        return {"n": 0, "p50": None, "p99": None, "max": None}
    return {"n": int(xs.size), "p50": round(float(np.percentile(xs, 50)), 2),
            "p99": round(float(np.percentile(xs, 99)), 2), "max": round(float(xs.max()), 2)}


def _goal(measured: float | None, goal: float, at_most: bool) -> dict[str, Any]:
    ok = measured is not None and (measured <= goal if at_most else measured >= goal)
    return {"goal": goal, "measured": measured, "flag": "PASS" if ok else "MISS"}


def _start_xvfb(window: tuple[int, int] = (1024, 768)) -> tuple[subprocess.Popen[bytes], str]:
    exe = shutil.which("Xvfb")
    if exe is None:
        raise StationError("no $DISPLAY and no Xvfb: the latency bench needs a display")
    for number in range(170, 220):
        if not Path(f"/tmp/.X11-unix/X{number}").exists() and \
                not Path(f"/tmp/.X{number}-lock").exists():
            break
    screen = f"{max(window[0], 1024)}x{max(window[1], 768)}x24"
    proc = subprocess.Popen([exe, f":{number}", "-screen", "0", screen, "-nolisten",
                             "tcp", "-noreset"], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 10
    while not Path(f"/tmp/.X11-unix/X{number}").exists():
        if time.monotonic() > deadline or proc.poll() is not None:
            proc.kill()
            raise StationError("Xvfb did not start")
        time.sleep(0.05)
    return proc, f":{number}"


def run(args: argparse.Namespace) -> int:
    width, height = parse_size(args.size)
    window = parse_size(args.window, "--window")
    if not (320 <= window[0] <= 7680 and 240 <= window[1] <= 4320):
        raise BadInput(f"{args.window} is not a window from 320x240 to 7680x4320", "--window")
    if not args.seconds > 0:
        raise BadInput("must be > 0", "--seconds")
    if not 10 <= args.rate <= 2000:
        raise BadInput("must be 10..2000 reports/s", "--rate")
    xvfb = None
    if not os.environ.get("DISPLAY"):
        xvfb, os.environ["DISPLAY"] = _start_xvfb(window)
    try:
        result = measure(width, height, args.backend, args.seconds, args.rate, args.model,
                         args.script, sim_thread=not args.inline_sim,
                         predict_ms=args.predict_ms, present=args.present, brush=args.brush,
                         window=window, wet=args.wet, sim_nice=args.sim_nice)
        if args.compare:
            peer = measure(width, height, args.backend, args.seconds, args.rate, args.model,
                           args.script, sim_thread=args.inline_sim,
                           predict_ms=args.predict_ms, present=args.present,
                           brush=args.brush, window=window, wet=args.wet,
                           sim_nice=args.sim_nice)
            result["peer"] = {k: peer[k] for k in ("sim", "latency", "frames", "load_avg")}
            result["ratios"] = _ratios(result, peer)
    finally:
        if xvfb is not None:
            xvfb.terminate()
            xvfb.wait(10)
    sys.stdout.write(json.dumps(result, indent=1) + "\n")
    return 0


def _wet_share(canvas: Any) -> float:
    """The share of cells holding surface water (``--wet``: the sky the sim steps)."""
    return round(float(np.mean(canvas.state().w > 0)), 4)


def _ratios(a: dict[str, Any], b: dict[str, Any]) -> dict[str, Any]:
    """This run over its peer: latency percentiles (lower is better) and frames/s."""
    out: dict[str, Any] = {}
    for key in ("p50_ms", "p95_ms", "p99_ms"):
        x, y = a["latency"][key], b["latency"][key]
        out[f"latency_{key}"] = round(x / y, 3) if x is not None and y else None
    fa, fb = a["frames"]["fps"], b["frames"]["fps"]
    out["fps"] = round(fa / fb, 3) if fb else None
    out["this"], out["peer"] = a["sim"], b["sim"]
    return out


def measure(width: int, height: int, backend: str, seconds: float, rate: int,
            model: str, script: str = "arc", sim_thread: bool = True,
            predict_ms: float | None = None, present: str = "auto",
            brush: str = "round", window: tuple[int, int] = (1024, 768),
            wet: bool = False, sim_nice: int = KioskConfig.sim_nice) -> dict[str, Any]:
    bus = f"bench-latency-{os.getpid()}-{int(sim_thread)}"
    with tempfile.TemporaryDirectory(prefix="station-latency-") as tmp:
        cfg = KioskConfig(bus=f">ipc:{bus}", width=width, height=height, backend=backend,
                          fullscreen=False, window=window, gallery=Path(tmp) / "gallery",
                          serve=None,
                          status="none", vsync=False, cmd="none", sim_thread=sim_thread,
                          predict_ms=predict_ms, present=present, sim_nice=sim_nice,
                          # the pen's path only: the X pointer entering the window would be
                          # a mouse sample, and the warm-up would take it for the pen's
                          input="pen",
                          idle=IdleConfig(attract_after=3600, finish_after=7200))
        app = KioskApp(cfg)
        if brush != "round":
            app.session.command("brush", kind=brush)
        wet_share: dict[str, float] = {}
        if wet:  # under the session's lock: the sim thread may be stepping
            with app.session.lock:
                wash(app.session.canvas, width, height)
                wet_share["start"] = _wet_share(app.session.canvas)
        spec = f"mock:{model}?script={script}&repeat=0&reports={rate * 2}&rate={rate}"
        probe = open_device(spec)
        ident = probe.describe()
        probe.close()
        x, y, w, h = app.canvas_rect()
        sw, sh = app.size
        cal = Calibration(DeviceId(int(ident["vid"]), int(ident["pid"])), area=AreaSettings(
            output=Rect(x / sw, y / sh, w / sw, h / sh)))
        cal_path = Path(tmp) / "cal.json"
        write_file(cal, cal_path)
        driver = subprocess.Popen(
            [sys.executable, "-m", "station", "driver", "--device", spec, "--bus",
             f"@ipc:{bus}", "--calibration", str(cal_path), "--status-interval", "0.5"],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        try:
            # warm up (first frames, JIT, the first stroke), then measure from a clean slate
            give_up = time.monotonic() + 30.0
            t_end = give_up
            last = time.monotonic()
            while time.monotonic() < min(t_end, give_up):
                now = time.monotonic()
                app.frame(now - last)
                last = now
                if app.session.counters.samples > 0 and t_end == give_up:
                    t_end = now + 2.0
            if app.session.counters.samples == 0:
                raise StationError("no pen samples arrived from the mock driver: "
                                   + (driver.stderr.read().decode()[-500:]
                                      if driver.poll() is not None and driver.stderr else ""))
            st = app.session
            app.latencies.clear()
            app.frames = 0
            for k in app.phase:
                app.phase[k] = 0.0
            app.pen_log, app.cursor_log, st.queue_log = [], [], []
            app.tail_log = []
            samples0, stamps0 = st.counters.samples, st.painted_stamps
            steps0, during0 = st.player.counters.steps, st.samples_during_steps
            copied0 = st.checkpoint_bytes_copied
            saves0 = st.sim.counters.autosaves
            st.lock_waits = LockWaits()
            pauses: list[tuple[int, float]] = []  # (generation, seconds) of each collection
            gc_start = [0.0]

            def on_gc(phase: str, info: dict[str, Any]) -> None:
                if phase == "start":
                    gc_start[0] = time.perf_counter()
                else:
                    pauses.append((int(info.get("generation", 0)),
                                   time.perf_counter() - gc_start[0]))

            gc.callbacks.append(on_gc)
            p0 = time.perf_counter()
            cells = pixels = 0
            frame_ms: list[float] = []
            t0 = time.monotonic()
            t_end = t0 + seconds
            while time.monotonic() < t_end:
                now = time.monotonic()
                drawn = app.frames
                app.frame(now - last)
                if app.frames > drawn:  # a pass that drew nothing rendered nothing
                    cells += app.display.cells_rendered
                    pixels += app.frame_pixels
                    frame_ms.append(time.monotonic() - now)
                last = now
            wall = time.monotonic() - t0
            p1 = time.perf_counter()
            gc.callbacks.remove(on_gc)
            load = [round(v, 2) for v in os.getloadavg()]
            n = max(app.frames, 1)
            lat = _percentiles(app.latencies)
            fps = round(app.frames / wall, 1)
            # the shadow: where it was drawn against the pen's path (prediction)
            # pen samples with the tip down: read time, device time, x, y; a stroke number
            log_ = app.pen_log
            pen = np.array([r[:4] for r in log_ if r[4]]).reshape(-1, 4)
            stroke = np.cumsum([0] + [int(a[4] != b[4]) for a, b in
                                      zip(log_[1:], log_[:-1], strict=True)])
            stroke = np.array([k for k, r in zip(stroke, log_, strict=True) if r[4]], int)
            curs = np.array(app.cursor_log).reshape(-1, 5)
            horizon_ms = 1000 * app.predictor.cfg.horizon_s  # auto: where the lag settled
            pc = PredictConfig(horizon_s=horizon_ms / 1000)
            # the predictor's own error on the device's clock; the shadow against the
            # path on the read clock, which frames are stamped with too
            errors = prediction_errors(pen[:, 1], pen[:, 2:], stroke, pc)
            lag_raw = perceived_lag(pen[:, 0], pen[:, 2:], curs[:, 0], curs[:, 1:3])
            lag_pred = perceived_lag(pen[:, 0], pen[:, 2:], curs[:, 0], curs[:, 3:5])
            sim_s = st.sim_busy(p0, p1)
            if wet:
                with st.lock:
                    wet_share["end"] = _wet_share(st.canvas)
            result = {
                "bench": "latency", "size": f"{width}x{height}", "backend": st.backend_name,
                "renderer": str(getattr(st.canvas, "renderer", "")),
                "display": os.environ.get("DISPLAY"), "gl_renderer":
                    app.ctx.info.get("GL_RENDERER", ""), "window": list(app.size),
                "cpus": os.cpu_count(), "load_avg": load,
                "sim": "thread" if st.threaded else "frame loop", "sim_nice": sim_nice,
                "present": {"mode": app.presenter.mode, "asked": present,
                            "partial_frames": app.presenter.partial_frames,
                            "whole_frames": app.presenter.whole_frames},
                "wet_share": wet_share or None,
                "tablet": {"model": model, "script": script, "reports_per_s": rate,
                           "samples": st.counters.samples - samples0,
                           "stamps": st.painted_stamps - stamps0,
                           "brush": st.player.brush.settings.kind},
                "latency": {**lat, "goal_p99_ms": GOAL_P99_MS,
                            "from": "driver read (time.monotonic)",
                            "to": "end of the present (swap, or copy of the changed "
                                  "rectangles) + glFinish of the first frame showing its paint",
                            "read_to_handled": _percentiles(st.queue_log or []),
                            "latch_to_shown": _percentiles([t for t, _ in app.tail_log]),
                            "latched_late_share": round(sum(k for _, k in app.tail_log) / max(
                                len(app.latencies), 1), 3)},
                "frames": {"fps": fps, "frames": app.frames,
                           "seconds": round(wall, 2), "goal_fps": GOAL_FPS,
                           "frame_time": _percentiles(frame_ms),
                           "sim_steps_per_s": round((st.player.counters.steps - steps0) / wall,
                                                    1),
                           "sim_busy_share": round(sim_s / wall, 3),
                           "sim_ms_per_step": round(1000 * sim_s / max(
                               st.player.counters.steps - steps0, 1), 2),
                           "samples_applied_during_steps":
                               st.samples_during_steps - during0,
                           # undo checkpoints' copies (arrays a step writes; the paper and
                           # the dried layers stay shared): MiB in the measured seconds
                           "checkpoint_copied_mib": round(
                               (st.checkpoint_bytes_copied - copied0) / 2**20, 1),
                           # autosaves in the measured seconds (one every 30 s between
                           # strokes: a full-HD one compresses for seconds)
                           "autosaves": st.sim.counters.autosaves - saves0,
                           "window_lock_waits": {
                               "n": st.lock_waits.n, "over_1ms": st.lock_waits.waited,
                               "total_ms": round(1000 * st.lock_waits.total_s, 1),
                               "max_ms": round(1000 * st.lock_waits.max_s, 2)},
                           "cells_rendered_per_frame": int(cells / n),
                           "pixels_redrawn_per_frame": int(pixels / n),
                           "gc_pauses": {"n": len(pauses), "gen2": sum(
                               1 for g, _ in pauses if g == 2), "max_ms": round(1000 * max(
                                   (d for _, d in pauses), default=0.0), 2), "total_ms": round(
                                   1000 * sum(d for _, d in pauses), 1)},
                           "share": {k: round(v / wall, 3) for k, v in app.phase.items()},
                           "ms_per_frame": {k: round(1000 * v / n, 2)
                                            for k, v in app.phase.items()}},
                "prediction": {
                    "horizon_ms": round(horizon_ms, 2),
                    "horizon": "auto (the measured lag)" if predict_ms is None else "fixed",
                    "model": "constant velocity, least-squares "
                    f"over {1000 * pc.window_s:.0f} ms, speed clamp {pc.max_speed:.0f} px/s",
                    "error_px_at_horizon": _px(errors),
                    "shadow_lag_ms": {"without": _percentiles(lag_raw),
                                      "with": _percentiles(lag_pred)},
                    "note": "shadow lag: how long before the frame the pen was where the "
                            "frame's shadow is (window pixels, pen path interpolated)"},
                "goals": {"latency_p99_ms": _goal(lat["p99_ms"], GOAL_P99_MS, at_most=True),
                          "fps": _goal(fps, GOAL_FPS, at_most=False)},
            }
        finally:
            driver.terminate()
            try:
                driver.wait(10)
            except subprocess.TimeoutExpired:
                driver.kill()
            app.close()
    return result
