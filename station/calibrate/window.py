"""``station calibrate --device SPEC``: the fullscreen calibration window.

A glfw window (fullscreen on the primary monitor unless ``--windowed``) with a
moderngl context made from it.  Drawn each frame, in screen pixels:

* the current target: a white ring and cross (tilt-pass targets add an arrow
  showing which way to lean the pen);
* accepted taps: green dots at their targets, with a yellow line to where the
  provisional fit put the tap (the residual, drawn 10× enlarged);
* rejected taps (misclicks): a red cross where the tap landed;
* the live pen cursor (through the provisional fit, or device-normalised
  until three taps are in): cyan while hovering, magenta while touching.

* words, top left, for an installer who does not see the terminal: what to do at
  the current target ("target 4/9: tap the centre of the cross"), the last tap's
  result with the reason of a rejection ("target 4/9: REJECTED (…); tap it
  again") and, at the end, the fit's residuals in pixels; they go to the window
  title and to stdout too.  The result stays on screen ``--result-seconds`` (a
  recording or mock that has no more taps ends it at once).

GLFW needs an X display (Xvfb in tests); the GL context comes
from the glfw window (``moderngl.create_context()``).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path
from typing import IO, TYPE_CHECKING, cast

import numpy as np

from station.calibrate.sources import CalibrationSource, open_source
from station.calibration.area import AreaSettings
from station.calibration.errors import CalibrationError
from station.calibration.files import default_path, write_file
from station.calibration.fit import FitReport, Mapping, PointSet, fit_mapping
from station.calibration.model import Calibration, FitInfo
from station.calibration.session import STEP_TEXT, CalibrationSession, TapResult
from station.errors import StationError
from station.events import PenSample

if TYPE_CHECKING:  # the window's libraries are an optional extra, imported where it opens
    import moderngl
    from PIL import Image, ImageFont

VERTEX = """
#version 330
uniform vec2 screen;
in vec2 pos;
void main() {
    vec2 ndc = pos / screen * 2.0 - 1.0;
    gl_Position = vec4(ndc.x, -ndc.y, 0.0, 1.0);
}
"""

FRAGMENT = """
#version 330
uniform vec4 color;
out vec4 frag;
void main() { frag = color; }
"""

BACKGROUND = (0.08, 0.08, 0.1)
WHITE = (1.0, 1.0, 1.0, 1.0)
GREEN = (0.1, 0.85, 0.2, 1.0)
YELLOW = (1.0, 0.85, 0.1, 1.0)
RED = (0.95, 0.15, 0.1, 1.0)
CYAN = (0.2, 0.9, 0.95, 1.0)
MAGENTA = (0.95, 0.2, 0.9, 1.0)


def _uniform(prog: moderngl.Program, name: str) -> moderngl.Uniform:
    """The uniform ``name`` of ``prog`` (moderngl types a member as any of four kinds)."""
    return cast("moderngl.Uniform", prog[name])


class Renderer:
    """Draws lines, discs and rings with one tiny shader (screen-pixel coordinates)."""

    def __init__(self, ctx: moderngl.Context, size: tuple[int, int]) -> None:
        self.ctx = ctx
        self.size = size
        self.prog = ctx.program(vertex_shader=VERTEX, fragment_shader=FRAGMENT)
        _uniform(self.prog, "screen").value = (float(size[0]), float(size[1]))
        self.vbo = ctx.buffer(reserve=4096 * 8, dynamic=True)
        self.vao = ctx.vertex_array(self.prog, [(self.vbo, "2f", "pos")])

    def _draw(self, pts: np.ndarray, mode: int, color: tuple[float, ...]) -> None:
        data = np.asarray(pts, dtype="f4").tobytes()
        if len(data) > self.vbo.size:
            self.vbo.orphan(len(data))
        self.vbo.write(data)
        _uniform(self.prog, "color").value = color
        self.vao.render(mode, vertices=len(pts))

    def lines(self, segments: list[tuple[float, float, float, float]],
              color: tuple[float, ...], width: float = 2.0) -> None:
        # thick lines as quads (core profile line width is 1 px on llvmpipe)
        tris = []
        for x0, y0, x1, y1 in segments:
            dx, dy = x1 - x0, y1 - y0
            n = math.hypot(dx, dy) or 1.0
            nx, ny = -dy / n * width / 2, dx / n * width / 2
            a, b = (x0 + nx, y0 + ny), (x0 - nx, y0 - ny)
            c, d = (x1 + nx, y1 + ny), (x1 - nx, y1 - ny)
            tris += [a, b, c, b, d, c]
        if tris:
            self._draw(np.array(tris), self.ctx.TRIANGLES, color)

    def disc(self, x: float, y: float, r: float, color: tuple[float, ...]) -> None:
        ang = np.linspace(0, 2 * math.pi, 33)
        fan = np.vstack([[x, y], np.column_stack([x + r * np.cos(ang), y + r * np.sin(ang)])])
        self._draw(fan, self.ctx.TRIANGLE_FAN, color)

    def ring(self, x: float, y: float, r: float, color: tuple[float, ...], w: float = 3) -> None:
        ang = np.linspace(0, 2 * math.pi, 49)
        outer = np.column_stack([x + (r + w / 2) * np.cos(ang), y + (r + w / 2) * np.sin(ang)])
        inner = np.column_stack([x + (r - w / 2) * np.cos(ang), y + (r - w / 2) * np.sin(ang)])
        strip = np.empty((2 * len(ang), 2))
        strip[0::2], strip[1::2] = outer, inner
        self._draw(strip, self.ctx.TRIANGLE_STRIP, color)

    def cross(self, x: float, y: float, r: float, color: tuple[float, ...], w: float = 2) -> None:
        self.lines([(x - r, y, x + r, y), (x, y - r, x, y + r)], color, w)

    def xmark(self, x: float, y: float, r: float, color: tuple[float, ...]) -> None:
        self.lines([(x - r, y - r, x + r, y + r), (x - r, y + r, x + r, y - r)], color, 3)


TEXT_VERTEX = """
#version 330
uniform vec2 screen;
in vec2 pos;
in vec2 uv;
out vec2 v_uv;
void main() {
    v_uv = uv;
    gl_Position = vec4(pos.x / screen.x * 2.0 - 1.0, 1.0 - pos.y / screen.y * 2.0, 0.0, 1.0);
}
"""
TEXT_FRAGMENT = """
#version 330
uniform sampler2D image;
in vec2 v_uv;
out vec4 frag;
void main() { frag = texture(image, v_uv); }
"""
TEXT_PX = 22
WORDS = tuple[str, tuple[float, ...]]


PANEL_ALPHA = 190


def panel_origin(size: tuple[int, int]) -> tuple[float, float]:
    """Where the words go: left, in the band between the top targets (y = 0.1) and the
    centre ones (y = 0.5), so they never cover a target."""
    return 20.0, float(int(0.1 * size[1]) + 45)


def render_words(lines: tuple[WORDS, ...], font: ImageFont.FreeTypeFont | ImageFont.ImageFont,
                 max_w: int) -> Image.Image:
    """The panel as an RGBA Pillow image: light words on translucent black."""
    from PIL import Image, ImageDraw

    pad, step = 12, TEXT_PX + 8
    width = min(max_w, pad * 2 + max(int(font.getlength(t)) for t, _ in lines))
    img = Image.new("RGBA", (max(width, 1), pad * 2 + step * len(lines)),
                    (0, 0, 0, PANEL_ALPHA))
    draw = ImageDraw.Draw(img)
    for i, (text, color) in enumerate(lines):
        rgba = (*(int(255 * c) for c in color[:3]), 255)
        draw.text((pad, pad + i * step), text, font=font, fill=rgba)
    return img


class TextPanel:
    """Lines of words on a dark panel (Pillow draws them, one texture per change)."""

    def __init__(self, ctx: moderngl.Context, size: tuple[int, int]) -> None:
        from PIL import ImageFont

        self.ctx = ctx
        self.prog = ctx.program(vertex_shader=TEXT_VERTEX, fragment_shader=TEXT_FRAGMENT)
        _uniform(self.prog, "screen").value = (float(size[0]), float(size[1]))
        self.vbo = ctx.buffer(reserve=6 * 4 * 4, dynamic=True)
        self.vao = ctx.vertex_array(self.prog, [(self.vbo, "2f 2f", "pos", "uv")])
        self.font = ImageFont.load_default(size=TEXT_PX)
        self.max_w = size[0] - 40
        self._key: tuple[WORDS, ...] | None = None
        self._tex: moderngl.Texture | None = None
        self._wh = (0, 0)

    def draw(self, lines: list[WORDS], x: float = 20, y: float = 20) -> None:
        key = tuple(lines)
        if not key:
            return
        if key != self._key:
            img = render_words(key, self.font, self.max_w)
            if self._tex is not None:
                self._tex.release()
            self._tex = self.ctx.texture(img.size, 4, img.tobytes())
            self._wh, self._key = img.size, key
        tex = self._tex
        if tex is None:  # made above the first time there are words
            return
        w, h = self._wh
        quad = np.array([x, y, 0, 0, x + w, y, 1, 0, x, y + h, 0, 1,
                         x + w, y, 1, 0, x + w, y + h, 1, 1, x, y + h, 0, 1], dtype="f4")
        self.vbo.write(quad.tobytes())
        self.ctx.enable(self.ctx.BLEND)
        self.ctx.blend_func = self.ctx.SRC_ALPHA, self.ctx.ONE_MINUS_SRC_ALPHA
        tex.use(0)
        self.vao.render(self.ctx.TRIANGLES, vertices=6)
        self.ctx.disable(self.ctx.BLEND)


class CalibrationWindow:
    """The glfw window, its GL context and the frame drawing."""

    def __init__(self, fullscreen: bool = True, title: str = "station calibrate") -> None:
        try:
            import glfw
            import moderngl
        except ImportError as exc:
            raise StationError(f"interactive calibration needs glfw and moderngl ({exc})") from None
        self.glfw = glfw
        if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
            raise StationError("no display: interactive calibration needs X (try Xvfb)")
        if not glfw.init():
            raise StationError("glfw could not initialise (no X display?)")
        monitor = glfw.get_primary_monitor()
        mode = glfw.get_video_mode(monitor)
        width, height = mode.size.width, mode.size.height
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 3)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        if not fullscreen:
            width, height = min(width, 1024), min(height, 768)
        self.window = glfw.create_window(width, height, title, monitor if fullscreen else None,
                                         None)
        if not self.window:
            glfw.terminate()
            raise StationError("glfw could not open a window")
        glfw.make_context_current(self.window)
        glfw.swap_interval(1)
        self.ctx = moderngl.create_context()
        self.size = glfw.get_framebuffer_size(self.window)
        self.renderer = Renderer(self.ctx, self.size)
        self.text = TextPanel(self.ctx, self.size)
        self.words: list[WORDS] = []  # what the panel says (the instruction, the last tap)
        self.escape = False

    def poll(self) -> bool:
        """Handle window events; False when the user closed it or pressed Escape."""
        g = self.glfw
        g.poll_events()
        if g.get_key(self.window, g.KEY_ESCAPE) == g.PRESS:
            self.escape = True
        return not (self.escape or g.window_should_close(self.window))

    def title(self, text: str) -> None:
        self.glfw.set_window_title(self.window, text)

    def draw(self, session: CalibrationSession, cursor: tuple[float, float, bool] | None,
             provisional: Mapping | None) -> None:
        r = self.renderer
        w, h = self.size
        self.ctx.viewport = (0, 0, w, h)
        self.ctx.clear(*BACKGROUND)
        sx, sy = float(w), float(h)
        for res in session.accepted:
            tx, ty = res.xy[0] * sx, res.xy[1] * sy
            r.disc(tx, ty, 9, GREEN)
            if provisional is not None and session.steps[res.target] == "tap":
                mapped = provisional.map(np.array([[res.tap.x, res.tap.y]]),
                                         np.array([[res.tap.tilt_x, res.tap.tilt_y]]))[0]
                ex, ey = (mapped[0] - res.xy[0]) * sx * 10, (mapped[1] - res.xy[1]) * sy * 10
                r.lines([(tx, ty, tx + ex, ty + ey)], YELLOW, 2)
        for res in session.rejected:
            where = res.predicted_px or (res.tap.x * sx, res.tap.y * sy)
            r.xmark(where[0], where[1], 10, RED)
        if not session.done:
            x, y = session.targets[session.current]
            tx, ty = x * sx, y * sy
            r.ring(tx, ty, 22, WHITE, 3)
            r.cross(tx, ty, 34, WHITE, 2)
            step = session.step
            if step == "light":
                r.ring(tx, ty, 10, WHITE, 2)
            elif step in ("hard", "upright"):
                r.disc(tx, ty, 12, WHITE if step == "hard" else YELLOW)
            hint = session.hints[session.current]
            if hint is not None and step == "tap":
                # arrow from the target in the direction the pen top should lean
                ax, ay = math.copysign(1, hint[0]), -math.copysign(1, hint[1])
                n = math.hypot(ax, ay)
                ex, ey = tx + 70 * ax / n, ty + 70 * ay / n
                r.lines([(tx, ty, ex, ey)], YELLOW, 4)
                r.disc(ex, ey, 8, YELLOW)
        if cursor is not None:
            cx, cy, touching = cursor
            r.cross(cx * sx, cy * sy, 12, MAGENTA if touching else CYAN, 2)
        self.text.draw(self.words, *panel_origin(self.size))

    def read_pixels(self) -> np.ndarray:
        """The framebuffer as an (h, w, 3) uint8 image, top row first."""
        w, h = self.size
        data = self.ctx.screen.read(viewport=(0, 0, w, h), components=3, alignment=1)
        return np.frombuffer(data, dtype=np.uint8).reshape(h, w, 3)[::-1].copy()

    def swap(self) -> None:
        self.glfw.swap_buffers(self.window)

    def close(self) -> None:
        self.glfw.destroy_window(self.window)
        self.glfw.terminate()


def _provisional(session: CalibrationSession) -> Mapping | None:
    acc = [r for r in session.position_taps if session.hints[r.target] is None]
    if len(acc) < 3:
        return None

    pts = PointSet(np.array([(r.tap.x, r.tap.y) for r in acc]), np.array([r.xy for r in acc]))
    try:
        return fit_mapping(pts, "affine")[0]
    except CalibrationError:
        return None


def _describe(result: TapResult, session: CalibrationSession, prov: Mapping | None) -> str:
    n = len(session.targets)
    if not result.accepted:
        return f"target {result.target + 1}/{n}: REJECTED ({result.reason}); tap it again"
    note = f" ({result.reason})" if result.reason else ""  # a provisional tap, a withdrawn one
    if prov is not None:
        w, h = session.screen
        m = prov.map(np.array([[result.tap.x, result.tap.y]]))[0]
        err = math.hypot((m[0] - result.xy[0]) * w, (m[1] - result.xy[1]) * h)
        return f"target {result.target + 1}/{n}: ok, residual {err:.1f} px{note}"
    return f"target {result.target + 1}/{n}: ok{note}"


class _Loop:
    """The frame loop state shared by the passes of one calibration."""

    def __init__(self, session: CalibrationSession, source: CalibrationSource,
                 window: CalibrationWindow, timeout: float, out: IO[str]) -> None:
        self.session = session
        self.source = source
        self.window = window
        self.timeout = timeout
        self.out = out
        self.start = time.monotonic()
        self.shown = -1
        self.cursor: tuple[float, float, bool] | None = None
        self.prov: Mapping | None = None

    def run_targets(self) -> bool:
        """Frames until every target has an accepted tap; False if the user cancelled."""
        session, source, window = self.session, self.source, self.window
        self.shown = -1
        while not session.done:
            now = time.monotonic() - self.start
            if now > self.timeout:
                raise StationError(f"calibration timed out after {self.timeout:.0f} s "
                                   f"({session.current}/{len(session.targets)} targets)")
            if not window.poll():
                return False
            if self.shown != len(session.results):
                self.shown = len(session.results)
                source.show_target(session.current, session.targets[session.current],
                                   session.hints[session.current], session.step)
                todo = (f"target {session.current + 1}/{len(session.targets)}: "
                        f"{STEP_TEXT[session.step]}")
                window.title(todo)
                window.words = [(todo, WHITE), *window.words[1:2]]
            sample: PenSample
            for sample in source.poll(now):
                self._cursor(sample)
                result = session.feed(sample)
                if result is not None:
                    self.prov = _provisional(session) or self.prov
                    line = _describe(result, session, self.prov)
                    self.out.write(line + "\n")
                    window.title(line)
                    window.words = [*window.words[:1], (line, GREEN if result.accepted
                                                        else RED)]
                if session.done:
                    break
            if source.exhausted and not session.done:
                raise CalibrationError(
                    f"the device ran out of taps at target {session.current + 1}/"
                    f"{len(session.targets)}")
            window.draw(session, self.cursor, self.prov)
            window.swap()
        return True

    def _cursor(self, sample: PenSample) -> None:
        if not sample.proximity:
            self.cursor = None
            return
        pos = (sample.x, sample.y)
        if self.prov is not None:
            m = self.prov.map(np.array([pos]))[0]
            pos = (float(m[0]), float(m[1]))
        self.cursor = (pos[0], pos[1], sample.touching)


def _result_words(report: FitReport, session: CalibrationSession, w: int, h: int) -> list[WORDS]:
    """The fit in words for the screen: done, residuals in pixels, what was left out."""
    px = max(w, h)
    good = report.max * px <= max(2.0, session.misclick_px / 4)
    return [
        (f"calibration done: {report.model} fit of {len(report.inliers)} taps", WHITE),
        (f"residuals: rms {report.rms * px:.2f} px, max {report.max * px:.2f} px, "
         f"leave-one-out rms {(report.loo_rms or 0) * px:.2f} px", GREEN if good else YELLOW),
        (f"misclicks rejected on the spot: {len(session.rejected)}, excluded by the fit: "
         f"{len(report.outliers)}", WHITE),
        ("saved; Esc closes this window" if good else
         "saved; the max residual is large: calibrate again if the pen feels off", WHITE),
    ]


def _hold(window: CalibrationWindow, source: CalibrationSource, session: CalibrationSession,
          report: FitReport,
          seconds: float) -> None:
    """Keep the result on screen for an installer to read (Esc ends it; so does a
    recorded or mock source that has nothing more to give)."""
    end = time.monotonic() + seconds
    while time.monotonic() < end and not source.exhausted and window.poll():
        window.draw(session, None, report.mapping)
        window.swap()
        time.sleep(0.05)


def run_interactive(args: argparse.Namespace) -> int:
    """The ``--device`` mode of ``station calibrate``."""
    source = open_source(args.device)
    window = CalibrationWindow(fullscreen=not args.windowed)
    out = sys.stdout
    try:
        session = CalibrationSession(
            screen=(int(window.size[0]), int(window.size[1])), points=args.points,
            tilt_pass=args.tilt_pass, pressure_pass=args.pressure_pass,
            misclick_px=args.misclick_px, model=args.model or "auto",
        )
        out.write(f"calibrating {source.device.describe()} on a {window.size[0]}×{window.size[1]} "
                  f"screen: {len(session.targets)} targets\n")
        loop = _Loop(session, source, window, args.timeout, out)
        while True:
            if not loop.run_targets():
                out.write("calibration cancelled\n")
                return 1
            if session.finish(args.noise):
                break
            again = len(session.targets) - session.current
            out.write(f"the fit excluded {again} tap(s) as misclicks: asking those targets "
                      "again\n")
        report = session.report
        if report is None:  # finish() always fits; keeps mypy and readers sure
            raise StationError("no fit")
        w, h = session.screen
        window.words = _result_words(report, session, w, h)
        window.title(window.words[0][0])
        window.draw(session, None, report.mapping)
        pixels = window.read_pixels()
        window.swap()
        if args.screenshot:
            from PIL import Image

            Image.fromarray(pixels).save(args.screenshot)
        out.write(
            f"fit: {report.model}, rms {report.rms * max(w, h):.2f} px, max "
            f"{report.max * max(w, h):.2f} px, leave-one-out rms "
            f"{(report.loo_rms or 0) * max(w, h):.2f} px; misclicks rejected on the spot: "
            f"{len(session.rejected)}, excluded by the fit: {len(report.outliers)}"
            + ("; swapped axes" if session.swapped_axes else "") + "\n"
        )
        for note in report.notes:
            out.write(f"note: {note}\n")
        if report.mapping.parallax != (0.0, 0.0):
            g = source.geometry
            px, py = report.mapping.parallax
            mm = ""
            if g.units_per_mm:
                mm = (f" = ({px * (g.x_max - g.x_min) / g.units_per_mm[0]:.2f}, "
                      f"{py * (g.y_max - g.y_min) / g.units_per_mm[1]:.2f}) mm")
            out.write(f"parallax per tan(tilt): ({px:.5f}, {py:.5f}) device-normalised{mm}\n")
        fit = FitInfo(report.model, tuple(map(tuple, report.mapping.matrix)),
                      report.mapping.parallax, report.rms, report.max, report.loo_rms,
                      len(report.inliers))
        cal = Calibration(source.device, source.geometry, fit,
                          area=AreaSettings(output_pixels=(w, h)))
        if session.pressure is not None:
            cal.pressure = session.pressure
            out.write(f"pressure: threshold {session.pressure.threshold:.3f}, maximum "
                      f"{session.pressure.maximum:.3f}\n")
        if session.tilt is not None:
            cal.tilt = session.tilt
            out.write(f"tilt offset: ({session.tilt.offset_x:.2f}, "
                      f"{session.tilt.offset_y:.2f}) degrees\n")
        path = Path(args.output) if args.output else default_path(source.device)
        write_file(cal, path)
        out.write(f"wrote {path}\n")
        window.words[-1] = (window.words[-1][0].replace("saved", f"saved to {path}"),
                            window.words[-1][1])
        _hold(window, source, session, report, args.result_seconds)
        return 0
    finally:
        window.close()
        source.close()
