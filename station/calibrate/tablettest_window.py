"""The tablet tester's window: glfw + Dear ImGui (imgui-bundle) over moderngl, as the kiosk.

Left: the pen's trail, pressure as width (magenta touching, grey hovering), on the
tablet's shape.  Right: the last raw report's fields beside the normalised sample;
the pressure curve with the live point and the tip threshold, editable (the curve's
two control points, the threshold); "Save to my device settings".  The mouse works
the sliders; the pen being tested never drives the UI (it is what is measured).
"""

from __future__ import annotations

import itertools
import time
from pathlib import Path

import glfw
import moderngl
import numpy as np
from imgui_bundle import imgui

from station.calibrate.tablettest import TabletTester, TesterSettings
from station.drivers.transport.base import EndOfStream, TransportError
from station.errors import StationError
from station.glkit.imgui_gl import ImGuiLayer

PANEL_W = 520  # pixels of the right-hand panel
TOUCH = imgui.IM_COL32(230, 60, 200, 255)
HOVER = imgui.IM_COL32(150, 150, 160, 160)
CURVE = imgui.IM_COL32(240, 240, 240, 255)
LIVE = imgui.IM_COL32(60, 220, 90, 255)
THRESHOLD = imgui.IM_COL32(240, 190, 40, 255)
FRAME = imgui.IM_COL32(90, 90, 100, 255)


