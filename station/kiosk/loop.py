"""The kiosk's loop: one pass (input, a frame with its late latch, steps), its
accounting, the status it publishes, and the end (save, release).

Functions of the app (:class:`~station.kiosk.app.KioskApp`), by job."""

from __future__ import annotations

import ctypes
import dataclasses
import gc
import logging
import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from station.errors import StationError
from station.kiosk import drawing, pen_input
from station.kiosk.config import (
    ATTRACT_FRAME_S,
    GC_AT_LEAST_S,
    GC_EVERY_S,
    GC_PEN_UP_S,
    LATCH_BUDGET_S,
    REDRAW_EVERY_S,
    STATUS_EVERY_S,
    THREAD_POLL_S,
    TILE_FRAME_S,
)

if TYPE_CHECKING:  # the functions take the app; no import at run time (app imports us)
    from station.kiosk.app import KioskApp

log = logging.getLogger(__name__)


def gl_function(name: str) -> Any:
    """A GL entry point through ctypes (released interpreter lock), or ``None``."""
    for lib in ("libGL.so.1", "libOpenGL.so.0"):
        try:
            fn = getattr(ctypes.CDLL(lib), name)
        except (OSError, AttributeError):
            continue
        fn.restype = None
        fn.argtypes = []
        return fn
    return None


@dataclass
class _FrameTimes:
    """``perf_counter`` marks of one frame's parts (all equal to the start when no frame
    is drawn): tiles rendered, UI composed, late latch drained, preview rendered, the
    back buffer filled, shown."""

    start: float
    tiles: float = 0.0
    ui: float = 0.0
    drained: float = 0.0
    preview: float = 0.0
    present: float = 0.0
    shown: float = 0.0

    def __post_init__(self) -> None:
        for name in ("tiles", "ui", "drained", "preview", "present", "shown"):
            setattr(self, name, self.start)


def gl_finish(app: KioskApp) -> None:
    """``glFinish`` through ctypes, which lets the simulation thread run while the GL
    driver completes the frame (moderngl's ``finish`` holds the interpreter lock,
    and llvmpipe rasterises in the call)."""
    if app._glfinish is None:
        app.ctx.finish()
    else:
        app._glfinish()


def quiet_wait_ms(app: KioskApp) -> int:
    """How long a quiet kiosk may wait for the pen: until the next step is due; with
    the simulation thread (which steps on its own), a few ms while paint is wet (its
    steps end any time).  At least a millisecond: a loop that does not wait spins,
    and a spinning loop takes the interpreter lock and a core from the steps."""
    s = app.session
    if app.idle.attract(time.monotonic()):
        return max(1, math.ceil(ATTRACT_FRAME_S * 1000))
    if s.threaded:
        wait = THREAD_POLL_S if s.active_tiles() else REDRAW_EVERY_S
    else:
        p = s.player
        t_next = (p.counters.steps + 1) / p.rate - p.waited
        wait = min(max(t_next - s.now(), 0.0), REDRAW_EVERY_S)
    return max(1, math.ceil(wait * 1000))


def frame(app: KioskApp, dt: float) -> None:
    """One pass of the loop: input, then (if anything changed) a frame with its late
    latch, then steps (see the module docstring).

    A quiet kiosk (no pen, nothing wet) does not redraw 60 times a second: it waits
    on the bus until the next step is due, so a pen sample is handled the moment it
    comes, and it redraws at least every :data:`REDRAW_EVERY_S` (status, banners).
    """
    t0 = time.perf_counter()
    app.glfw.poll_events()
    app._follow_window_size()
    busy, got_input = take_input(app)
    tw = time.perf_counter()
    now = time.monotonic()
    got_input = operator_and_idle(app, now) or got_input
    t1 = time.perf_counter()
    times = _FrameTimes(t1)
    if frame_due(app, now, got_input):
        app.session.frame_begins()  # a step's checkpoint copy waits for it (in pieces)
        try:
            got_input = draw_frame(app, now, dt, times) or got_input
        finally:
            app.session.frame_ends()
    # ImGui spreads pen events queued together over the next frames: draw one more
    app._need_draw = got_input
    steps_or_housekeeping(app)
    t_end = time.perf_counter()
    if busy:  # a pass that did not wait for the bus
        app._last_pass_s = t_end - t0
    account(app, t0, tw, t1, times, t_end)
    maybe_publish_status(app)


