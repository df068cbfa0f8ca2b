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
"""

from __future__ import annotations

import ctypes
import dataclasses
import fcntl
import logging
import math
import os
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from station.bus import Publisher, Subscriber
from station.canvas.palette import default_palette
from station.canvas.profiles import get_profile
from station.errors import BadInput, StationError
from station.events import Command, PenSample, Tool
from station.kiosk import mouse, subcell
from station.kiosk.attract import INVITATION, AttractShow, demo_stroke
from station.kiosk.commands import MESSAGE_MAX, check_kiosk_command, is_kiosk_command
from station.kiosk.compose import Box, Compositor, merge_rects, screen_box
from station.kiosk.display import CpuDisplay, GpuDisplay, make_display
from station.kiosk.gallery import (
    Gallery,
    GalleryServer,
    WebOptions,
    default_base_url,
    new_id,
    painting_url,
    qr_matrix,
)
from station.kiosk.idle import IdleClock, IdleConfig
from station.kiosk.predict import LagEstimate, PenPredictor, PredictConfig
from station.kiosk.present import PRESENT_MODES, Presenter
from station.kiosk.session import KioskSession
from station.kiosk.ui import PanelState, draw_attract, draw_banner, draw_panel, draw_qr
from station.kiosk.views import VIEWS, Camera, Viewport, input_camera, make_camera
from station.render.km import to_srgb8
from station.sim.journal import autosave_path
from station.sim.live import KIOSK_CMD_ENDPOINT, LiveConfig, default_status_endpoint

log = logging.getLogger(__name__)

DRIVER_SILENT_S = 5.0  # a driver that said nothing this long is taken as gone
STATUS_EVERY_S = 0.5
REDRAW_EVERY_S = 0.25  # a quiet kiosk still redraws this often (status line, banners)
AUTO_HORIZON_START_S = 0.008  # the auto prediction's horizon until frames measured it
TILE_FRAME_S = 1 / 120  # frames that show only the steps' tiles come at most this often
LATCH_BUDGET_S = 0.002  # the late latch handles pen samples for at most this long
THREAD_POLL_S = 0.004  # a wet canvas: how often the window looks for the thread's steps
ATTRACT_FRAME_S = 1 / 12  # the attract screen's animation: frames this often

FLAT_VERT = """
#version 330
uniform mat4 vp;
in vec3 pos;
void main() { gl_Position = vp * vec4(pos, 1.0); }
"""
FLAT_FRAG = """
#version 330
uniform vec4 color;
out vec4 frag;
void main() { frag = color; }
"""

BACKGROUND = (0.13, 0.13, 0.15)
TABLE = (0.42, 0.29, 0.18, 1.0)
SHADOW = (0.0, 0.0, 0.0, 0.28)
CURSOR_TOUCH = (0.1, 0.1, 0.1, 0.55)


@dataclass
class KioskConfig:
    """Settings of one ``station kiosk`` run."""

    bus: str | None = None
    width: int = 800
    height: int = 600
    profile: str = "watercolor"
    backend: str = "auto"
    seed: int = 0
    rate: float | None = None
    fullscreen: bool = True
    monitor: int = 0
    window: tuple[int, int] = (1024, 768)
    gallery: Path = Path("gallery")
    # HOST:PORT of the gallery web page (loopback unless the operator names the kiosk's
    # address); None: no server.  web: what it serves and its limits.
    serve: str | None = "127.0.0.1:8080"
    web: WebOptions = field(default_factory=WebOptions)
    base_url: str | None = None  # what QR codes point to (default: this machine's address)
    idle: IdleConfig = field(default_factory=IdleConfig)
    status: str | None = None  # status endpoint; "none" disables
    duration: float | None = None
    screenshot_dir: Path | None = None
    view: str = "2d"
    vsync: bool = True
    panel_fraction: float = 0.3
    cmd: str | None = None  # where `station send` reaches the kiosk; "none" disables
    autosave: float = 30.0  # seconds between autosaves of the painting (0: off)
    sim_thread: bool = True  # steps in a thread of their own (False: in the frame loop)
    # the pen shadow drawn this far ahead of the last sample (0: off; None: auto, the
    # window's own measured pen-to-screen lag, station.kiosk.predict.LagEstimate)
    predict_ms: float | None = None
    present: str = "auto"  # auto, swap, partial (station.kiosk.present)
    # what paints besides a pen driver on the bus: the window's mouse/touchscreen
    # ("auto": yes, unless a pen was heard in the last second; "pen": no; "mouse": yes)
    input: str = "auto"
    mouse_pressure: float | None = 0.6  # the mouse's pressure (None: from its speed)
    keys: Path | None = None  # CURVE key directory for tcp endpoints (None: the default)
    client_key: str | None = None  # a client key pair of its own for connecting over tcp


def numba_threadsafe() -> bool:
    """Whether numba's threading layer lets two threads launch parallel kernels at once
    (``omp``, ``tbb``; the fallback ``workqueue`` aborts the process if they do)."""
    try:
        import numba
        from numba.np.ufunc import parallel

        parallel._launch_threads()
        return str(numba.threading_layer()) in ("omp", "tbb")
    except Exception:  # an unknown numba: assume the worst
        return False


def painting_in_progress(live_dir: Path) -> Path | None:
    """The live log of the painting a killed or restarted kiosk left in ``live_dir``, or
    ``None``: the newest log that holds a stroke (the tip down on the paper).  A log
    without one is a fresh canvas nobody painted on (an idle kiosk saves its painting
    and starts such a one): it and its autosave go, and the kiosk starts fresh."""
    logs = sorted(live_dir.glob("*.jsonl"), key=lambda p: p.stat().st_mtime, reverse=True)
    found: Path | None = None
    for path in logs:
        if _held_by_another(path):  # a kiosk beside this one paints on it (one gallery)
            continue
        if not _has_stroke(path):
            path.unlink(missing_ok=True)
            autosave_path(path).unlink(missing_ok=True)
        elif found is None:
            found = path
        else:  # an older crash's painting: kept for the operator (station paint repaints it)
            log.warning("an older painting in progress is left in %s", path)
    return found


def hold_live_log(path: Path) -> int | None:
    """An exclusive lock on a live log for as long as this kiosk paints on it (the file
    descriptor; the system lets go when the process dies, ``kill -9`` included): another
    kiosk on the same gallery neither resumes nor removes it."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_CREAT, 0o600)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        return None
    return fd