class TesterWindow:
    """One window; :meth:`run` until closed, the source ends (plus ``linger`` seconds)
    or ``frames`` frames; an optional screenshot of the last frame."""

    def __init__(self, tester: TabletTester, size: tuple[int, int] = (1280, 760)) -> None:
        if not glfw.init():
            raise StationError("glfw could not initialise (no display? try Xvfb or --terminal)")
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 3)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        self.window = glfw.create_window(size[0], size[1], "station tablet-test", None, None)
        if not self.window:
            glfw.terminate()
            raise StationError("glfw could not open a window")
        glfw.make_context_current(self.window)
        glfw.swap_interval(1)
        self.ctx: moderngl.Context = moderngl.create_context()
        fw, fh = glfw.get_framebuffer_size(self.window)
        self.size: tuple[int, int] = (int(fw), int(fh))
        self.gui = ImGuiLayer(self.ctx, self.size, scale=1.15)
        self.tester = tester
        s = tester.settings
        self.curve = list(s.curve)
        self.threshold = s.threshold
        self.message = ""
        self.ended = False

    # -- the frame -------------------------------------------------------------------
    def _pen_view(self) -> None:
        w, h = self.size
        imgui.set_next_window_pos(imgui.ImVec2(0, 0))
        imgui.set_next_window_size(imgui.ImVec2(w - PANEL_W, h))
        flags = imgui.WindowFlags_.no_move | imgui.WindowFlags_.no_resize | \
            imgui.WindowFlags_.no_collapse
        imgui.begin("Pen (pressure as width)", None, flags)
        r = self.tester.source.ranges
        aspect = (r.x.span or 1) / (r.y.span or 1)
        if r.has_resolution:
            aspect *= float(r.y.resolution or 1) / float(r.x.resolution or 1)
        origin = imgui.get_cursor_screen_pos()
        avail = imgui.get_content_region_avail()
        aw, ah = avail.x, avail.y - 30
        bw, bh = (aw, aw / aspect) if aw / aspect <= ah else (ah * aspect, ah)
        dl = imgui.get_window_draw_list()
        x0, y0 = origin.x, origin.y
        dl.add_rect(imgui.ImVec2(x0, y0), imgui.ImVec2(x0 + bw, y0 + bh), FRAME, 0.0, 2.0)
        prev = None
        for p in self.tester.trail:
            pt = imgui.ImVec2(x0 + p.x * bw, y0 + p.y * bh)
            if prev is not None:
                if p.touching and prev[1]:
                    dl.add_line(prev[0], pt, TOUCH, 1.0 + 16.0 * p.pressure)
                else:
                    dl.add_line(prev[0], pt, HOVER, 1.0)
            prev = (pt, p.touching)
        imgui.dummy(imgui.ImVec2(bw, bh))
        imgui.text(f"{self.tester.raw_count} raw samples, {self.tester.sample_count} "
                   f"normalised{'  (the source has ended)' if self.ended else ''}")
        imgui.end()

    def _panel(self) -> None:
        w, h = self.size
        t = self.tester
        imgui.set_next_window_pos(imgui.ImVec2(w - PANEL_W, 0))
        imgui.set_next_window_size(imgui.ImVec2(PANEL_W, h))
        flags = imgui.WindowFlags_.no_move | imgui.WindowFlags_.no_resize | \
            imgui.WindowFlags_.no_collapse
        imgui.begin("What the pen sends", None, flags)
        d = t.source.describe()
        imgui.text_wrapped(f"{d.get('product', '')} ({d.get('usb_id', '')}), "
                           f"{d.get('parser', '')}")
        raw, norm = t.raw_fields(), t.sample_fields()
        if imgui.begin_table("fields", 4, imgui.TableFlags_.borders_inner_v):
            for i in range(max(len(raw), len(norm))):
                imgui.table_next_row()
                for col, rows in ((0, raw), (2, norm)):
                    imgui.table_set_column_index(col)
                    imgui.text(rows[i][0] if i < len(rows) else "")
                    imgui.table_set_column_index(col + 1)
                    imgui.text(rows[i][1] if i < len(rows) else "")
            imgui.end_table()
        imgui.separator()
        imgui.text("Pressure curve (raw -> painted) and tip threshold")
        self._curve_plot()
        changed = False
        for i, label in enumerate(("x1", "y1", "x2", "y2")):
            c, v = imgui.slider_float(label, self.curve[i], 0.0, 1.0, "%.2f")
            if c:
                self.curve[i], changed = v, True
        c, v = imgui.slider_float("tip threshold", self.threshold, 0.0, 0.5, "%.3f")
        if c:
            self.threshold, changed = v, True
        if changed:
            t.apply(TesterSettings(tuple(self.curve), self.threshold))  # type: ignore[arg-type]
        if imgui.button("Save to my device settings"):
            try:
                self.message = f"saved to {t.save()}"
            except Exception as exc:  # a read-only home: said on screen, the test goes on
                self.message = f"not saved: {exc}"
        if self.message:
            imgui.text_wrapped(self.message)
        imgui.end()

    def _curve_plot(self) -> None:
        t = self.tester
        dl = imgui.get_window_draw_list()
        o = imgui.get_cursor_screen_pos()
        size = PANEL_W - 60.0
        sz = min(size, 150.0)

        def at(px: float, py: float) -> imgui.ImVec2:
            return imgui.ImVec2(o.x + px * sz, o.y + (1.0 - py) * sz)

        dl.add_rect(at(0, 1), at(1, 0), FRAME)
        pts = t.curve_points(48)
        for (ax, ay), (bx, by) in itertools.pairwise(pts):
            dl.add_line(at(ax, ay), at(bx, by), CURVE, 2.0)
        dl.add_line(at(self.threshold, 0), at(self.threshold, 1), THRESHOLD, 2.5)
        live = t.live_point()
        if live is not None:
            dl.add_circle_filled(at(*live), 6.0, LIVE)
        imgui.dummy(imgui.ImVec2(sz, sz + 6))

    def frame(self) -> None:
        x, y = glfw.get_cursor_pos(self.window)
        down = glfw.get_mouse_button(self.window, glfw.MOUSE_BUTTON_LEFT) == glfw.PRESS
        self.gui.pointer(x, y, down)
        self.gui.new_frame(1 / 60)
        self._pen_view()
        self._panel()
        self.ctx.viewport = (0, 0, *self.size)
        self.ctx.clear(0.09, 0.09, 0.11)
        self.gui.render()

    def screenshot(self, path: Path) -> None:
        from PIL import Image

        w, h = self.size
        data = self.ctx.screen.read(viewport=(0, 0, w, h), components=3, alignment=1)
        img = np.frombuffer(data, np.uint8).reshape(h, w, 3)[::-1]
        Image.fromarray(img).save(path)

    def run(self, duration: float | None, linger: float, screenshot: Path | None) -> None:
        start = time.monotonic()
        end_at: float | None = None
        try:
            while not glfw.window_should_close(self.window):
                now = time.monotonic()
                if duration is not None and now - start >= duration:
                    break
                if end_at is not None and now >= end_at:
                    break
                if not self.ended:
                    try:
                        for _ in range(64):  # drain what came since the last frame
                            if not self.tester.poll(0.0):
                                break
                    except (EndOfStream, TransportError):
                        self.ended = True
                        end_at = now + linger
                self.frame()
                if screenshot is not None and (end_at is not None or (
                        duration is not None and now - start >= duration - 0.1)):
                    self.screenshot(screenshot)
                glfw.swap_buffers(self.window)
                glfw.poll_events()
        finally:
            self.gui.close()
            glfw.destroy_window(self.window)
            glfw.terminate()
