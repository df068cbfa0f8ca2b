"""The kiosk's drawing: the scene (table, canvas at the screen's resolution), the
brush's shadow, the panel's UI and the composition of what changed into the back buffer.

Functions of the app (:class:`~station.kiosk.app.KioskApp`), by job."""

from __future__ import annotations

import logging
import math
import os
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from station.kiosk import pen_input
from station.kiosk.attract import INVITATION, demo_stroke
from station.kiosk.compose import Box, merge_rects, screen_box
from station.kiosk.config import (
    ATTRACT_FRAME_S,
    REDRAW_EVERY_S,
    STATUS_EVERY_S,
)
from station.kiosk.ui import draw_attract, draw_banner, draw_panel, draw_qr
from station.kiosk.views import Camera, input_camera, make_camera

if TYPE_CHECKING:  # the functions take the app; no import at run time (app imports us)
    from station.kiosk.app import KioskApp

log = logging.getLogger(__name__)

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

#: A pen heard this recently is at work (its frames are not made whole for safety).
PEN_AT_WORK_S = 0.5

BACKGROUND = (0.13, 0.13, 0.15)
TABLE = (0.42, 0.29, 0.18, 1.0)
SHADOW = (0.0, 0.0, 0.0, 0.28)
CURSOR_TOUCH = (0.1, 0.1, 0.1, 0.55)


def camera(app: KioskApp) -> Camera:
    return make_camera(app.panel.view, app.area, app.aspect, app.follow_at)


def flat(app: KioskApp, cam: Camera, pts: np.ndarray, color: tuple[float, ...], mode: int) -> None:
    data = np.asarray(pts, "f4").tobytes()
    if len(data) > app.flat_vbo.size:
        app.flat_vbo.orphan(len(data))
    app.flat_vbo.write(data)
    app.flat_prog["vp"].write(cam.vp.T.astype("f4").tobytes())
    app.flat_prog["color"].value = color
    app.flat_vao.render(mode, vertices=len(pts))


def draw_scene(app: KioskApp, cam: Camera, clip: Box | None = None) -> None:
    """The view of the canvas (background, table, canvas) into the bound framebuffer;
    ``clip``: only inside these window pixels (x0, y0, x1, y1)."""
    ctx = app.ctx
    w, h = app.size
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
        flat(app, cam, np.array([[-t, t, -1e-3], [t, t, -1e-3], [-t, -t, -1e-3],
                                  [t, -t, -1e-3]]), TABLE, ctx.TRIANGLE_STRIP)
    draw_canvas(app, cam, app.display.texture)
    ctx.disable(ctx.BLEND)
    ctx.viewport = (0, 0, w, h)
    ctx.scissor = None


def draw_canvas(app: KioskApp, cam: Camera, texture: Any) -> None:
    """The canvas quad at the screen's resolution (:mod:`station.kiosk.subcell`)."""
    prog = app.canvas_prog
    texture.use(0)
    prog["canvas"].value = 0
    app.display.surface.use(prog, 1)
    use_steps(prog, app.display.steps, 3)
    prog["cells"].value = (float(app.cfg.width), float(app.cfg.height))
    prog["vp"].write(cam.vp.T.astype("f4").tobytes())
    app.canvas_vao.render(app.ctx.TRIANGLE_STRIP)


def use_steps(prog: Any, steps: Any, unit: int) -> None:
    """Bind the steps' texture (hard edges inside the paint, :mod:`station.kiosk.subcell`)
    to ``unit``, or tell the shader there is none."""
    if steps is not None:
        steps.use(unit)
        prog["steps"].value = unit
    prog["step_contours"].value = steps is not None


def reference_picture(app: KioskApp) -> np.ndarray:
    """The window's picture drawn from scratch (sRGB8, H×W×3, row 0 on top): the whole
    canvas rendered afresh (:meth:`CpuDisplay.full_texture`), the whole scene and UI,
    no shadow — what the screen must show outside the shadow, however it got there."""
    ctx = app.ctx
    w, h = app.size
    tex = ctx.texture((w, h), 4)
    fbo = ctx.framebuffer([tex])
    full = app.display.full_texture()
    real = app.display.texture
    full_steps = app.display.full_steps()
    real_steps = app.display.steps
    try:
        fbo.use()
        app.display.texture = full
        app.display.steps = full_steps
        draw_scene(app, camera(app))
        app.gui.draw((0, 0, w, h))
        data = fbo.read(viewport=(0, 0, w, h), components=3, alignment=1)
    finally:
        app.display.texture = real
        app.display.steps = real_steps
        if full is not real:
            full.release()
        if full_steps is not None and full_steps is not real_steps:
            full_steps.release()
        fbo.release()
        tex.release()
        ctx.screen.use()
    return np.frombuffer(data, np.uint8).reshape(h, w, 3)[::-1]


