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
from typing import TYPE_CHECKING, Any

import numpy as np

from station.kiosk.views import Camera

if TYPE_CHECKING:  # imgui-bundle is an optional extra; only the type is needed here
    from station.glkit.imgui_gl import UiTriangles

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

#: Damaged rectangles closer than this (window pixels) are redrawn as one.
MERGE_GAP_PX = 24


def union(a: Box | None, b: Box | None) -> Box | None:
    if a is None:
        return b
    if b is None:
        return a
    return (min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3]))


def canvas_box(cam: Camera, cells: tuple[int, int, int, int], width: int, height: int
               ) -> Box | None:
    """Window pixels covering the canvas cells ``(y0, y1, x0, x1)`` in view ``cam``
    (``None``: a corner lies behind the camera — redraw it all — or it is off screen)."""
    boxes = canvas_boxes(cam, [cells], width, height)
    return boxes[0] if boxes else None


def canvas_boxes(cam: Camera, cells: list[tuple[int, int, int, int]], width: int,
                 height: int) -> list[Box] | None:
    """:func:`canvas_box` of many cell rectangles in one projection (``None``: one has a
    corner behind the camera — redraw it all)."""
    if not cells:
        return []
    c = np.asarray(cells, float)  # y0, y1, x0, x1
    u = np.stack([c[:, 2], c[:, 3], c[:, 2], c[:, 3]], axis=1) / width
    v = np.stack([c[:, 0], c[:, 0], c[:, 1], c[:, 1]], axis=1) / height
    world = np.stack([(u - 0.5) * cam.aspect, 0.5 - v, np.zeros_like(u), np.ones_like(u)],
                     axis=-1)  # Camera.canvas_to_world, homogeneous
    clip = world @ cam.vp.T
    if not (clip[..., 3] > 1e-9).all():
        return None
    vp = cam.viewport
    xs = vp.x + (clip[..., 0] / clip[..., 3] + 1) / 2 * vp.w
    ys = vp.y + (1 - clip[..., 1] / clip[..., 3]) / 2 * vp.h
    x0 = np.maximum(np.floor(xs.min(axis=1)).astype(int) - MARGIN_PX, vp.x)
    y0 = np.maximum(np.floor(ys.min(axis=1)).astype(int) - MARGIN_PX, vp.y)
    x1 = np.minimum(np.floor(xs.max(axis=1)).astype(int) + 1 + MARGIN_PX, vp.x + vp.w)
    y1 = np.minimum(np.floor(ys.max(axis=1)).astype(int) + 1 + MARGIN_PX, vp.y + vp.h)
    return [(int(a), int(b), int(c_), int(d)) for a, b, c_, d in zip(x0, y0, x1, y1, strict=True)
            if c_ > a and d > b]


def screen_box(cam: Camera, pts: np.ndarray, size: tuple[int, int]) -> Box | None:
    """Window pixels covering the world points ``pts`` (N×3) in view ``cam``, clipped to
    the window of ``size``; ``None`` if none is in front of the camera or on screen."""
    c = np.column_stack([pts, np.ones(len(pts))]) @ cam.vp.T
    front = c[:, 3] > 1e-9
    if not front.all():
        return None if not front.any() else (0, 0, size[0], size[1])
    ndc = c[:, :2] / c[:, 3:4]
    vp = cam.viewport
    xs = vp.x + (ndc[:, 0] + 1) / 2 * vp.w
    ys = vp.y + (1 - ndc[:, 1]) / 2 * vp.h
    box = (max(int(xs.min()) - MARGIN_PX, 0), max(int(ys.min()) - MARGIN_PX, 0),
           min(int(xs.max()) + 1 + MARGIN_PX, size[0]),
           min(int(ys.max()) + 1 + MARGIN_PX, size[1]))
    return box if box[2] > box[0] and box[3] > box[1] else None


#: The grid (window pixels) the UI's changed triangles are gathered on into rectangles.
UI_GRID_PX = 16

#: More rectangles than this of UI damage are redrawn as their bounding box.
UI_MOST_RECTS = 32