def take_input(app: KioskApp) -> tuple[bool, bool]:
    """Wait for the bus as long as the kiosk may (not at all when a frame is due),
    then handle what came; returns (the pass is busy, input came)."""
    s = app.session
    urgent = app._need_draw or bool(app.screenshots)
    busy = (urgent or s.whole_dirty or bool(s.dirty.any()) or app.display.behind())
    received = s.sub.stats.received
    if not busy:
        wait_ms = quiet_wait_ms(app)
    elif urgent:
        wait_ms = 0
    else:  # only the steps' tiles to show: not sooner than TILE_FRAME_S after the last
        # frame, waiting on the bus meanwhile (the pen is shown at once), so the other
        # processes a frame needs (the X server, the driver) get the cores
        wait_ms = max(0, math.ceil(1000 * (TILE_FRAME_S - (time.monotonic()
                                                            - app._last_draw))))
    # handling may take half as long as the last pass took: it keeps up with the pen
    # on a slow pass, and a queue that grew cannot hold the frames back
    s.drain(wait_ms, 0.5 * app._last_pass_s)
    moused = pen_input.feed_mouse(app)
    return busy, s.sub.stats.received != received or moused


def operator_and_idle(app: KioskApp, now: float) -> bool:
    """``station send``'s commands, the drivers' status, a fresh canvas when asked
    for or idle, the panel following the painting's brush; ``True``: the picture
    changed (a fresh canvas)."""
    pen_input.commands(app)
    pen_input.driver_status(app)
    if app._fresh_requested:
        app._fresh_requested = False
        app.fresh_canvas("operator")
    if app.session.painted_stamps > 0:
        app.idle.painted = True
    pen_input.sync_panel(app)
    if app.idle.should_finish(now):
        pid = app.fresh_canvas("idle")
        log.info("idle: painting %s saved to the gallery, fresh canvas", pid)
        return True
    return False


def frame_due(app: KioskApp, now: float, got_input: bool) -> bool:
    """Whether to draw: new stamps come with input (their preview is drawn then); a
    step's changes come as dirty tiles; a quiet kiosk every REDRAW_EVERY_S."""
    s = app.session
    return (app._need_draw or got_input or bool(app.screenshots) or s.whole_dirty
            or bool(s.dirty.any()) or app.display.behind()
            or now - app._last_draw >= REDRAW_EVERY_S
            or view_key(app) != app._drawn_view or app.presenter.owes_whole()
            or (app.idle.attract(now) and now - app._last_draw >= ATTRACT_FRAME_S))


def view_key(app: KioskApp) -> tuple[str, tuple[float, float]]:
    """What the camera depends on: a view changed by any path is drawn at once."""
    return app.panel.view, app.follow_at