def predicted_hover(app: KioskApp) -> tuple[float, float] | None:
    """Canvas (u, v) of the pen's shadow: the pen as predicted for when this frame is
    seen (:mod:`station.kiosk.predict`), where it is over the canvas."""
    app._cursor_drawn = None
    if app.hover is None:
        return None
    last = app.predictor.last()
    p = app.predictor.predict(age=time.monotonic() - app._pen_received)
    if p is None or last is None:
        return app.hover
    uv = input_camera(app.panel.view, app.area, app.aspect).screen_to_canvas(*p) \
        if p[0] >= app.panel_w else None
    if uv is None or not (0.0 <= uv[0] <= 1.0 and 0.0 <= uv[1] <= 1.0):
        uv = app.hover
    app._cursor_drawn = ((last[1], last[2]), p)
    app._shadow_read = app._pen_read
    return uv


def cursor_shape(app: KioskApp, cam: Camera) -> tuple[np.ndarray, tuple[float, ...]] | None:
    """The brush's shadow: a disc (world points, a triangle fan) the size of its
    footprint at full pressure, offset as if lit from the top left, where the pen is
    predicted to be when this frame shows; with its colour.  ``None``: no pen."""
    shown = predicted_hover(app)
    if shown is None:
        return None
    r = app.session.player.brush.settings.size / 2 / app.cfg.height
    u, v = shown
    off = 0.0 if app.touching else 0.006
    c = cam.canvas_to_world(u + off, v + off)
    ang = np.linspace(0, 2 * math.pi, 41)
    ring = np.column_stack([c[0] + r * np.cos(ang), c[1] + r * np.sin(ang),
                            np.full(ang.size, 1e-4)])
    return (np.vstack([[c[0], c[1], 1e-4], ring]),
            CURSOR_TOUCH if app.touching else SHADOW)


def draw_cursor(app: KioskApp, cam: Camera, shape: tuple[np.ndarray, tuple[float, ...]]) -> None:
    """The shadow (:meth:`cursor_shape`) over the presented picture."""
    ctx = app.ctx
    w, h = app.size
    ctx.viewport = cam.viewport.gl(h)
    ctx.enable(ctx.BLEND)
    ctx.blend_func = ctx.SRC_ALPHA, ctx.ONE_MINUS_SRC_ALPHA
    flat(app, cam, shape[0], shape[1], ctx.TRIANGLE_FAN)
    ctx.disable(ctx.BLEND)
    ctx.viewport = (0, 0, w, h)


def canvas_rect(app: KioskApp) -> list[float]:
    """Where the canvas is on the screen in the 2D view: x, y, width, height (pixels)."""
    cam = make_camera("2d", app.area, app.aspect)
    x0, y0 = cam.world_to_screen(cam.canvas_to_world(0.0, 0.0)) or (0.0, 0.0)
    x1, y1 = cam.world_to_screen(cam.canvas_to_world(1.0, 1.0)) or (0.0, 0.0)
    return [x0, y0, x1 - x0, y1 - y0]


def status_line(app: KioskApp) -> str:
    s = app.session
    m = s.moisture()
    parts = []
    if m is not None:
        parts.append(m.line())
        if m.word != "dry":
            parts.append("drying" if s.active_tiles() else "settled")
    if s.counters.bad_samples:
        parts.append("layer full: press New layer")
    return "  ".join(parts)


def build_ui(app: KioskApp, dt: float) -> int:
    """One ImGui frame (panel, QR, banners), not drawn yet; returns its hash."""
    app.gui.new_frame(dt)
    w, h = app.size
    app.rects = {}
    draw_panel(app.panel, app.panel_w, h, status_text(app), app.rects)
    if app.qr is not None:
        side = min(240.0, h * 0.3)
        draw_qr(app.qr[0], w - side - 40, h - side - 80, side, app.rects)
    now = time.monotonic()
    a = app.area
    if pen_input.pen_missing(app):
        draw_banner("The pen is unplugged - please wait, it will be back",
                    a.x + 20, a.y + 20, a.w - 40, 110, "unplugged", big=False)
    elif app.idle.attract(now):
        draw_attract(a.x, a.y, a.w, a.h, INVITATION, attract_image(app, now),
                     demo_stroke(now, a.w, a.h), app.rects)
    else:
        app._attracting = False
    return app.gui.end_frame()


def attract_image(app: KioskApp, now: float) -> tuple[int, tuple[int, int]] | None:
    """The replay frame the attract screen shows now (an ImGui texture), or ``None``
    (no replay in the gallery: the demo stroke)."""
    if not app._attracting:
        app._attracting = True
        app.attract_show.start(now)
    rgba, new = app.attract_show.frame(now)
    if rgba is None:
        return None
    if new or app._attract_tex is None:
        h, w = rgba.shape[:2]
        # a new texture (and ImGui id) for each new frame: the compositor redraws the
        # UI where its draw data changed, and an id is what changes
        old = app._attract_tex
        tex = app.ctx.texture((w, h), 4, np.ascontiguousarray(rgba).tobytes())
        tex.filter = (app.ctx.LINEAR, app.ctx.LINEAR)
        app._attract_tex = (app.gui.add_texture(tex), (w, h), tex)
        if old is not None:
            app.gui.textures.pop(old[0], None)
            old[2].release()
    tid, size, _tex = app._attract_tex
    return tid, size