def _held_by_another(path: Path) -> bool:
    fd = hold_live_log(path)
    if fd is None:
        return path.exists()
    os.close(fd)  # closing lets the lock go
    return False


def _has_stroke(path: Path) -> bool:
    """Whether the session log at ``path`` holds a pen sample with the tip down."""
    try:
        with path.open("rb") as f:
            for line in f:
                if b'"touching": true' in line or b'"touching":true' in line:
                    return True
    except OSError:
        return False
    return False


def _gl_function(name: str) -> Any:
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
        self.compositor = Compositor(self.ctx, self.size)
        self.presenter = Presenter(glfw, self.window, str(self.ctx.info.get("GL_RENDERER", "")),
                                   self.size, self.cfg.present, self.cfg.vsync)

    # -- start-up, in parts -----------------------------------------------------------
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

    def _mouse_time(self) -> tuple[float, float]:
        now = time.monotonic()
        return now - self.session.started_mono, now

    def on_cursor(self, window: Any, x: float, y: float) -> None:
        """glfw: the pointer moved to window pixel (x, y)."""
        self.mouse.move(float(x), float(y), *self._mouse_time())

    def on_mouse_button(self, window: Any, button: int, action: int, mods: int) -> None:
        """glfw: a button went down or up (the left one, or a touchscreen's finger)."""
        if button == self.glfw.MOUSE_BUTTON_LEFT:
            self.mouse.button(action == self.glfw.PRESS, *self._mouse_time())

    def on_cursor_enter(self, window: Any, entered: int) -> None:
        if not entered:
            self.mouse.leave(*self._mouse_time())

    def _feed_mouse(self) -> bool:
        """The mouse's samples to the painting, as a pen's (``auto``: not while a pen is
        heard); ``True`` if any went."""
        samples = self.mouse.take()
        if not samples or (self.cfg.input == "auto"
                           and time.monotonic() - self._pen_heard < mouse.PEN_WINS_S):
            return False
        for sample in samples:
            self.session.handle("pen", sample)
        return True

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
        self._glfinish = _gl_function("glFinish")
        self._glflush = _gl_function("glFlush")
        # the UI is built only when what it shows may have changed (compose)
        self._ui_last_key: tuple[Any, ...] | None = None
        self._ui_built = 0.0
        self._ui_hash = 0
        self._ui_bounds: Box | None = None
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
            session.start_worker()
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

    def _gl_finish(self) -> None:
        """``glFinish`` through ctypes, which lets the simulation thread run while the GL
        driver completes the frame (moderngl's ``finish`` holds the interpreter lock,
        and llvmpipe rasterises in the call)."""
        if self._glfinish is None:
            self.ctx.finish()
        else:
            self._glfinish()

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

    # -- input -----------------------------------------------------------------------------
    def _map_pen(self, s: PenSample) -> PenSample | None:
        """Screen-space sample → the canvas's sample (``None``: the panel has it)."""
        now = time.monotonic()
        w, h = self.size
        px, py = s.x * w, s.y * h
        self._pen_received = now
        if s.device != mouse.DEVICE:
            self._pen_heard = now
        self._pen_read = s.t_mono if s.t_mono > 0.0 else now
        self.predictor.add(s.t, px, py, s.proximity, s.touching and s.proximity)
        if self.pen_log is not None:
            self.pen_log.append((s.t_mono if s.t_mono > 0.0 else now, s.t, px, py,
                                 s.touching and s.proximity))
        self.panel.eraser = s.tool is Tool.ERASER
        if s.proximity:
            self.idle.activity(now)
        touching = s.touching and s.proximity
        if touching and not self.touching:
            self.capture = "ui" if px < self.panel_w else "canvas"
        self.touching = touching
        capture = self.capture
        if not touching:
            self.capture = None
        cam = input_camera(self.panel.view, self.area, self.aspect)
        uv = cam.screen_to_canvas(px, py) if px >= self.panel_w else None
        inside = uv is not None and 0.0 <= uv[0] <= 1.0 and 0.0 <= uv[1] <= 1.0
        self.hover = uv if (s.proximity and inside) else None
        if inside and uv is not None:
            self.follow_at = uv
        near = s.proximity
        if capture == "ui" or (capture is None and px < self.panel_w):
            self.gui.pointer(px if near else None, py if near else None, touching)
            return None
        # over the canvas ImGui still follows the pen (a drag released there ends there)
        self.gui.pointer(px if near else None, py if near else None, False)
        if not inside or uv is None:  # off the canvas: the stroke lifts
            last = self.session.last_canvas_pen if hasattr(self, "session") else None
            if last is None or not last.touching:
                return None
            return s.with_(x=last.x, y=last.y, touching=False, pressure=0.0)
        return s.with_(x=float(uv[0]), y=float(uv[1]))

    def _sync_panel(self) -> None:
        """Show the brush the painting really has (an operator's ``brush`` command on the
        bus changes it too)."""
        b = self.session.player.brush.settings
        key = (b.kind, b.size, b.water, tuple(sorted(b.pigment.items())))
        if key == self._brush_key:
            return
        self._brush_key = key
        p = self.panel
        mine = p.brush_args()
        if (mine["kind"] == b.kind and math.isclose(mine["size"], b.size)
                and math.isclose(mine["water"], b.water)
                and mine["pigment"].keys() == b.pigment.keys()
                and all(math.isclose(v, b.pigment[k]) for k, v in mine["pigment"].items())):
            return  # the panel's own brush: keep its parts as the visitor mixed them
        p.kind, p.size, p.water = b.kind, float(b.size), float(b.water)
        total = sum(b.pigment.values())
        if total > 0:
            p.strength = float(total)
            p.mix = {name: float(v / total) for name, v in b.pigment.items()}
        else:
            p.mix = {}

    def _kiosk_command(self, cmd: Command) -> bool:
        """Commands for the window (:mod:`station.kiosk.commands`: ``view``, ``fresh``,
        ``screenshot``, ``message``) and the gallery's ``save`` and ``stop``; ``False``:
        the painting's.  A bad one is logged and dropped (it came from the bus)."""
        if cmd.cmd == "save":
            self.save_now()
            return True
        if cmd.cmd == "stop":
            self.stop_requested = True
            return True
        if not is_kiosk_command(cmd.cmd):
            return False
        try:
            check_kiosk_command(cmd, where="bus")
        except BadInput as exc:
            log.warning("kiosk command refused: %s", exc)
            return True
        if cmd.cmd == "view":
            self.panel.set_view(str(cmd.args["name"]))
        elif cmd.cmd == "fresh":
            self._fresh_requested = True
        elif cmd.cmd == "message":  # an operator's note on the panel (blueprint show-message)
            self.panel.message = " ".join(str(cmd.args["text"]).split())[:MESSAGE_MAX]
        elif cmd.cmd == "screenshot":
            if self.cfg.screenshot_dir is None:
                log.warning("screenshot refused: the kiosk runs without --screenshot-dir")
            else:
                self.screenshots.append(self.cfg.screenshot_dir / f"{cmd.args['name']}.png")
        return True

    def _commands(self) -> None:
        """Commands sent to the kiosk's own endpoint (``station send``)."""
        if self.cmd_sub is None:
            return
        answerer = self.session.sim.answerer
        answerer.upstream = self.cmd_sub.send_upstream  # a "peer" answer goes back here
        try:
            msg = self.cmd_sub.recv(0)
            while msg is not None:
                self.session.handle(msg.kind, msg.value, msg.topic, msg.replay)
                msg = self.cmd_sub.recv(0)
        finally:
            answerer.upstream = None

    def _driver_status(self) -> None:
        msg = self.driver_sub.recv(0)
        while msg is not None:
            v = msg.value
            if isinstance(v, dict) and v.get("kind") == "driver":
                state = str(v.get("state", "unknown"))
                if state != self.driver_state:
                    self.driver_events.append(state)
                self.driver_state = state
                self.driver_seen = time.monotonic()
            msg = self.driver_sub.recv(0)

    def pen_missing(self) -> bool:
        """Whether to show "the pen is unplugged": a driver said so, or went silent."""
        if self.driver_state in ("gone", "waiting", "failed"):
            return True
        return (self.driver_state == "running"
                and time.monotonic() - self.driver_seen > DRIVER_SILENT_S)

    # -- drawing ---------------------------------------------------------------------------
    def camera(self) -> Camera:
        return make_camera(self.panel.view, self.area, self.aspect, self.follow_at)

    def _flat(self, cam: Camera, pts: np.ndarray, color: tuple[float, ...], mode: int) -> None:
        data = np.asarray(pts, "f4").tobytes()
        if len(data) > self.flat_vbo.size:
            self.flat_vbo.orphan(len(data))
        self.flat_vbo.write(data)
        self.flat_prog["vp"].write(cam.vp.T.astype("f4").tobytes())
        self.flat_prog["color"].value = color
        self.flat_vao.render(mode, vertices=len(pts))

    def draw_scene(self, cam: Camera, clip: Box | None = None) -> None:
        """The view of the canvas (background, table, canvas) into the bound framebuffer;
        ``clip``: only inside these window pixels (x0, y0, x1, y1)."""
        ctx = self.ctx
        w, h = self.size
        scissor = None if clip is None else (clip[0], h - clip[3], clip[2] - clip[0],
                                             clip[3] - clip[1])
        ctx.viewport = (0, 0, w, h)
        ctx.scissor = scissor
        ctx.clear(*BACKGROUND)
        ctx.viewport = cam.viewport.gl(h)
        ctx.scissor = scissor
        ctx.enable(ctx.BLEND)
        ctx.blend_func = ctx.SRC_ALPHA, ctx.ONE_MINUS_SRC_ALPHA
        if cam.name != "2d":
            t = 3.0
            self._flat(cam, np.array([[-t, t, -1e-3], [t, t, -1e-3], [-t, -t, -1e-3],
                                      [t, -t, -1e-3]]), TABLE, ctx.TRIANGLE_STRIP)
        self.draw_canvas(cam, self.display.texture)
        ctx.disable(ctx.BLEND)
        ctx.viewport = (0, 0, w, h)
        ctx.scissor = None

    def draw_canvas(self, cam: Camera, texture: Any) -> None:
        """The canvas quad at the screen's resolution (:mod:`station.kiosk.subcell`)."""
        prog = self.canvas_prog
        texture.use(0)
        prog["canvas"].value = 0
        self.display.surface.use(prog, 1)
        prog["cells"].value = (float(self.cfg.width), float(self.cfg.height))
        prog["vp"].write(cam.vp.T.astype("f4").tobytes())
        self.canvas_vao.render(self.ctx.TRIANGLE_STRIP)

    def reference_picture(self) -> np.ndarray:
        """The window's picture drawn from scratch (sRGB8, H×W×3, row 0 on top): the whole
        canvas rendered afresh (:meth:`CpuDisplay.full_texture`), the whole scene and UI,
        no shadow — what the screen must show outside the shadow, however it got there."""
        ctx = self.ctx
        w, h = self.size
        tex = ctx.texture((w, h), 4)
        fbo = ctx.framebuffer([tex])
        full = self.display.full_texture()
        real = self.display.texture
        try:
            fbo.use()
            self.display.texture = full
            self.draw_scene(self.camera())
            self.gui.draw((0, 0, w, h))
            data = fbo.read(viewport=(0, 0, w, h), components=3, alignment=1)
        finally:
            self.display.texture = real
            if full is not real:
                full.release()
            fbo.release()
            tex.release()
            ctx.screen.use()
        return np.frombuffer(data, np.uint8).reshape(h, w, 3)[::-1]

    def predicted_hover(self) -> tuple[float, float] | None:
        """Canvas (u, v) of the pen's shadow: the pen as predicted for when this frame is
        seen (:mod:`station.kiosk.predict`), where it is over the canvas."""
        self._cursor_drawn = None
        if self.hover is None:
            return None
        last = self.predictor.last()
        p = self.predictor.predict(age=time.monotonic() - self._pen_received)
        if p is None or last is None:
            return self.hover
        uv = input_camera(self.panel.view, self.area, self.aspect).screen_to_canvas(*p) \
            if p[0] >= self.panel_w else None
        if uv is None or not (0.0 <= uv[0] <= 1.0 and 0.0 <= uv[1] <= 1.0):
            uv = self.hover
        self._cursor_drawn = ((last[1], last[2]), p)
        self._shadow_read = self._pen_read
        return uv

    def cursor_shape(self, cam: Camera) -> tuple[np.ndarray, tuple[float, ...]] | None:
        """The brush's shadow: a disc (world points, a triangle fan) the size of its
        footprint at full pressure, offset as if lit from the top left, where the pen is
        predicted to be when this frame shows; with its colour.  ``None``: no pen."""
        shown = self.predicted_hover()
        if shown is None:
            return None
        r = self.session.player.brush.settings.size / 2 / self.cfg.height
        u, v = shown
        off = 0.0 if self.touching else 0.006
        c = cam.canvas_to_world(u + off, v + off)
        ang = np.linspace(0, 2 * math.pi, 41)
        ring = np.column_stack([c[0] + r * np.cos(ang), c[1] + r * np.sin(ang),
                                np.full(ang.size, 1e-4)])
        return (np.vstack([[c[0], c[1], 1e-4], ring]),
                CURSOR_TOUCH if self.touching else SHADOW)

    def draw_cursor(self, cam: Camera, shape: tuple[np.ndarray, tuple[float, ...]]) -> None:
        """The shadow (:meth:`cursor_shape`) over the presented picture."""
        ctx = self.ctx
        w, h = self.size
        ctx.viewport = cam.viewport.gl(h)
        ctx.enable(ctx.BLEND)
        ctx.blend_func = ctx.SRC_ALPHA, ctx.ONE_MINUS_SRC_ALPHA
        self._flat(cam, shape[0], shape[1], ctx.TRIANGLE_FAN)
        ctx.disable(ctx.BLEND)
        ctx.viewport = (0, 0, w, h)

    def canvas_rect(self) -> list[float]:
        """Where the canvas is on the screen in the 2D view: x, y, width, height (pixels)."""
        cam = make_camera("2d", self.area, self.aspect)
        x0, y0 = cam.world_to_screen(cam.canvas_to_world(0.0, 0.0)) or (0.0, 0.0)
        x1, y1 = cam.world_to_screen(cam.canvas_to_world(1.0, 1.0)) or (0.0, 0.0)
        return [x0, y0, x1 - x0, y1 - y0]

    def status_line(self) -> str:
        s = self.session
        m = s.moisture()
        parts = []
        if m is not None:
            parts.append(m.line())
            if m.word != "dry":
                parts.append("drying" if s.active_tiles() else "settled")
        if s.counters.bad_samples:
            parts.append("layer full: press New layer")
        return "  ".join(parts)

    def build_ui(self, dt: float) -> int:
        """One ImGui frame (panel, QR, banners), not drawn yet; returns its hash."""
        self.gui.new_frame(dt)
        w, h = self.size
        self.rects = {}
        draw_panel(self.panel, self.panel_w, h, self._status_text(), self.rects)
        if self.qr is not None:
            side = min(240.0, h * 0.3)
            draw_qr(self.qr[0], w - side - 40, h - side - 80, side, self.rects)
        now = time.monotonic()
        a = self.area
        if self.pen_missing():
            draw_banner("The pen is unplugged - please wait, it will be back",
                        a.x + 20, a.y + 20, a.w - 40, 110, "unplugged", big=False)
        elif self.idle.attract(now):
            draw_attract(a.x, a.y, a.w, a.h, INVITATION, self._attract_image(now),
                         demo_stroke(now, a.w, a.h), self.rects)
        else:
            self._attracting = False
        return self.gui.end_frame()

    def _attract_image(self, now: float) -> tuple[int, tuple[int, int]] | None:
        """The replay frame the attract screen shows now (an ImGui texture), or ``None``
        (no replay in the gallery: the demo stroke)."""
        if not self._attracting:
            self._attracting = True
            self.attract_show.start(now)
        rgba, new = self.attract_show.frame(now)
        if rgba is None:
            return None
        if new or self._attract_tex is None:
            h, w = rgba.shape[:2]
            # a new texture (and ImGui id) for each new frame: the compositor redraws the
            # UI where its draw data changed, and an id is what changes
            old = self._attract_tex
            tex = self.ctx.texture((w, h), 4, np.ascontiguousarray(rgba).tobytes())
            tex.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
            self._attract_tex = (self.gui.add_texture(tex), (w, h), tex)
            if old is not None:
                self.gui.textures.pop(old[0], None)
                old[2].release()
        tid, size, _tex = self._attract_tex
        return tid, size

    def _ui_key(self, now: float) -> tuple[Any, ...]:
        """What the panel and overlays show; the last item: the pen is near the panel
        (ImGui must see it every frame: hover, taps, drags)."""
        p = self.panel
        pen = self.session.last_pen
        near = pen is not None and pen.proximity and \
            (pen.x * self.size[0] < self.panel_w + 40 or self.capture == "ui")
        return (self._status_text(), tuple(sorted(p.mix.items())), p.size, p.water,
                p.strength, p.kind, p.view, p.confirm_clear, p.eraser, p.message, p.mixing,
                p.can_undo(), len(p.pressed), self.qr_url, self.pen_missing(),
                self.idle.attract(now) and int(now / ATTRACT_FRAME_S), near)

    def _status_text(self) -> str:
        """The status line, refreshed every :data:`STATUS_EVERY_S` (people read it; a
        text changing every step would redraw the panel every step)."""
        now = time.monotonic()
        if now >= self._status_due:
            self._status_due = now + STATUS_EVERY_S
            self._status_cache = self.status_line()
        return self._status_cache

    def build_ui_if_changed(self, dt: float) -> None:
        """Build the UI when what it shows may have changed (else ImGui's last draw data
        stays valid: no new frame)."""
        now = time.monotonic()
        key = self._ui_key(now)
        if (key != self._ui_last_key or key[-1] or bool(self.screenshots)
                or now - self._ui_built >= REDRAW_EVERY_S):
            self._ui_hash = self.build_ui(now - self._ui_built if self._ui_built else dt)
            self._ui_bounds = self.gui.bounds()
            self._ui_last_key, self._ui_built = key, now

    def compose_changes(self, cam: Camera) -> None:
        """Redraw the parts of the picture that the display re-rendered since the last
        call and where the UI changed (see compose.py); called before the late latch (the
        tiles) and after it (the pen's preview).  The GL work is flushed at once, so the
        rasteriser draws the first part while the window takes the pen."""
        boxes = self.compositor.update(cam, self.display.damage,
                                       (self.cfg.width, self.cfg.height), self._ui_hash,
                                       self._ui_bounds, lambda box: self.draw_scene(cam, box),
                                       self.gui.draw)
        self.display.damage = []
        self.frame_pixels += self.compositor.pixels_redrawn
        self._frame_full = self._frame_full or self.compositor.full_last
        self._frame_boxes.extend(boxes)
        if self._glflush is not None:
            self._glflush()

    def fill_back_buffer(self, cam: Camera) -> None:
        """The picture into the back buffer — all of it, or only where the window changes
        when the presenter copies rectangles — and the shadow over it."""
        shadow = self.cursor_shape(cam)
        shadow_box = None if shadow is None else screen_box(cam, shadow[0],
                                                              (self.size[0], self.size[1]))
        now = time.monotonic()
        if (self.screenshots or self._frame_full
                or self.presenter.needs_whole(now, self._last_whole)):
            self.compositor.present()
            self._present_rects = None
            self._last_whole = now
        else:
            # merged once: overlapping rectangles would be copied twice, here and to X
            rects = merge_rects([b for b in (*self._frame_boxes, self._shadow_box,
                                             shadow_box) if b is not None])
            self.compositor.present(rects)
            self._present_rects = rects
        self._frame_boxes = []
        self._frame_full = False
        self._shadow_box = shadow_box
        if shadow is not None:
            self.draw_cursor(cam, shadow)

    def _screenshot(self, path: Path) -> None:
        from PIL import Image

        w, h = self.size
        data = self.ctx.screen.read(viewport=(0, 0, w, h), components=3, alignment=1)
        img = np.frombuffer(data, np.uint8).reshape(h, w, 3)[::-1]
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp")
        Image.fromarray(img).save(tmp, format="PNG")
        os.replace(tmp, path)  # whoever waits for the file never sees half of it

    # -- the loop --------------------------------------------------------------------------
    def _quiet_wait_ms(self) -> int:
        """How long a quiet kiosk may wait for the pen: until the next step is due; with
        the simulation thread (which steps on its own), a few ms while paint is wet (its
        steps end any time).  At least a millisecond: a loop that does not wait spins,
        and a spinning loop takes the interpreter lock and a core from the steps."""
        s = self.session
        if self.idle.attract(time.monotonic()):
            return max(1, math.ceil(ATTRACT_FRAME_S * 1000))
        if s.threaded:
            wait = THREAD_POLL_S if s.active_tiles() else REDRAW_EVERY_S
        else:
            p = s.player
            t_next = (p.counters.steps + 1) / p.rate - p.waited
            wait = min(max(t_next - s.now(), 0.0), REDRAW_EVERY_S)
        return max(1, math.ceil(wait * 1000))

    def frame(self, dt: float) -> None:
        """One pass of the loop: input, then (if anything changed) a frame with its late
        latch, then steps (see the module docstring).

        A quiet kiosk (no pen, nothing wet) does not redraw 60 times a second: it waits
        on the bus until the next step is due, so a pen sample is handled the moment it
        comes, and it redraws at least every :data:`REDRAW_EVERY_S` (status, banners).
        """
        t0 = time.perf_counter()
        self.glfw.poll_events()
        self._follow_window_size()
        busy, got_input = self._take_input()
        tw = time.perf_counter()
        now = time.monotonic()
        got_input = self._operator_and_idle(now) or got_input
        t1 = time.perf_counter()
        times = _FrameTimes(t1)
        if self._frame_due(now, got_input):
            got_input = self._draw_frame(now, dt, times) or got_input
        # ImGui spreads pen events queued together over the next frames: draw one more
        self._need_draw = got_input
        self._steps_or_housekeeping()
        t_end = time.perf_counter()
        if busy:  # a pass that did not wait for the bus
            self._last_pass_s = t_end - t0
        self._account(t0, tw, t1, times, t_end)
        self.maybe_publish_status()

    # -- the parts of a pass ------------------------------------------------------------
    def _take_input(self) -> tuple[bool, bool]:
        """Wait for the bus as long as the kiosk may (not at all when a frame is due),
        then handle what came; returns (the pass is busy, input came)."""
        s = self.session
        urgent = self._need_draw or bool(self.screenshots)
        busy = (urgent or s.whole_dirty or bool(s.dirty.any()) or self.display.behind())
        received = s.sub.stats.received
        if not busy:
            wait_ms = self._quiet_wait_ms()
        elif urgent:
            wait_ms = 0
        else:  # only the steps' tiles to show: not sooner than TILE_FRAME_S after the last
            # frame, waiting on the bus meanwhile (the pen is shown at once), so the other
            # processes a frame needs (the X server, the driver) get the cores
            wait_ms = max(0, math.ceil(1000 * (TILE_FRAME_S - (time.monotonic()
                                                                - self._last_draw))))
        # handling may take half as long as the last pass took: it keeps up with the pen
        # on a slow pass, and a queue that grew cannot hold the frames back
        s.drain(wait_ms, 0.5 * self._last_pass_s)
        moused = self._feed_mouse()
        return busy, s.sub.stats.received != received or moused

    def _operator_and_idle(self, now: float) -> bool:
        """``station send``'s commands, the drivers' status, a fresh canvas when asked
        for or idle, the panel following the painting's brush; ``True``: the picture
        changed (a fresh canvas)."""
        self._commands()
        self._driver_status()
        if self._fresh_requested:
            self._fresh_requested = False
            self.fresh_canvas("operator")
        if self.session.painted_stamps > 0:
            self.idle.painted = True
        self._sync_panel()
        if self.idle.should_finish(now):
            pid = self.fresh_canvas("idle")
            log.info("idle: painting %s saved to the gallery, fresh canvas", pid)
            return True
        return False

    def _frame_due(self, now: float, got_input: bool) -> bool:
        """Whether to draw: new stamps come with input (their preview is drawn then); a
        step's changes come as dirty tiles; a quiet kiosk every REDRAW_EVERY_S."""
        s = self.session
        return (self._need_draw or got_input or bool(self.screenshots) or s.whole_dirty
                or bool(s.dirty.any()) or self.display.behind()
                or now - self._last_draw >= REDRAW_EVERY_S
                or self._view_key() != self._drawn_view or self.presenter.owes_whole()
                or (self.idle.attract(now) and now - self._last_draw >= ATTRACT_FRAME_S))

    def _view_key(self) -> tuple[str, tuple[float, float]]:
        """What the camera depends on: a view changed by any path is drawn at once."""
        return self.panel.view, self.follow_at

    def _draw_frame(self, now: float, dt: float, times: _FrameTimes) -> bool:
        """Tiles, UI, their composition, the late latch, the preview, present; returns
        whether the late latch took input."""
        s = self.session
        self.frame_pixels = 0
        with s.lock:  # not while a step hands its sources over (the kernel may run)
            self.display.update_tiles()
            # a screenshot shows the whole canvas as it is, not a frame still catching up
            # with its tiles (the per-frame budget keeps the pen fluid, not a screenshot)
            while self.screenshots and self.display.behind():
                self.display.update_tiles()
        times.tiles = time.perf_counter()
        self.build_ui_if_changed(now - self._last_draw if self._last_draw else dt)
        cam = self.camera()
        self._drawn_view = self._view_key()
        self.compose_changes(cam)
        # the late latch: what the pen sent while the tiles and the UI were drawn is
        # shown in this frame, not the next (what stands between a sample and the
        # screen is only its stamps' preview, their composition and the present)
        times.ui = time.perf_counter()
        n_early = len(s.awaiting_paint)
        received = s.sub.stats.received
        s.drain(0, LATCH_BUDGET_S, floor_s=0.0)
        latched = s.sub.stats.received != received
        times.drained = time.perf_counter()
        with s.lock:
            self.display.update_preview()
        times.preview = time.perf_counter()
        self.compose_changes(cam)
        self.fill_back_buffer(cam)
        for path in self.screenshots:
            self._screenshot(path)
        self.screenshots.clear()
        times.present = time.perf_counter()
        shown = self._present()
        times.shown = time.perf_counter()
        self._record_shown(shown, times, n_early)
        return latched

    def _present(self) -> float:
        """The back buffer to the screen, whole or by rectangles; when it was shown."""
        if self._present_rects is None:
            self._gl_finish()
            self.presenter.present_whole()
        else:
            self.presenter.present_rects(self._present_rects)
            self._gl_finish()
        return time.monotonic()

    def _record_shown(self, shown: float, times: _FrameTimes, n_early: int) -> None:
        """A frame is on screen: the latency of the paint it shows, the prediction's
        horizon from its measured lag, the bench's records."""
        s = self.session
        for t_read in s.awaiting_paint:
            self.latencies.append(shown - t_read)
        if self.tail_log is not None:
            self.tail_log.append((times.shown - times.ui, len(s.awaiting_paint) - n_early))
        if self._cursor_drawn is not None and self.cfg.predict_ms is None:
            lag = shown - self._shadow_read
            if lag <= self.predictor.cfg.stale_s:  # a moving pen (a still one is not
                # predicted, and its lag is only the time it stood still)
                self.predictor.cfg = dataclasses.replace(self.predictor.cfg,
                                                         horizon_s=self.lag.add(lag))
        if self.cursor_log is not None and self._cursor_drawn is not None:
            (rx, ry), (qx, qy) = self._cursor_drawn
            self.cursor_log.append((shown, rx, ry, qx, qy))
        s.awaiting_paint.clear()
        self._last_draw = shown
        self.frames += 1

    def _steps_or_housekeeping(self) -> None:
        s = self.session
        if s.threaded:
            s.check_worker()
            s.housekeeping()
        else:  # the steps in this loop (after presenting: a step delays the next frame)
            s.run_due_steps(max_steps=2)  # what they change: dirty tiles

    def _account(self, t0: float, tw: float, t1: float, times: _FrameTimes,
                 t_end: float) -> None:
        """The pass's wall time into the phases (the bench's share per phase)."""
        ph = self.phase
        ph["wait"] += tw - t0
        ph["input"] += (t1 - tw) + (times.drained - times.ui)
        ph["render"] += (times.tiles - t1) + (times.preview - times.drained)
        ph["ui"] += (times.ui - times.tiles) + (times.present - times.preview)
        ph["present"] += times.shown - times.present
        ph["sim"] += t_end - times.shown

    def run(self) -> dict[str, Any]:
        """Frames until stopped (signal, ``stop`` command, ``duration``)."""
        start = time.monotonic()
        last = start
        failures = 0
        try:
            while not self.stop_requested and not self.session.stop_requested:
                now = time.monotonic()
                if self.cfg.duration is not None and now - start >= self.cfg.duration:
                    break
                try:
                    self.frame(now - last)
                    failures = 0
                except (StationError, OSError, ValueError, RuntimeError) as exc:
                    # a kiosk keeps showing the painting: log, count, go on — unless every
                    # frame fails, which is a bug to report, not to spin on
                    failures += 1
                    self.frame_errors += 1
                    if failures == 1:
                        log.exception("frame failed: %s", exc)
                    if failures >= 100:
                        raise
                last = now
        finally:
            final = self.kiosk_status()
            self.close()
        # close() saves the painting to the gallery: the final status says so (taken
        # before it, it would read "saved": [] for a painting that is in the gallery)
        final["saved"] = list(self.saved)
        return final

    def kiosk_status(self) -> dict[str, Any]:
        s = self.session
        st = s.status()
        st.update({
            "process": "kiosk", "view": self.panel.view, "frames": self.frames,
            "sim_thread": s.threaded,
            "frame_errors": self.frame_errors,
            "painting_id": s.painting_id, "resumed": s.resumed,
            "painted_stamps": s.painted_stamps, "saved": list(self.saved),
            "qr_url": self.qr_url, "driver_state": self.driver_state,
            "driver_events": list(self.driver_events), "pen_missing": self.pen_missing(),
            "attract": self.idle.attract(time.monotonic()), "ui": dict(self.rects),
            "window": list(self.size), "canvas_rect": self.canvas_rect(), "panel": {
                "mix": dict(self.panel.mix), "size": self.panel.size,
                "water": self.panel.water, "strength": self.panel.strength,
                "confirm_clear": self.panel.confirm_clear, "eraser": self.panel.eraser,
                "mixing": self.panel.mixing,
                "pressed": list(self.panel.pressed)},
            "player_commands": dict(s.player.counters.commands),
            "skipped_commands": dict(s.player.counters.skipped_commands),
            "brush": s.player.brush.settings.to_args(),
            "wet_fraction": s.wet_fraction(),
            **self._moisture_status(),
            "gallery_url": self.base_url,
        })
        return st

    def _moisture_status(self) -> dict[str, Any]:
        m = self.session.moisture()
        if m is None:
            return {"paper": None, "damp_fraction": None}
        return {"paper": m.word, "damp_fraction": m.damp}

    def maybe_publish_status(self) -> None:
        now = time.monotonic()
        if self.pub is None or now < self._next_status:
            return
        self._next_status = now + STATUS_EVERY_S
        try:
            self.pub.publish_status(self.kiosk_status())
        except Exception as exc:  # status is best effort; the kiosk goes on
            log.warning("cannot publish status: %s", exc)

    def install_signal_handlers(self) -> None:
        import signal

        def on_signal(signum: int, frame: Any) -> None:
            self.stop_requested = True

        signal.signal(signal.SIGTERM, on_signal)
        signal.signal(signal.SIGINT, on_signal)

    def close(self) -> None:
        """Save the painting (the operator stopped the kiosk), release everything."""
        try:
            self.finish_painting("stopped")
        finally:
            self._release_live_log()
            if self.pub is not None:
                try:
                    self.pub.publish_status({**self.kiosk_status_safe(), "state": "stopped"})
                except Exception:
                    pass
                self.pub.close()
            self.driver_sub.close()
            if self.cmd_sub is not None:
                self.cmd_sub.close()
            if self.server is not None:
                self.server.stop()
            self.display.release()
            self.compositor.release()
            self.gui.close()
            self.glfw.destroy_window(self.window)
            self.glfw.terminate()

    def kiosk_status_safe(self) -> dict[str, Any]:
        return {"process": "kiosk", "saved": list(self.saved), "frames": self.frames}