def draw_frame(app: KioskApp, now: float, dt: float, times: _FrameTimes) -> bool:
    """Tiles, UI, their composition, the late latch, the preview, present; returns
    whether the late latch took input."""
    s = app.session
    app.frame_pixels = 0
    # not while the simulation thread holds the lock (a step's take of its stamps, its
    # end): the tiles wait for the next frame
    if s.lock.acquire(blocking=bool(app.screenshots)):
        try:
            if app.screenshots:  # a screenshot shows the canvas between steps
                s.wait_step()
            app.display.update_tiles()
            # a screenshot shows the whole canvas as it is, not a frame still catching up
            # with its tiles (the per-frame budget keeps the pen fluid, not a screenshot)
            while app.screenshots and app.display.behind():
                app.display.update_tiles()
        finally:
            s.lock.release()
    else:
        app.display.cells_rendered = 0
    times.tiles = time.perf_counter()
    drawing.build_ui_if_changed(app, now - app._last_draw if app._last_draw else dt)
    cam = drawing.camera(app)
    app._drawn_view = view_key(app)
    drawing.compose_changes(app, cam)
    # the late latch: what the pen sent while the tiles and the UI were drawn is
    # shown in this frame, not the next (what stands between a sample and the
    # screen is only its stamps' preview, their composition and the present)
    times.ui = time.perf_counter()
    n_early = len(s.awaiting_paint)
    received = s.sub.stats.received
    s.drain(0, LATCH_BUDGET_S, floor_s=0.0)
    latched = s.sub.stats.received != received
    times.drained = time.perf_counter()
    with s.window_lock():
        app.display.update_preview()
        # a screenshot shows the whole canvas: the tiles that a large fresh preview left
        # to the next frames' budget are drawn now (between steps)
        while app.screenshots and app.display.behind():
            s.wait_step()
            app.display.update_tiles()
    times.preview = time.perf_counter()
    drawing.compose_changes(app, cam)
    drawing.fill_back_buffer(app, cam)
    for path in app.screenshots:
        drawing.screenshot(app, path)
    app.screenshots.clear()
    times.present = time.perf_counter()
    shown = present(app)
    times.shown = time.perf_counter()
    record_shown(app, shown, times, n_early)
    return latched


def present(app: KioskApp) -> float:
    """The back buffer to the screen, whole or by rectangles; when it was shown."""
    if app._present_rects is None:
        gl_finish(app)
        app.presenter.present_whole()
    else:
        app.presenter.present_rects(app._present_rects)
        gl_finish(app)
    return time.monotonic()


def record_shown(app: KioskApp, shown: float, times: _FrameTimes, n_early: int) -> None:
    """A frame is on screen: the latency of the paint it shows, the prediction's
    horizon from its measured lag, the bench's records."""
    s = app.session
    for t_read in s.awaiting_paint:
        app.latencies.append(shown - t_read)
    if app.tail_log is not None:
        app.tail_log.append((times.shown - times.ui, len(s.awaiting_paint) - n_early))
    if app._cursor_drawn is not None and app.cfg.predict_ms is None:
        lag = shown - app._shadow_read
        if lag <= app.predictor.cfg.stale_s:  # a moving pen (a still one is not
            # predicted, and its lag is only the time it stood still)
            app.predictor.cfg = dataclasses.replace(app.predictor.cfg,
                                                     horizon_s=app.lag.add(lag))
    if app.cursor_log is not None and app._cursor_drawn is not None:
        (rx, ry), (qx, qy) = app._cursor_drawn
        app.cursor_log.append((shown, rx, ry, qx, qy))
    s.awaiting_paint.clear()
    app._last_draw = shown
    app.frames += 1


def steps_or_housekeeping(app: KioskApp) -> None:
    s = app.session
    if s.threaded:
        s.check_worker()
        s.housekeeping()
    else:  # the steps in this loop (after presenting: a step delays the next frame)
        s.run_due_steps(max_steps=2)  # what they change: dirty tiles
    collect_when_pen_up(app, time.monotonic())


def collect_when_pen_up(app: KioskApp, now: float) -> bool:
    """A full garbage collection when it cannot cost the pen a frame (the pen off the
    paper for :data:`GC_PEN_UP_S`, the last one :data:`GC_EVERY_S` ago), or when the
    last is :data:`GC_AT_LEAST_S` old; returns whether it collected (see
    ``KioskApp._take_over_full_collections``)."""
    since = now - app._last_full_gc
    pen_up = not app.touching and now - app._last_touch >= GC_PEN_UP_S
    if not ((pen_up and since >= GC_EVERY_S) or since >= GC_AT_LEAST_S):
        return False
    gc.collect()
    app._last_full_gc = now
    app.full_collections += 1
    return True


def account(app: KioskApp, t0: float, tw: float, t1: float, times: _FrameTimes,
             t_end: float) -> None:
    """The pass's wall time into the phases (the bench's share per phase)."""
    ph = app.phase
    ph["wait"] += tw - t0
    ph["input"] += (t1 - tw) + (times.drained - times.ui)
    ph["render"] += (times.tiles - t1) + (times.preview - times.drained)
    ph["ui"] += (times.ui - times.tiles) + (times.present - times.preview)
    ph["present"] += times.shown - times.present
    ph["sim"] += t_end - times.shown


