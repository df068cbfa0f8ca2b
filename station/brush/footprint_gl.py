"""The footprint drawn with OpenGL (dissertation §7.4.2: a render pass from below).

The same bristle tubes as :func:`station.brush.footprint.rasterise`, drawn as
instanced quads into a float RG target with the MAX blend equation: red is
the cover, green the depth below the plane.  The vertex and fragment shaders
live in ``shaders/brush_footprint.{vert,frag}``.  Where a context exists (EGL
with llvmpipe here, the vendor driver on a GPU) this is the interactive
path; the tests hold it to the numba rasteriser.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from station.brush.footprint import CLIP_ABOVE, NO_DEPTH, FootprintMaps, window
from station.canvas.gl.context import create_context
from station.canvas.gl.shaderlib import compile_program

_CORNERS = np.array([0, 0, 1, 0, 0, 1, 1, 1], np.float32)


class GLFootprint:
    """A moderngl renderer of footprints (owns its context unless given one)."""

    def __init__(self, ctx: Any = None) -> None:
        import moderngl

        self._own = ctx is None
        self.ctx = ctx if ctx is not None else create_context()
        self.prog: Any = compile_program(self.ctx, "brush_footprint.vert",
                                         "brush_footprint.frag",
                                         {"CLIP_ABOVE": f"{CLIP_ABOVE:.6f}"})
        self._corners = self.ctx.buffer(_CORNERS.tobytes())
        self._max = moderngl.MAX
        self._fbo: Any = None
        self._size = (0, 0)

    def _target(self, w: int, h: int) -> Any:
        if self._size != (w, h):
            if self._fbo is not None:
                self._fbo.color_attachments[0].release()
                self._fbo.release()
            tex = self.ctx.texture((w, h), 2, dtype="f4")
            self._fbo = self.ctx.framebuffer(color_attachments=[tex])
            self._size = (w, h)
        return self._fbo

    def rasterise(self, segs: np.ndarray, radius: float,
                  win: tuple[int, int, int, int] | None = None) -> FootprintMaps:
        """Cover and depth maps, as :func:`station.brush.footprint.rasterise`."""
        import moderngl

        segs = np.ascontiguousarray(segs, np.float32).reshape(-1, 2, 3)
        y0, x0, h, w = win if win is not None else window(segs.astype(np.float64), radius)
        if h <= 0 or w <= 0 or segs.shape[0] == 0:
            return FootprintMaps(y0, x0, np.zeros((max(h, 0), max(w, 0)), np.float32),
                                 np.full((max(h, 0), max(w, 0)), NO_DEPTH, np.float32))
        fbo = self._target(w, h)
        inst = self.ctx.buffer(segs.reshape(-1, 6).tobytes())
        vao = self.ctx.vertex_array(self.prog, [(self._corners, "2f", "corner"),
                                                (inst, "3f 3f/i", "seg_a", "seg_b")])
        self.prog["origin"].value = (float(x0), float(y0))
        self.prog["size"].value = (float(w), float(h))
        self.prog["radius"].value = float(radius)
        fbo.use()
        fbo.viewport = (0, 0, w, h)
        fbo.clear(0.0, NO_DEPTH, 0.0, 0.0)
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.ONE, moderngl.ONE
        self.ctx.blend_equation = self._max
        vao.render(moderngl.TRIANGLE_STRIP, instances=segs.shape[0])
        self.ctx.disable(moderngl.BLEND)
        data = np.frombuffer(fbo.read(components=2, dtype="f4"), np.float32).reshape(h, w, 2)
        vao.release()
        inst.release()
        return FootprintMaps(y0, x0, np.ascontiguousarray(data[..., 0]),
                             np.ascontiguousarray(data[..., 1]))

    def close(self) -> None:
        if self._fbo is not None:
            self._fbo.color_attachments[0].release()
            self._fbo.release()
            self._fbo = None
        if self._own:
            self.ctx.release()