def ui_damage(old: UiTriangles, new: UiTriangles, size: tuple[int, int]) -> list[Box]:
    """Window rectangles where the UI drawn as ``new`` may differ from ``old``.

    A pixel's colour is the blend of the triangles that cover it, in drawing order.
    Triangles at the start and the end of both frames are the same ones; in between,
    where the triangles that both frames draw keep their order, only the pixels of
    triangles that one of them draws and the other does not can change (a status line's
    new text: its glyphs, not the panel around it).  Otherwise every triangle in between
    counts as changed."""
    ho, hn = old.hashes, new.hashes
    n = min(ho.size, hn.size)
    differs = ho[:n] != hn[:n]
    first = int(np.argmax(differs)) if differs.any() else n
    rest = n - first  # the common end, at most what the start left
    tail = ho[ho.size - rest:][::-1] != hn[hn.size - rest:][::-1]
    last = int(np.argmax(tail)) if tail.any() else rest
    mo, mn = slice(first, ho.size - last), slice(first, hn.size - last)
    mid_o, mid_n = ho[mo], hn[mn]
    kept_o, kept_n = np.isin(mid_o, mid_n), np.isin(mid_n, mid_o)
    if np.array_equal(mid_o[kept_o], mid_n[kept_n]):
        changed = np.concatenate([old.boxes[mo][~kept_o], new.boxes[mn][~kept_n]])
    else:
        changed = np.concatenate([old.boxes[mo], new.boxes[mn]])
    return grid_rects(changed, size, UI_GRID_PX)


