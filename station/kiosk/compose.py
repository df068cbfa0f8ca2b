"""The window's picture, redrawn only where it changed (damage rectangles).

A frame of the kiosk is the view of the canvas (background, table, canvas)
with the ImGui panel and overlays on top, and the brush's shadow on top of
everything.  Redrawing all of it every frame costs 7–10 ms on llvmpipe
(1024×768: the canvas shader's sRGB transfer per pixel, the panel's
triangles), most of a 60 Hz frame; yet while a visitor paints, a frame
changes a brush-sized part of the canvas.

So the picture without the shadow is kept in a framebuffer of its own (RGBA8,
window-sized).  Each frame redraws there only the damaged rectangles — the
canvas cells the display re-rendered (projected to the screen), and where the
UI's drawing changed (the union of its old and new extent) — with the scissor
test, scene then UI, so overlays stay on top.  A new camera (view switch, the
following camera moving) redraws everything.  The framebuffer is then copied
to the window's back buffer (one texel fetch per pixel, no filtering), the
shadow drawn over it, and the buffers swapped: on every GPU the back buffer's
content after a swap is undefined, so it is never relied on.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from station.kiosk.views import Camera

Box = tuple[int, int, int, int]  # window pixels x0, y0, x1, y1 (origin top-left, exclusive)

COPY_VERT = """
#version 330
in vec2 pos;
void main() { gl_Position = vec4(pos, 0.0, 1.0); }
"""
COPY_FRAG = """
#version 330
uniform sampler2D picture;
out vec4 frag;
void main() { frag = texelFetch(picture, ivec2(gl_FragCoord.xy), 0); }
"""

#: Pixels added around a projected canvas rectangle: linear filtering reads one texel
#: beyond a cell, and rounding of the projection.
MARGIN_PX = 3


def union(a: Box | None, b: Box | None) -> Box | None:
    if a is None:
        return b
    if b is None:
        return a
    return (min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3]))


def canvas_box(cam: Camera, cells: tuple[int, int, int, int], width: int, height: int
               ) -> Box | None:
    """Window pixels covering the canvas cells ``(y0, y1, x0, x1)`` in view ``cam``
    (``None``: a corner lies behind the camera — redraw it all)."""
    y0, y1, x0, x1 = cells
    pts = []
    for u, v in ((x0 / width, y0 / height), (x1 / width, y0 / height),
                 (x0 / width, y1 / height), (x1 / width, y1 / height)):
        p = cam.world_to_screen(cam.canvas_to_world(u, v))
        if p is None:
            return None
        pts.append(p)
    xs = [p[0] for p in pts]
    ys = [p[1] for p in pts]
    vp = cam.viewport
    box = (max(int(min(xs)) - MARGIN_PX, vp.x), max(int(min(ys)) - MARGIN_PX, vp.y),
           min(int(max(xs)) + 1 + MARGIN_PX, vp.x + vp.w),
           min(int(max(ys)) + 1 + MARGIN_PX, vp.y + vp.h))
    return box if box[2] > box[0] and box[3] > box[1] else None


class Compositor:
    """The kiosk's picture in a framebuffer of its own (see the module docstring)."""

    def __init__(self, ctx: Any, size: tuple[int, int]) -> None:
        self.ctx = ctx
        self.size = size
        self.texture = ctx.texture(size, 4)
        self.texture.filter = (ctx.NEAREST, ctx.NEAREST)
        self.fbo = ctx.framebuffer([self.texture])
        self.prog = ctx.program(vertex_shader=COPY_VERT, fragment_shader=COPY_FRAG)
        self.vbo = ctx.buffer(np.array([-1, -1, 1, -1, -1, 1, 1, 1], "f4").tobytes())
        self.vao = ctx.vertex_array(self.prog, [(self.vbo, "2f", "pos")])
        self._camera_key: bytes | None = None
        self._ui_hash: int | None = None
        self._ui_box: Box | None = None
        self.pixels_redrawn = 0  # window pixels redrawn in the picture by the last frame
        self.full_redraws = 0

    def invalidate(self) -> None:
        """Redraw everything next frame (a fresh canvas, a screenshot's exact picture)."""
        self._camera_key = None

    def update(self, cam: Camera, canvas_cells: list[tuple[int, int, int, int]],
               canvas_size: tuple[int, int], ui_hash: int, ui_box: Box | None,
               draw_scene: Callable[[Box], None], draw_ui: Callable[[Box], None]) -> int:
        """Redraw the damaged parts of the picture; returns the pixels redrawn.

        ``canvas_cells``: canvas rectangles ``(y0, y1, x0, x1)`` re-rendered since the
        last frame; ``ui_hash``/``ui_box``: the UI's drawing this frame and its extent;
        ``draw_scene(clip)`` draws the view of the canvas, ``draw_ui(clip)`` the UI, both
        only inside ``clip``.
        """
        w, h = self.size
        key = cam.vp.astype("f4").tobytes() + repr(cam.viewport).encode()
        boxes: list[Box] = []
        if key != self._camera_key:
            boxes = [(0, 0, w, h)]
            self.full_redraws += 1
        else:
            cw, ch = canvas_size
            damage: Box | None = None
            for cells in canvas_cells:
                b = canvas_box(cam, cells, cw, ch)
                if b is None:
                    damage = (0, 0, w, h)
                    break
                damage = union(damage, b)
            if damage is not None:
                boxes.append(damage)
            if ui_hash != self._ui_hash:
                ui_damage = union(self._ui_box, ui_box)
                if ui_damage is not None:
                    boxes.append(ui_damage)
        self._camera_key = key
        self._ui_hash = ui_hash
        self._ui_box = ui_box
        if len(boxes) == 2 and _overlap(boxes[0], boxes[1]):
            merged = union(boxes[0], boxes[1])
            boxes = [merged] if merged is not None else []
        ctx = self.ctx
        self.fbo.use()
        pixels = 0
        for x0, y0, x1, y1 in boxes:
            x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
            if x1 <= x0 or y1 <= y0:
                continue
            draw_scene((x0, y0, x1, y1))
            draw_ui((x0, y0, x1, y1))
            pixels += (x1 - x0) * (y1 - y0)
        ctx.scissor = None
        self.pixels_redrawn = pixels
        return pixels

    def present(self) -> None:
        """Copy the picture into the window's back buffer (bound after the call)."""
        ctx = self.ctx
        ctx.screen.use()
        w, h = self.size
        ctx.viewport = (0, 0, w, h)
        ctx.scissor = None
        ctx.disable(ctx.BLEND)
        self.texture.use(0)
        self.prog["picture"].value = 0
        self.vao.render(ctx.TRIANGLE_STRIP)

    def release(self) -> None:
        self.vao.release()
        self.vbo.release()
        self.prog.release()
        self.fbo.release()
        self.texture.release()


def _overlap(a: Box, b: Box) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]
