"""The kiosk window and its frame loop.

One process: glfw window + moderngl context, the simulation of the current
painting (:class:`~station.kiosk.session.KioskSession`, fed by the bus; its
steps in a thread of their own), the canvas display, the ImGui panel.  A pass
of the window's loop:

1. take the messages waiting on the bus, for a bounded time (pen samples are
   mapped through the view: over the panel they go to ImGui, over the canvas
   to the brush);
2. if anything changed: re-render changed tiles (for at most a time budget),
   build the UI if it changed, and compose those changes
   (:mod:`station.kiosk.compose`);
3. the late latch: take the pen samples that came meanwhile, render the
   preview of the stamps not yet simulated, compose it, draw the brush's shadow
   where the pen is predicted to be (:mod:`station.kiosk.predict`) and present
   (:mod:`station.kiosk.present`: the whole window, or only the changed
   rectangles) — the driver read time of every sample that made paint is now
   shown (latency);
4. housekeeping (or, with ``sim_thread=False``, the due steps: after
   presenting, so a step's cost delays the next frame, not the paint that just
   arrived).

A visitor cannot leave: no title bar in fullscreen, the window's close request
is refused, no key does anything.  The operator ends the kiosk with SIGTERM /
SIGINT or a ``stop`` command on the bus; the painting is saved to the gallery.

The app is in parts by job: here the start-up and the paintings' sessions;
:mod:`station.kiosk.pen_input` (pen, mouse, commands), :mod:`station.kiosk.drawing`
(scene, shadow, UI, composition), :mod:`station.kiosk.loop` (a pass, status, the end),
:mod:`station.kiosk.config` (settings) and :mod:`station.kiosk.livelog` (resuming).
"""

from __future__ import annotations

import dataclasses
import gc
import logging
import math
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from station.bus import Publisher, Subscriber
from station.canvas.palette import default_palette
from station.canvas.profiles import get_profile
from station.errors import BadInput, StationError
from station.events import Command, PenSample
from station.kiosk import drawing, loop, mouse, pen_input, subcell
from station.kiosk import warm as kiosk_warm
from station.kiosk.attract import AttractShow
from station.kiosk.compose import Box, Compositor
from station.kiosk.config import (
    AUTO_HORIZON_START_S,
    GC_GEN2_THRESHOLD,
    KioskConfig,
    numba_threadsafe,
)
from station.kiosk.display import CpuDisplay, GpuDisplay, make_display
from station.kiosk.drawing import FLAT_FRAG, FLAT_VERT
from station.kiosk.gallery import (
    Gallery,
    GalleryServer,
    default_base_url,
    new_id,
    painting_url,
    qr_matrix,
)
from station.kiosk.idle import IdleClock
from station.kiosk.livelog import hold_live_log, painting_in_progress
from station.kiosk.loop import gl_function
from station.kiosk.predict import LagEstimate, PenPredictor, PredictConfig
from station.kiosk.present import PRESENT_MODES, Presenter
from station.kiosk.session import KioskSession
from station.kiosk.ui import PanelState
from station.kiosk.views import VIEWS, Camera, Viewport
from station.render.km import to_srgb8
from station.sim.live import KIOSK_CMD_ENDPOINT, LiveConfig, default_status_endpoint

if TYPE_CHECKING:  # imgui-bundle is an optional extra (imported where the window opens)
    from station.glkit.imgui_gl import UiTriangles

__all__ = ["KioskApp", "KioskConfig", "hold_live_log", "numba_threadsafe", "painting_in_progress"]

log = logging.getLogger(__name__)