def ui_key(app: KioskApp, now: float) -> tuple[Any, ...]:
    """What the panel and overlays show; the last item: the pen is near the panel
    (ImGui must see it every frame: hover, taps, drags)."""
    p = app.panel
    pen = app.session.last_pen
    near = pen is not None and pen.proximity and \
        (pen.x * app.size[0] < app.panel_w + 40 or app.capture == "ui")
    return (status_text(app), tuple(sorted(p.mix.items())), p.size, p.water,
            p.strength, p.kind, p.view, p.confirm_clear, p.eraser, p.message, p.mixing,
            p.can_undo(), len(p.pressed), app.qr_url, pen_input.pen_missing(app),
            app.idle.attract(now) and int(now / ATTRACT_FRAME_S), near)


def status_text(app: KioskApp) -> str:
    """The status line, refreshed every :data:`STATUS_EVERY_S` (people read it; a
    text changing every step would redraw the panel every step)."""
    now = time.monotonic()
    if now >= app._status_due:
        app._status_due = now + STATUS_EVERY_S
        app._status_cache = status_line(app)
    return app._status_cache


def build_ui_if_changed(app: KioskApp, dt: float) -> None:
    """Build the UI when what it shows may have changed (else ImGui's last draw data
    stays valid: no new frame)."""
    now = time.monotonic()
    key = ui_key(app, now)
    if (key != app._ui_last_key or key[-1] or bool(app.screenshots)
            or now - app._ui_built >= REDRAW_EVERY_S):
        ui_hash = build_ui(app, now - app._ui_built if app._ui_built else dt)
        if ui_hash != app._ui_hash or app._ui_tris is None:  # (the same drawing: as it was)
            app._ui_hash = ui_hash
            app._ui_bounds = app.gui.bounds()
            app._ui_tris = app.gui.triangles()
        app._ui_last_key, app._ui_built = key, now


def compose_changes(app: KioskApp, cam: Camera) -> None:
    """Redraw the parts of the picture that the display re-rendered since the last
    call and where the UI changed (see compose.py); called before the late latch (the
    tiles) and after it (the pen's preview).  The GL work is flushed at once, so the
    rasteriser draws the first part while the window takes the pen."""
    boxes = app.compositor.update(cam, app.display.damage,
                                   (app.cfg.width, app.cfg.height), app._ui_hash,
                                   app._ui_bounds, lambda box: draw_scene(app, cam, box),
                                   app.gui.draw, app._ui_tris)
    app.display.damage = []
    app.frame_pixels += app.compositor.pixels_redrawn
    app._frame_full = app._frame_full or app.compositor.full_last
    app._frame_boxes.extend(boxes)
    if app._glflush is not None:
        app._glflush()


def fill_back_buffer(app: KioskApp, cam: Camera) -> None:
    """The picture into the back buffer — all of it, or only where the window changes
    when the presenter copies rectangles — and the shadow over it."""
    shadow = cursor_shape(app, cam)
    shadow_box = None if shadow is None else screen_box(cam, shadow[0],
                                                          (app.size[0], app.size[1]))
    now = time.monotonic()
    if (app.screenshots or app._frame_full
            or app.presenter.needs_whole(now, app._last_whole,
                                         painting=now - app._pen_received < PEN_AT_WORK_S)):
        app.compositor.present()
        app._present_rects = None
        app._last_whole = now
    else:
        # merged once: overlapping rectangles would be copied twice, here and to X
        rects = merge_rects([b for b in (*app._frame_boxes, app._shadow_box,
                                         shadow_box) if b is not None])
        # the safety net's rows, apart: merged, a window-wide band would widen any
        # rectangle it touches to the window's width
        band = app.presenter.rolling_band(now)
        if band is not None:
            rects.append(band)
        app.compositor.present(rects)
        app._present_rects = rects
    app._frame_boxes = []
    app._frame_full = False
    app._shadow_box = shadow_box
    if shadow is not None:
        draw_cursor(app, cam, shadow)


def screenshot(app: KioskApp, path: Path) -> None:
    from PIL import Image

    w, h = app.size
    data = app.ctx.screen.read(viewport=(0, 0, w, h), components=3, alignment=1)
    img = np.frombuffer(data, np.uint8).reshape(h, w, 3)[::-1]
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    Image.fromarray(img).save(tmp, format="PNG")
    os.replace(tmp, path)  # whoever waits for the file never sees half of it
