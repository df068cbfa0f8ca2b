"""Dear ImGui (imgui-bundle) drawn with moderngl, fed by the pen, not a mouse.

imgui-bundle's own Python backends draw with PyOpenGL; the kiosk's GL state is
moderngl's, so this module renders ImGui's draw lists through moderngl (one
program, one streaming vertex/index buffer, scissor per command) and manages
ImGui's textures (the font atlas, 1.92's ``RendererHasTextures`` protocol).

Input: :meth:`ImGuiLayer.pointer` takes the pen's window position and whether
its tip touches; nothing else (no keyboard, no mouse) reaches ImGui.
"""

from __future__ import annotations

import ctypes
import math
import zlib
from dataclasses import dataclass
from typing import TYPE_CHECKING, cast

import numpy as np
from imgui_bundle import imgui

if TYPE_CHECKING:  # moderngl is imported by whoever makes the context
    import moderngl

VERTEX = """
#version 330
uniform mat4 proj;
in vec2 pos;
in vec2 uv;
in vec4 col;
out vec2 f_uv;
out vec4 f_col;
void main() { f_uv = uv; f_col = col; gl_Position = proj * vec4(pos, 0.0, 1.0); }
"""

FRAGMENT = """
#version 330
uniform sampler2D tex;
in vec2 f_uv;
in vec4 f_col;
out vec4 frag;
void main() { frag = f_col * texture(tex, f_uv); }
"""


#: Odd 64-bit constants weighting a triangle's words in its hash (:meth:`ImGuiLayer.triangles`;
#: fixed, so hashes compare across frames).
_HASH_WEIGHTS = (np.random.default_rng(0x1A6E).integers(0, 2**63, 32, dtype=np.uint64)
                 * np.uint64(2) + np.uint64(1))


@dataclass(frozen=True)
class UiTriangles:
    """A UI frame's triangles in drawing order: ``hashes`` (uint64, one a triangle: its
    vertices — position, texture coordinate, colour —, clip rectangle and texture) and
    ``boxes`` (int32 (n, 4): window pixels x0, y0, x1, y1 it can touch; empty where
    clipped away)."""

    hashes: np.ndarray
    boxes: np.ndarray