class KioskApp:
    """The window, the current painting, the panel, the gallery (see module docstring)."""

    def __init__(self, cfg: KioskConfig) -> None:
        try:
            import glfw  # optional extra (painting-station[kiosk])
            import moderngl  # optional extra
        except ImportError as exc:
            raise StationError(f"the kiosk needs glfw and moderngl ({exc}); "
                               "pip install 'painting-station[kiosk]'") from None
        self.cfg = self._checked_config(cfg)
        self.glfw = glfw
        # the window's thread gets the interpreter back from the simulation thread's
        # Python within half a millisecond (the default 5 ms would be a third of a 60 Hz
        # frame, and every bus read gives it up)
        sys.setswitchinterval(0.0005)
        self.window = self._open_window(glfw, self.cfg)
        self.ctx: Any = moderngl.create_context()
        self._lay_out()
        self._programs()
        self._open_gallery()
        self._open_endpoints()
        self._make_panel()
        self._init_frame_state()
        self._take_the_mouse()
        self.session: KioskSession = self._new_session(painting_in_progress(self.live_dir))
        self.display: CpuDisplay | GpuDisplay = make_display(self.ctx, self.session)
        self._warm_kernels()
        self.compositor = Compositor(self.ctx, self.size)
        self.presenter = Presenter(glfw, self.window, str(self.ctx.info.get("GL_RENDERER", "")),
                                   self.size, self.cfg.present, self.cfg.vsync)
        self._take_over_full_collections()

    # -- start-up, in parts -----------------------------------------------------------
    def _warm_kernels(self) -> None:
        """Every compiled kernel a visitor's strokes, brushes and the display run, called
        once now (:mod:`station.kiosk.warm`): loaded from numba's cache in about a second,
        or compiled here, before the first frame, not in the first visitor's stroke."""
        backend = "cpu" if self.session.backend_name == "cpu" else "numpy"
        try:
            took = kiosk_warm.warm(backend, self.cfg.profile,
                                   display=isinstance(self.display, CpuDisplay))
        except StationError as exc:  # a warm-up only: the visitor's first stroke compiles
            log.warning("kiosk: warming the kernels failed (%s); they compile on first use",
                        exc)
            return
        log.info("kiosk: kernels ready in %.1f s", took)

    def _take_over_full_collections(self) -> None:
        """What start-up made (modules, numba's and ImGui's objects, the window) lives as
        long as the process: frozen out of the collector's sight, so a full collection
        walks only what painting made since; and full collections come from the loop,
        while the pen is up (:func:`station.kiosk.loop.collect_when_pen_up`), not
        whenever the survivors grew."""
        gc.collect()
        gc.freeze()
        g0, g1, _ = gc.get_threshold()
        gc.set_threshold(g0, g1, GC_GEN2_THRESHOLD)
        self._last_full_gc = time.monotonic()

    @staticmethod
    def _checked_config(cfg: KioskConfig) -> KioskConfig:
        """``cfg`` checked (bad input: :class:`BadInput`), with the simulation in the
        frame loop where numba's threading layer cannot run two threads' kernels."""
        if cfg.present not in PRESENT_MODES:
            raise BadInput(f"unknown present mode {cfg.present!r} (one of "
                           f"{', '.join(PRESENT_MODES)})", "--present")
        if cfg.view not in VIEWS:
            raise BadInput(f"unknown view {cfg.view!r} (one of {', '.join(VIEWS)})", "--view")
        if cfg.input not in mouse.INPUTS:
            raise BadInput(f"unknown input {cfg.input!r} (one of {', '.join(mouse.INPUTS)})",
                           "--input")
        # the simulation's OpenMP workers sleep as soon as a parallel loop ends instead
        # of spinning for the next: spinning, they take the cores the window's thread
        # needs to show the pen (read when OpenMP starts, so before the first kernel)
        os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
        if cfg.sim_thread and not numba_threadsafe():
            log.warning("numba's threading layer is not thread-safe here (install tbb): "
                        "the simulation steps in the frame loop")
            cfg = dataclasses.replace(cfg, sim_thread=False)
        return cfg

    @staticmethod
    def _open_window(glfw: Any, cfg: KioskConfig) -> Any:
        """The window (fullscreen on ``cfg.monitor``, or ``cfg.window``) with its GL
        context current; a visitor cannot close it."""
        if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
            raise StationError("no display: the kiosk needs X or Wayland (try Xvfb)")
        if not glfw.init():
            raise StationError("glfw could not initialise (no display?)")
        gl43 = cfg.backend == "gl"
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 4 if gl43 else 3)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        monitor = None
        width, height = cfg.window
        if cfg.fullscreen:
            monitors = glfw.get_monitors() or []
            if not 0 <= cfg.monitor < len(monitors):
                glfw.terminate()
                raise BadInput(f"monitor {cfg.monitor} does not exist ({len(monitors)} "
                               "connected)", "--monitor")
            monitor = monitors[cfg.monitor]
            mode = glfw.get_video_mode(monitor)
            width, height = mode.size.width, mode.size.height
        window = glfw.create_window(width, height, "station kiosk", monitor, None)
        if not window:
            glfw.terminate()
            raise StationError("glfw could not open a window"
                               + (" with OpenGL 4.3 (the gl backend needs it)" if gl43 else ""))
        glfw.make_context_current(window)
        glfw.swap_interval(1 if cfg.vsync else 0)
        # a visitor cannot close the kiosk: refuse every close request
        glfw.set_window_close_callback(window, lambda w: glfw.set_window_should_close(w, False))
        if cfg.fullscreen:
            glfw.set_input_mode(window, glfw.CURSOR, glfw.CURSOR_HIDDEN)
        return window

    def _lay_out(self) -> None:
        """The window's size, the panel's width, the canvas's area, the ImGui layer."""
        fb = self.glfw.get_framebuffer_size(self.window)
        self.size: tuple[int, int] = (int(fb[0]), int(fb[1]))
        w, h = self.size
        self._place_panel()
        self.aspect = self.cfg.width / self.cfg.height
        # imgui-bundle is an optional extra (painting-station[kiosk]), like glfw
        from station.glkit.imgui_gl import ImGuiLayer

        self.gui = ImGuiLayer(self.ctx, (w, h), scale=max(1.5, h / 480))

    def _place_panel(self) -> None:
        w, h = self.size
        self.panel_w = int(max(300, w * self.cfg.panel_fraction))
        self.area = Viewport(self.panel_w, 0, w - self.panel_w, h)

    def _take_the_mouse(self) -> None:
        """The mouse (or a touchscreen's pointer) paints too (:mod:`station.kiosk.mouse`)
        unless ``--input pen``."""
        self.mouse = mouse.MousePen(self.size, self.cfg.mouse_pressure)
        self._pen_heard = -math.inf  # monotonic time of the last sample from a pen driver
        if self.cfg.input == "pen":
            return
        glfw = self.glfw
        glfw.set_cursor_pos_callback(self.window, self.on_cursor)
        glfw.set_mouse_button_callback(self.window, self.on_mouse_button)
        glfw.set_cursor_enter_callback(self.window, self.on_cursor_enter)

    def _open_gallery(self) -> None:
        """The gallery, its live directory (logs and autosaves of paintings in progress)
        and its web page's server."""
        cfg = self.cfg
        self.gallery = Gallery(cfg.gallery)
        self.live_dir = self.gallery.root / ".live"
        self.live_dir.mkdir(exist_ok=True)
        self.server: GalleryServer | None = None
        base_url = cfg.base_url
        if cfg.serve:
            host, _, port = cfg.serve.rpartition(":")
            self.server = GalleryServer(self.gallery, host or "127.0.0.1", int(port),
                                        base_url, cfg.web).start()
            if base_url is None:
                base_url = default_base_url(self.server.port, host or "127.0.0.1")
        self.base_url = base_url or "http://127.0.0.1:8080"

    def _open_endpoints(self) -> None:
        """The status publisher, the drivers' status, ``station send``'s endpoint (the
        paintings' sessions come and go; these stay)."""
        cfg = self.cfg
        status_ep = cfg.status or default_status_endpoint(cfg.bus)
        keys, client_key = cfg.keys, cfg.client_key  # CURVE, used on tcp only
        self.pub = None if status_ep == "none" else Publisher(status_ep, keys=keys,
                                                              client_key=client_key)
        self.driver_sub = Subscriber(cfg.bus, topics=("status",), keys=keys,
                                     client_key=client_key)
        # `station send` reaches the kiosk here (the sessions come and go; this stays)
        cmd_ep = cfg.cmd or "@" + KIOSK_CMD_ENDPOINT  # never the sim's: see station.answer
        self.cmd_sub = None if cmd_ep == "none" else Subscriber(
            cmd_ep if cmd_ep[0] in "@>" else "@" + cmd_ep, topics=("cmd",), keys=keys,
            client_key=client_key, answers="tcp://" in cmd_ep)  # tcp: station.answer "peer"

    def _make_panel(self) -> None:
        """The panel, with the profile's brush, and the idle clock."""
        brush = get_profile(self.cfg.profile).brush
        self.panel = PanelState(default_palette(), self._send, self.save_now,
                                view=self.cfg.view, mix={brush.pigment: 1.0},
                                size=2.0 * brush.radius,
                                can_undo=lambda: self.session.history.can_undo())
        self.rects: dict[str, Any] = {}
        self.idle = IdleClock(self.cfg.idle, time.monotonic())

    def _init_frame_state(self) -> None:
        """What the loop keeps between frames: the pen, the driver, the gallery's
        saves, the bench's records, the caches of the UI, compositing and presenting."""
        # the attract screen (station.kiosk.attract)
        self.attract_show = AttractShow(self.cfg.gallery)
        self._attracting = False
        self._attract_tex: tuple[int, tuple[int, int], Any] | None = None
        # the pen and what it holds
        self.stop_requested = False
        self.capture: str | None = None  # "ui" or "canvas" while the tip is down
        self.hover: tuple[float, float] | None = None  # canvas (u, v) of the pen
        self.touching = False
        self.follow_at = (0.5, 0.5)
        self.lag = LagEstimate(initial=AUTO_HORIZON_START_S)
        cfg = self.cfg
        self.predictor = PenPredictor(PredictConfig(
            horizon_s=self.lag.value if cfg.predict_ms is None else max(cfg.predict_ms, 0.0)
            / 1000))
        self._pen_received = 0.0  # monotonic time the last pen sample came
        self._last_touch = 0.0  # ... the last that touched the paper
        self._last_full_gc = 0.0  # ... the last full garbage collection
        self.full_collections = 0  # made by the loop (collect_when_pen_up)
        self._pen_read = 0.0  # ... and when its driver read it (monotonic)
        self._shadow_read = 0.0  # the read time of the sample this frame's shadow is from
        # the driver, the gallery, the operator
        self.driver_state = "unknown"
        self.driver_seen = 0.0
        self.driver_events: list[str] = []
        self.saved: list[str] = []
        self.makers: list[subprocess.Popen[bytes]] = []  # replays and prints being made
        self.qr: tuple[int, tuple[int, int]] | None = None  # ImGui texture id, size
        self.qr_url: str | None = None
        self.qr_texture: Any = None
        self.screenshots: list[Path] = []
        self._fresh_requested = False  # an operator's "fresh" command
        # counts and the latency bench's records: pen samples (read time, device time, x,
        # y, touching) in window pixels, and per frame (shown, last sample's x, y, the
        # shadow's predicted x, y); per frame: seconds from the late latch to shown,
        # samples that made paint in it
        self.frames = 0
        self.frame_errors = 0
        self.latencies: list[float] = []
        self.phase = {"wait": 0.0, "input": 0.0, "sim": 0.0, "render": 0.0, "ui": 0.0,
                      "present": 0.0}
        self.pen_log: list[tuple[float, float, float, float, bool]] | None = None
        self.cursor_log: list[tuple[float, float, float, float, float]] | None = None
        self.tail_log: list[tuple[float, int]] | None = None
        self._cursor_drawn: tuple[tuple[float, float], tuple[float, float]] | None = None
        # the loop's pace
        self._need_draw = True
        self._last_draw = 0.0
        self._last_pass_s = 0.0  # wall time of the last pass of the loop
        self._next_status = 0.0
        self._status_due = 0.0
        self._status_cache = ""
        self._brush_key: tuple[Any, ...] | None = None
        self._drawn_view: tuple[str, tuple[float, float]] | None = None
        self._glfinish = gl_function("glFinish")
        self._glflush = gl_function("glFlush")
        # the UI is built only when what it shows may have changed (compose)
        self._ui_last_key: tuple[Any, ...] | None = None
        self._ui_built = 0.0
        self._ui_hash = 0
        self._ui_bounds: Box | None = None
        self._ui_tris: UiTriangles | None = None  # its triangles (where the UI changed)
        # compositing and presenting
        self._frame_boxes: list[Box] = []  # what this frame redrew in the picture
        self.frame_pixels = 0  # ... in pixels (both compositions of the frame)
        self._frame_full = False  # ... everything (a new camera)
        self._present_rects: list[Box] | None = None  # this frame's partial present
        self._shadow_box: Box | None = None  # where the last frame drew the shadow
        self._last_whole = 0.0  # monotonic time of the last whole present

    # -- GL programs -------------------------------------------------------------
    def _follow_window_size(self) -> None:
        """A window resized (a window manager, a monitor's mode, an operator) is laid out
        and drawn anew at its new size: the picture's framebuffer, the panel, the
        presenter all follow (kept at the old size, the window showed black bands along
        its right and bottom edges and stale parts of the old picture)."""
        fb = self.glfw.get_framebuffer_size(self.window)
        size = (int(fb[0]), int(fb[1]))
        if size == self.size or size[0] <= 0 or size[1] <= 0:  # same, or minimised
            return
        log.info("window resized to %dx%d", *size)
        self.size = size
        self._place_panel()
        self.gui.resize(size)
        self.mouse.size = size
        self.compositor.release()
        self.compositor = Compositor(self.ctx, size)
        self.presenter.resized(size)
        self._frame_boxes, self._shadow_box = [], None
        self._ui_last_key = None  # the panel is built again for the new size
        self._need_draw = True

    def _programs(self) -> None:
        ctx = self.ctx
        self.canvas_prog = ctx.program(vertex_shader=subcell.CANVAS_VERT,
                                       fragment_shader=subcell.CANVAS_FRAG)
        self.flat_prog = ctx.program(vertex_shader=FLAT_VERT, fragment_shader=FLAT_FRAG)
        a = self.aspect / 2
        quad = np.array([[-a, 0.5, 0, 0, 0], [a, 0.5, 0, 1, 0], [-a, -0.5, 0, 0, 1],
                         [a, -0.5, 0, 1, 1]], "f4")  # uv row 0 = canvas top
        self.canvas_vbo = ctx.buffer(quad.tobytes())
        self.canvas_vao = ctx.vertex_array(self.canvas_prog,
                                           [(self.canvas_vbo, "3f 2f", "pos", "uv")])
        self.flat_vbo = ctx.buffer(reserve=4096 * 12, dynamic=True)
        self.flat_vao = ctx.vertex_array(self.flat_prog, [(self.flat_vbo, "3f", "pos")])

    # -- sessions (one per painting) ---------------------------------------------------
    def _new_session(self, resume: Path | None = None) -> KioskSession:
        """A fresh painting, or (``resume``: its live log) the painting in progress that a
        killed or restarted kiosk left: its autosave plus the log since, replayed exactly
        (:mod:`station.sim.recovery`), the log continued."""
        cfg = self.cfg
        pid = resume.stem if resume is not None else new_id()
        opts: dict[str, Any] = {"ctx": self.ctx} if cfg.backend == "gl" else {}
        live = LiveConfig(bus=cfg.bus, width=cfg.width, height=cfg.height, profile=cfg.profile,
                          backend=cfg.backend, seed=cfg.seed, rate=cfg.rate,
                          log_path=str(self.live_dir / f"{pid}.jsonl"), status="none",
                          cmd="none", autosave=cfg.autosave, backend_opts=opts,
                          keys=cfg.keys, client_key=cfg.client_key,
                          recover=str(resume) if resume is not None else None)
        session = KioskSession(live, map_pen=self._map_pen, kiosk_command=self._kiosk_command)
        session.resumed = resume is not None
        pub = self.pub
        if pub is not None:  # the deformable brush's reaction to haptic devices
            session.haptics.send = pub.publish_haptic
            session.haptics.wanted = lambda name: pub.wants(f"haptic.{name}")
        session.painting_id = pid
        self._release_live_log()
        self._live_lock = hold_live_log(session.log_path)
        self.session = session
        if resume is None:
            self.panel.apply_brush()  # the visitor's brush carries over, logged first
        self.idle.fresh(time.monotonic())
        self.idle.painted = session.resumed
        self._set_qr(None)
        if cfg.sim_thread:
            session.start_worker(cfg.sim_nice)
        return session

    def _release_live_log(self) -> None:
        fd, self._live_lock = getattr(self, "_live_lock", None), None
        if fd is not None:
            os.close(fd)

    def _send(self, name: str, args: dict[str, Any]) -> None:
        session = getattr(self, "session", None)
        if session is not None:
            session.command(name, **args)

    def _meta(self, reason: str) -> dict[str, Any]:
        s = self.session
        st = s.status()
        return {"width": s.cfg.width, "height": s.cfg.height, "profile": s.player.profile,
                "backend": s.backend_name, "seed": s.cfg.seed, "started": s.started_wall,
                "reason": reason, "steps": st["steps"], "samples": st["samples"],
                "commands": st["commands"], "stamps": st["stamps"],
                "painting_seconds": st["painting_time"]}

    def _render_srgb8(self) -> np.ndarray:
        return to_srgb8(self.session.render_between_steps())

    def save_now(self) -> str:
        """Save the painting so far to the gallery (the visitor's Save); shows its QR."""
        s = self.session
        pid = s.painting_id
        s.journal.sync()  # the copy in the gallery holds every record so far
        try:
            self.gallery.save(pid, self._render_srgb8(), s.log_path, self._meta("save"))
        except (OSError, StationError) as exc:  # the painting goes on; its log is kept
            log.error("cannot save painting %s to the gallery: %s", pid, exc)
            self.panel.message = "Sorry, the painting could not be saved just now."
            return pid
        self.saved.append(pid)
        self._make_extras(pid)
        self._set_qr(painting_url(self.base_url, pid))
        return pid

    def finish_painting(self, reason: str) -> str | None:
        """Save the painting to the gallery (if anything was painted) and start afresh."""
        s = self.session
        s.stop_worker()
        pid = s.painting_id
        painted = s.painted_stamps > 0 or s.resumed or pid in self.saved
        meta = self._meta(reason)
        s.shutdown()  # log end marker, log closed
        stored = True
        if painted:
            try:
                self.gallery.save(pid, self._render_srgb8(), s.log_path, meta)
                self.saved.append(pid)
                self._make_extras(pid)
            except (OSError, StationError) as exc:
                # the session log stays in <gallery>/.live: `station paint` repaints it
                log.error("cannot save painting %s to the gallery (%s); its log is kept in %s",
                          pid, exc, s.log_path)
                stored = False
        close = getattr(s.canvas, "close", None)
        if close is not None:
            close()
        if stored:  # in the gallery now (or nothing was painted): the live files go
            self._release_live_log()
            Path(s.log_path).unlink(missing_ok=True)
            Path(s.autosave_path).unlink(missing_ok=True)
        return pid if painted and stored else None

    def _make_extras(self, pid: str) -> None:
        """Start the replay and print of ``pid`` in a low-priority process of its own
        (:meth:`Gallery.prepare`); finished ones are reaped here too."""
        self.makers = [p for p in self.makers if p.poll() is None]
        try:
            self.makers.append(self.gallery.prepare(pid))
        except OSError as exc:  # the page makes the replay when asked; no print then
            log.warning("cannot start the replay of painting %s: %s", pid, exc)

    def fresh_canvas(self, reason: str) -> str | None:
        pid = self.finish_painting(reason)
        self.session = self._new_session()
        self.display.bind(self.session)
        return pid

    def _set_qr(self, url: str | None) -> None:
        self.qr_url = url
        if url is None:
            self.qr = None
            return
        m = qr_matrix(url)
        img = np.where(m[:, :, None] > 0, 0, 255).astype(np.uint8).repeat(4, axis=2)
        img[..., 3] = 255
        img = img.repeat(8, axis=0).repeat(8, axis=1)  # crisp modules when scaled
        if self.qr_texture is not None:
            self.qr_texture.release()
        self.qr_texture = self.ctx.texture((img.shape[1], img.shape[0]), 4, img.tobytes())
        self.qr_texture.filter = (self.ctx.NEAREST, self.ctx.NEAREST)
        self.qr = (self.gui.add_texture(self.qr_texture), (img.shape[1], img.shape[0]))

    # -- the parts elsewhere, by job (pen_input, drawing, loop) ----------------------
    def on_cursor(self, window: Any, x: float, y: float) -> None:
        """See :func:`station.kiosk.pen_input.on_cursor`."""
        pen_input.on_cursor(self, window, x, y)

    def on_mouse_button(self, window: Any, button: int, action: int, mods: int) -> None:
        """See :func:`station.kiosk.pen_input.on_mouse_button`."""
        pen_input.on_mouse_button(self, window, button, action, mods)

    def on_cursor_enter(self, window: Any, entered: int) -> None:
        """See :func:`station.kiosk.pen_input.on_cursor_enter`."""
        pen_input.on_cursor_enter(self, window, entered)

    def _map_pen(self, s: PenSample) -> PenSample | None:
        """See :func:`station.kiosk.pen_input.map_pen`."""
        return pen_input.map_pen(self, s)

    def _kiosk_command(self, cmd: Command) -> bool:
        """See :func:`station.kiosk.pen_input.kiosk_command`."""
        return pen_input.kiosk_command(self, cmd)

    def pen_missing(self) -> bool:
        """See :func:`station.kiosk.pen_input.pen_missing`."""
        return pen_input.pen_missing(self)

    def camera(self) -> Camera:
        """See :func:`station.kiosk.drawing.camera`."""
        return drawing.camera(self)

    def draw_scene(self, cam: Camera, clip: Box | None = None) -> None:
        """See :func:`station.kiosk.drawing.draw_scene`."""
        drawing.draw_scene(self, cam, clip)

    def reference_picture(self) -> np.ndarray:
        """See :func:`station.kiosk.drawing.reference_picture`."""
        return drawing.reference_picture(self)

    def canvas_rect(self) -> list[float]:
        """See :func:`station.kiosk.drawing.canvas_rect`."""
        return drawing.canvas_rect(self)

    def build_ui(self, dt: float) -> int:
        """See :func:`station.kiosk.drawing.build_ui`."""
        return drawing.build_ui(self, dt)

    def frame(self, dt: float) -> None:
        """See :func:`station.kiosk.loop.frame`."""
        loop.frame(self, dt)

    def run(self) -> dict[str, Any]:
        """See :func:`station.kiosk.loop.run`."""
        return loop.run(self)

    def kiosk_status(self) -> dict[str, Any]:
        """See :func:`station.kiosk.loop.kiosk_status`."""
        return loop.kiosk_status(self)

    def close(self) -> None:
        """See :func:`station.kiosk.loop.close`."""
        loop.close(self)

    def install_signal_handlers(self) -> None:
        """See :func:`station.kiosk.loop.install_signal_handlers`."""
        loop.install_signal_handlers(self)

    def maybe_publish_status(self) -> None:
        """See :func:`station.kiosk.loop.maybe_publish_status`."""
        loop.maybe_publish_status(self)

    def _gl_finish(self) -> None:
        """See :func:`station.kiosk.loop.gl_finish`."""
        loop.gl_finish(self)

    def status_line(self) -> str:
        """See :func:`station.kiosk.drawing.status_line`."""
        return drawing.status_line(self)

    def cursor_shape(self, cam: Camera) -> tuple[np.ndarray, tuple[float, ...]] | None:
        """See :func:`station.kiosk.drawing.cursor_shape`."""
        return drawing.cursor_shape(self, cam)