def grid_rects(boxes: np.ndarray, size: tuple[int, int], cell: int) -> list[Box]:
    """Rectangles of ``cell``-pixel grid squares covering ``boxes`` (int (n, 4): x0, y0,
    x1, y1; empty ones ignored), clipped to the window of ``size``: thousands of glyph
    quads become a few rectangles."""
    w, h = size
    b = np.asarray(boxes, np.int64).reshape(-1, 4)
    b = np.column_stack([np.clip(b[:, 0], 0, w), np.clip(b[:, 1], 0, h),
                         np.clip(b[:, 2], 0, w), np.clip(b[:, 3], 0, h)])
    b = b[(b[:, 2] > b[:, 0]) & (b[:, 3] > b[:, 1])]
    if b.size == 0:
        return []
    gw, gh = -(-w // cell), -(-h // cell)
    gx0, gy0 = b[:, 0] // cell, b[:, 1] // cell
    gx1, gy1 = -(-b[:, 2] // cell), -(-b[:, 3] // cell)
    mark = np.zeros((gh + 1, gw + 1), np.int32)  # corners: a 2-D prefix sum fills them
    np.add.at(mark, (gy0, gx0), 1)
    np.add.at(mark, (gy0, gx1), -1)
    np.add.at(mark, (gy1, gx0), -1)
    np.add.at(mark, (gy1, gx1), 1)
    grid = mark.cumsum(axis=0).cumsum(axis=1)[:gh, :gw] > 0
    rects: list[Box] = []
    for gy in np.flatnonzero(grid.any(axis=1)):
        row = np.concatenate(([False], grid[gy], [False]))
        edges = np.flatnonzero(row[1:] != row[:-1])
        for a, c in zip(edges[0::2], edges[1::2], strict=True):
            rects.append((int(a) * cell, int(gy) * cell, min(int(c) * cell, w),
                          min((int(gy) + 1) * cell, h)))
    rects = merge_rects(rects, 1)
    if len(rects) > UI_MOST_RECTS:
        return [(min(r[0] for r in rects), min(r[1] for r in rects),
                 max(r[2] for r in rects), max(r[3] for r in rects))]
    return rects


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
        self._ui_tris: UiTriangles | None = None
        self.pixels_redrawn = 0  # window pixels redrawn in the picture by the last frame
        self.full_redraws = 0
        self.full_last = True  # the last update redrew everything (a new camera)

    def invalidate(self) -> None:
        """Redraw everything next frame (a fresh canvas, a screenshot's exact picture)."""
        self._camera_key = None

    def update(self, cam: Camera, canvas_cells: list[tuple[int, int, int, int]],
               canvas_size: tuple[int, int], ui_hash: int, ui_box: Box | None,
               draw_scene: Callable[[Box], None], draw_ui: Callable[[Box], None],
               ui_tris: UiTriangles | None = None) -> list[Box]:
        """Redraw the damaged parts of the picture; returns the boxes redrawn.

        ``canvas_cells``: canvas rectangles ``(y0, y1, x0, x1)`` re-rendered since the
        last frame; ``ui_hash``/``ui_box``: the UI's drawing this frame and its extent;
        ``draw_scene(clip)`` draws the view of the canvas, ``draw_ui(clip)`` the UI, both
        only inside ``clip``; ``ui_tris``: the UI's triangles, which narrow its damage to
        where they changed (:func:`ui_damage`; without them: the old and new extents).
        """
        w, h = self.size
        key = cam.vp.astype("f4").tobytes() + repr(cam.viewport).encode()
        boxes: list[Box] = []
        self.full_last = key != self._camera_key
        if self.full_last:
            boxes = [(0, 0, w, h)]
            self.full_redraws += 1
        else:
            cw, ch = canvas_size
            canvas = canvas_boxes(cam, canvas_cells, cw, ch)
            boxes = [(0, 0, w, h)] if canvas is None else canvas
            if ui_hash != self._ui_hash:
                if ui_tris is not None and self._ui_tris is not None:
                    boxes.extend(ui_damage(self._ui_tris, ui_tris, (w, h)))
                else:
                    extent = union(self._ui_box, ui_box)
                    if extent is not None:
                        boxes.append(extent)
        self._camera_key = key
        self._ui_hash = ui_hash
        self._ui_box = ui_box
        self._ui_tris = ui_tris
        boxes = merge_rects(boxes, MERGE_GAP_PX)
        ctx = self.ctx
        self.fbo.use()
        pixels = 0
        drawn: list[Box] = []
        for x0, y0, x1, y1 in boxes:
            x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
            if x1 <= x0 or y1 <= y0:
                continue
            draw_scene((x0, y0, x1, y1))
            draw_ui((x0, y0, x1, y1))
            pixels += (x1 - x0) * (y1 - y0)
            drawn.append((x0, y0, x1, y1))
        ctx.scissor = None
        self.pixels_redrawn = pixels
        return drawn

    def present(self, rects: list[Box] | None = None) -> None:
        """Copy the picture into the window's back buffer (bound after the call): all of
        it, or only inside ``rects`` (what a partial present shows)."""
        ctx = self.ctx
        ctx.screen.use()
        w, h = self.size
        ctx.viewport = (0, 0, w, h)
        ctx.disable(ctx.BLEND)
        self.texture.use(0)
        self.prog["picture"].value = 0
        if rects is None:
            ctx.scissor = None
            self.vao.render(ctx.TRIANGLE_STRIP)
            return
        for x0, y0, x1, y1 in rects:
            x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
            if x1 > x0 and y1 > y0:
                ctx.scissor = (x0, h - y1, x1 - x0, y1 - y0)
                self.vao.render(ctx.TRIANGLE_STRIP)
        ctx.scissor = None

    def release(self) -> None:
        self.vao.release()
        self.vbo.release()
        self.prog.release()
        self.fbo.release()
        self.texture.release()


def merge_rects(rects: list[Box], gap: int = 0) -> list[Box]:
    """Rectangles closer than ``gap`` pixels (or overlapping) merged into their bounding
    box, until none are: each rectangle is a few draw calls, and overlapping ones would
    draw pixels twice."""
    out = [r for r in rects if r[2] > r[0] and r[3] > r[1]]
    merged = True
    while merged and len(out) > 1:
        merged = False
        for i in range(len(out)):
            for j in range(i + 1, len(out)):
                a, b = out[i], out[j]
                if (a[0] < b[2] + gap and b[0] < a[2] + gap and a[1] < b[3] + gap
                        and b[1] < a[3] + gap):
                    out[i] = (min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]),
                              max(a[3], b[3]))
                    del out[j]
                    merged = True
                    break
            if merged:
                break
    return out