class ImGuiLayer:
    """An ImGui context drawn into a moderngl context of ``size`` pixels."""

    def __init__(self, ctx: moderngl.Context, size: tuple[int, int], scale: float = 2.0) -> None:
        self.ctx = ctx
        self.size = size
        self.context = imgui.create_context()
        io = imgui.get_io()
        io.display_size = imgui.ImVec2(float(size[0]), float(size[1]))
        io.set_ini_filename("")  # a kiosk keeps no layout file
        io.backend_flags |= imgui.BackendFlags_.renderer_has_textures
        io.config_flags |= imgui.ConfigFlags_.no_mouse_cursor_change
        style = imgui.get_style()
        style.scale_all_sizes(scale)
        style.font_scale_main = scale
        self.prog = ctx.program(vertex_shader=VERTEX, fragment_shader=FRAGMENT)
        cast("moderngl.Uniform", self.prog["tex"]).value = 0  # a sampler: a uniform
        self.vbo = ctx.buffer(reserve=1 << 20, dynamic=True)
        self.ibo = ctx.buffer(reserve=1 << 19, dynamic=True)
        self.vao = ctx.vertex_array(self.prog, [(self.vbo, "2f 2f 4f1", "pos", "uv", "col")],
                                    index_buffer=self.ibo, index_element_size=imgui.INDEX_SIZE)
        self.textures: dict[int, moderngl.Texture] = {}
        self._next_id = 1
        self.touching = False

    def resize(self, size: tuple[int, int]) -> None:
        """The window is now ``size`` pixels (the panel is laid out for it next frame)."""
        self.size = size
        imgui.get_io().display_size = imgui.ImVec2(float(size[0]), float(size[1]))

    # -- textures --------------------------------------------------------------
    def add_texture(self, texture: moderngl.Texture) -> int:
        """Register a moderngl texture for ``imgui.image``; returns its ImGui id."""
        tex_id = self._next_id
        self._next_id += 1
        self.textures[tex_id] = texture
        return tex_id

    def _sync_textures(self) -> None:
        for tex in imgui.get_platform_io().textures:
            status = tex.status
            if status in (imgui.ImTextureStatus.want_create, imgui.ImTextureStatus.want_updates):
                pixels = np.asarray(tex.get_pixels_array(), np.uint8).tobytes()
                if status == imgui.ImTextureStatus.want_create or tex.tex_id not in self.textures:
                    gl_tex = self.ctx.texture((tex.width, tex.height), 4, pixels)
                    gl_tex.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
                    tex.set_tex_id(self.add_texture(gl_tex))
                else:
                    self.textures[tex.tex_id].write(pixels)
                tex.set_status(imgui.ImTextureStatus.ok)
            elif status == imgui.ImTextureStatus.want_destroy:
                old = self.textures.get(tex.tex_id)
                if old is not None:
                    del self.textures[tex.tex_id]
                    old.release()
                tex.set_tex_id(0)
                tex.set_status(imgui.ImTextureStatus.destroyed)

    # -- input ---------------------------------------------------------------------
    def pointer(self, x: float | None, y: float | None, touching: bool) -> None:
        """The pen: window pixel position (``None`` out of proximity) and tip state."""
        imgui.set_current_context(self.context)
        io = imgui.get_io()
        io.add_mouse_source_event(imgui.MouseSource.pen)
        if x is None or y is None:
            io.add_mouse_pos_event(-imgui.FLT_MAX, -imgui.FLT_MAX)
        else:
            io.add_mouse_pos_event(float(x), float(y))
        if touching != self.touching:
            io.add_mouse_button_event(0, touching)
            self.touching = touching

    def want_pointer(self) -> bool:
        """Whether the pen is over an ImGui window (the canvas must not paint)."""
        imgui.set_current_context(self.context)
        return bool(imgui.get_io().want_capture_mouse)

    # -- frames --------------------------------------------------------------------
    def new_frame(self, dt: float) -> None:
        imgui.set_current_context(self.context)
        imgui.get_io().delta_time = max(dt, 1e-4)
        imgui.new_frame()

    def render(self) -> None:
        """End the ImGui frame and draw it over what is in the framebuffer."""
        self.end_frame()
        self.draw()

    def end_frame(self) -> int:
        """End the ImGui frame (textures synchronised); returns a hash of what it draws,
        so a caller can tell whether the UI looks different from the last frame."""
        imgui.render()
        self._sync_textures()
        data = imgui.get_draw_data()
        h = 0
        for cmds in data.cmd_lists:
            vbytes = cmds.vtx_buffer.size() * imgui.VERTEX_SIZE
            ibytes = cmds.idx_buffer.size() * imgui.INDEX_SIZE
            h = zlib.crc32(ctypes.string_at(cmds.vtx_buffer.data_address(), vbytes), h)
            h = zlib.crc32(ctypes.string_at(cmds.idx_buffer.data_address(), ibytes), h)
            for cmd in cmds.cmd_buffer:
                r = cmd.clip_rect
                h = zlib.crc32(repr((r.x, r.y, r.z, r.w, cmd.tex_ref.get_tex_id(),
                                     cmd.elem_count, cmd.idx_offset)).encode(), h)
        return h

    def bounds(self) -> tuple[int, int, int, int] | None:
        """Window pixels (x0, y0, x1, y1) that the last ended frame draws on, or ``None``:
        per draw list, its vertices' extent within its clip rectangles (a clip rectangle
        alone can be the whole display, as for a banner's full-screen host window)."""
        box = None
        for cmds in imgui.get_draw_data().cmd_lists:
            n = cmds.vtx_buffer.size()
            if n == 0 or cmds.cmd_buffer.size() == 0:
                continue
            raw = ctypes.string_at(cmds.vtx_buffer.data_address(), n * imgui.VERTEX_SIZE)
            pos = np.frombuffer(raw, np.float32).reshape(n, -1)[:, :2]
            lo, hi = pos.min(axis=0), pos.max(axis=0)
            clip = None
            for cmd in cmds.cmd_buffer:
                r = cmd.clip_rect
                c = (r.x, r.y, r.z, r.w)
                clip = c if clip is None else (min(clip[0], c[0]), min(clip[1], c[1]),
                                               max(clip[2], c[2]), max(clip[3], c[3]))
            if clip is None:
                continue
            b = (int(max(lo[0], clip[0])) - 1, int(max(lo[1], clip[1])) - 1,
                 int(math.ceil(min(hi[0], clip[2]))) + 1, int(math.ceil(min(hi[1], clip[3]))) + 1)
            if b[2] <= b[0] or b[3] <= b[1]:
                continue
            box = b if box is None else (min(box[0], b[0]), min(box[1], b[1]),
                                         max(box[2], b[2]), max(box[3], b[3]))
        return box

    def triangles(self) -> UiTriangles:
        """The last ended frame's triangles in drawing order (:class:`UiTriangles`): what a
        compositor compares with the last frame it drew to find where the UI changed."""
        hashes: list[np.ndarray] = []
        boxes: list[np.ndarray] = []
        words = imgui.VERTEX_SIZE // 4
        itype = np.uint32 if imgui.INDEX_SIZE == 4 else np.uint16
        for cmds in imgui.get_draw_data().cmd_lists:
            n, m = cmds.vtx_buffer.size(), cmds.idx_buffer.size()
            if n == 0 or m == 0:
                continue
            vtx = np.frombuffer(ctypes.string_at(cmds.vtx_buffer.data_address(),
                                                 n * imgui.VERTEX_SIZE), np.uint32
                                ).reshape(n, words)
            idx = np.frombuffer(ctypes.string_at(cmds.idx_buffer.data_address(),
                                                 m * imgui.INDEX_SIZE), itype)
            for cmd in cmds.cmd_buffer:
                count = cmd.elem_count - cmd.elem_count % 3
                if count == 0:
                    continue
                tri = idx[cmd.idx_offset:cmd.idx_offset + count].astype(np.int64) + cmd.vtx_offset
                v = vtx[np.minimum(tri, n - 1)].reshape(-1, 3 * words)
                r = cmd.clip_rect
                key = zlib.crc32(repr((r.x, r.y, r.z, r.w, cmd.tex_ref.get_tex_id())).encode())
                # the three vertices' words and the command's key, weighted by odd 64-bit
                # constants and summed (wrapping): two different triangles agree by chance
                # about once in 2**60
                h = (v.astype(np.uint64) * _HASH_WEIGHTS[:3 * words]).sum(axis=1, dtype=np.uint64)
                hashes.append(h + np.array([key], np.uint64) * _HASH_WEIGHTS[-1:])
                pos = v.view(np.float32).reshape(-1, 3, words)[:, :, :2]
                lo, hi = pos.min(axis=1), pos.max(axis=1)
                # its pixels: the vertices' extent within the clip rectangle, one pixel more
                # each way for rounding
                boxes.append(np.stack([
                    np.floor(np.maximum(lo[:, 0], r.x)) - 1,
                    np.floor(np.maximum(lo[:, 1], r.y)) - 1,
                    np.ceil(np.minimum(hi[:, 0], r.z)) + 1,
                    np.ceil(np.minimum(hi[:, 1], r.w)) + 1], axis=1).astype(np.int32))
        if not hashes:
            return UiTriangles(np.zeros(0, np.uint64), np.zeros((0, 4), np.int32))
        return UiTriangles(np.concatenate(hashes), np.concatenate(boxes))

    def draw(self, clip: tuple[int, int, int, int] | None = None) -> None:
        """Draw the last ended frame over what is in the framebuffer; ``clip``: only
        inside these window pixels (x0, y0, x1, y1), as the compositor redraws a
        damaged rectangle."""
        data = imgui.get_draw_data()
        w, h = self.size
        ctx = self.ctx
        ctx.viewport = (0, 0, w, h)
        ctx.enable_only(ctx.BLEND)
        ctx.blend_func = ctx.SRC_ALPHA, ctx.ONE_MINUS_SRC_ALPHA
        cast("moderngl.Uniform", self.prog["proj"]).write(np.array(
            [[2.0 / w, 0, 0, 0], [0, -2.0 / h, 0, 0], [0, 0, -1, 0], [-1, 1, 0, 1]],
            "f4").tobytes())
        for cmds in data.cmd_lists:
            vbytes = cmds.vtx_buffer.size() * imgui.VERTEX_SIZE
            ibytes = cmds.idx_buffer.size() * imgui.INDEX_SIZE
            if vbytes > self.vbo.size:
                self.vbo.orphan(vbytes * 2)
            if ibytes > self.ibo.size:
                self.ibo.orphan(ibytes * 2)
            self.vbo.write(ctypes.string_at(cmds.vtx_buffer.data_address(), vbytes))
            self.ibo.write(ctypes.string_at(cmds.idx_buffer.data_address(), ibytes))
            for cmd in cmds.cmd_buffer:
                tex = self.textures.get(cmd.tex_ref.get_tex_id())
                if tex is None:
                    continue
                x0, y0, x1, y1 = cmd.clip_rect
                if clip is not None:
                    x0, y0 = max(x0, clip[0]), max(y0, clip[1])
                    x1, y1 = min(x1, clip[2]), min(y1, clip[3])
                    if x1 <= x0 or y1 <= y0:
                        continue
                tex.use(0)
                ctx.scissor = (int(x0), int(h - y1), int(x1 - x0), int(y1 - y0))
                self.vao.render(ctx.TRIANGLES, vertices=cmd.elem_count, first=cmd.idx_offset)
        ctx.scissor = None
        ctx.disable(ctx.BLEND)

    def close(self) -> None:
        for tex in self.textures.values():
            tex.release()
        self.textures.clear()
        imgui.destroy_context(self.context)