def run(app: KioskApp) -> dict[str, Any]:
    """Frames until stopped (signal, ``stop`` command, ``duration``)."""
    start = time.monotonic()
    last = start
    failures = 0
    try:
        while not app.stop_requested and not app.session.stop_requested:
            now = time.monotonic()
            if app.cfg.duration is not None and now - start >= app.cfg.duration:
                break
            try:
                frame(app, now - last)
                failures = 0
            except (StationError, OSError, ValueError, RuntimeError) as exc:
                # a kiosk keeps showing the painting: log, count, go on — unless every
                # frame fails, which is a bug to report, not to spin on
                failures += 1
                app.frame_errors += 1
                if failures == 1:
                    log.exception("frame failed: %s", exc)
                if failures >= 100:
                    raise
            last = now
    finally:
        final = kiosk_status(app)
        close(app)
    # close() saves the painting to the gallery: the final status says so (taken
    # before it, it would read "saved": [] for a painting that is in the gallery)
    final["saved"] = list(app.saved)
    return final


def kiosk_status(app: KioskApp) -> dict[str, Any]:
    s = app.session
    st = s.status()
    st.update({
        "process": "kiosk", "view": app.panel.view, "frames": app.frames,
        "sim_thread": s.threaded,
        "frame_errors": app.frame_errors,
        "painting_id": s.painting_id, "resumed": s.resumed,
        "painted_stamps": s.painted_stamps, "saved": list(app.saved),
        "qr_url": app.qr_url, "driver_state": app.driver_state,
        "driver_events": list(app.driver_events), "pen_missing": pen_input.pen_missing(app),
        "attract": app.idle.attract(time.monotonic()), "ui": dict(app.rects),
        "window": list(app.size), "canvas_rect": drawing.canvas_rect(app), "panel": {
            "mix": dict(app.panel.mix), "size": app.panel.size,
            "water": app.panel.water, "strength": app.panel.strength,
            "confirm_clear": app.panel.confirm_clear, "eraser": app.panel.eraser,
            "mixing": app.panel.mixing,
            "pressed": list(app.panel.pressed)},
        "player_commands": dict(s.player.counters.commands),
        "skipped_commands": dict(s.player.counters.skipped_commands),
        "brush": s.player.brush.settings.to_args(),
        "wet_fraction": s.wet_fraction(),
        **moisture_status(app),
        "gallery_url": app.base_url,
    })
    return st


def moisture_status(app: KioskApp) -> dict[str, Any]:
    m = app.session.moisture()
    if m is None:
        return {"paper": None, "damp_fraction": None}
    return {"paper": m.word, "damp_fraction": m.damp}


def maybe_publish_status(app: KioskApp) -> None:
    now = time.monotonic()
    if app.pub is None or now < app._next_status:
        return
    app._next_status = now + STATUS_EVERY_S
    try:
        app.pub.publish_status(kiosk_status(app))
    except Exception as exc:  # status is best effort; the kiosk goes on
        log.warning("cannot publish status: %s", exc)


def install_signal_handlers(app: KioskApp) -> None:
    import signal

    def on_signal(signum: int, frame: Any) -> None:
        app.stop_requested = True

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)


def close(app: KioskApp) -> None:
    """Save the painting (the operator stopped the kiosk), release everything."""
    try:
        app.finish_painting("stopped")
    finally:
        app._release_live_log()
        if app.pub is not None:
            try:
                app.pub.publish_status({**kiosk_status_safe(app), "state": "stopped"})
            except Exception:
                pass
            app.pub.close()
        app.driver_sub.close()
        if app.cmd_sub is not None:
            app.cmd_sub.close()
        if app.server is not None:
            app.server.stop()
        app.display.release()
        app.compositor.release()
        app.gui.close()
        app.glfw.destroy_window(app.window)
        app.glfw.terminate()


def kiosk_status_safe(app: KioskApp) -> dict[str, Any]:
    return {"process": "kiosk", "saved": list(app.saved), "frames": app.frames}
