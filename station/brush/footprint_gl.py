"""The footprint drawn with OpenGL (dissertation §7.4.2: a render pass from below).

The same bristle tubes as :func:`station.brush.footprint.rasterise`, drawn as
instanced quads into a float RG target with the MAX blend equation: red is
the cover, green the depth below the plane.  With ``tags`` a second pass
(``brush_footprint_tag.frag``) draws the same quads into a float R target: a
tube writes its segment number where its depth equals the cell's deepest from
the first pass, and the MIN blend equation keeps the first of equals, the
reference's tie rule; the numbers are mapped to the tags on the CPU.  The
shaders live in ``shaders/brush_footprint.{vert,frag}``,
``brush_footprint_tag.frag`` and the shared ``brush_tube.glsl``.  Where a
context exists (EGL with llvmpipe here, the vendor driver on a GPU) this is
the interactive path; the tests hold it to the numba rasteriser.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from station.brush.footprint import CLIP_ABOVE, NO_DEPTH, FootprintMaps, window
from station.glkit.context import create_context
from station.glkit.shaderlib import compile_program

if TYPE_CHECKING:
    import moderngl

_CORNERS = np.array([0, 0, 1, 0, 0, 1, 1, 1], np.float32)


class GLFootprint:
    """A moderngl renderer of footprints (owns its context unless given one)."""

    def __init__(self, ctx: moderngl.Context | None = None) -> None:
        import moderngl

        self._own = ctx is None
        self.ctx = ctx if ctx is not None else create_context()
        self.prog: Any = compile_program(self.ctx, "brush_footprint.vert",
                                         "brush_footprint.frag",
                                         {"CLIP_ABOVE": f"{CLIP_ABOVE:.6f}"})
        # the tag pass is a program of its own (one program per pass); a depth
        # buffer would quantise the depths (ties the reference separates) and its
        # test would also drop the cover of shallower tubes, hence the comparison
        # with the first pass's float depth and a MIN blend over segment numbers
        self.tag_prog: Any = compile_program(self.ctx, "brush_footprint.vert",
                                             "brush_footprint_tag.frag",
                                             {"CLIP_ABOVE": f"{CLIP_ABOVE:.6f}"})
        self._corners = self.ctx.buffer(_CORNERS.tobytes())
        self._max = moderngl.MAX
        self._min = moderngl.MIN
        self._fbo: moderngl.Framebuffer | None = None
        self._tag_fbo: moderngl.Framebuffer | None = None
        self._size = (0, 0)

    def _release_targets(self) -> None:
        for fbo in (self._fbo, self._tag_fbo):
            if fbo is not None:
                fbo.color_attachments[0].release()
                fbo.release()
        self._fbo = self._tag_fbo = None

    def _target(self, w: int, h: int) -> Any:
        if self._size != (w, h):
            self._release_targets()
            tex = self.ctx.texture((w, h), 2, dtype="f4")
            self._fbo = self.ctx.framebuffer(color_attachments=[tex])
            self._size = (w, h)
        return self._fbo

    def _tag_target(self, w: int, h: int) -> Any:
        if self._tag_fbo is None:
            tex = self.ctx.texture((w, h), 1, dtype="f4")
            self._tag_fbo = self.ctx.framebuffer(color_attachments=[tex])
        return self._tag_fbo

    def rasterise(self, segs: np.ndarray, radius: float,
                  win: tuple[int, int, int, int] | None = None,
                  tags: np.ndarray | None = None) -> FootprintMaps:
        """Cover and depth maps, as :func:`station.brush.footprint.rasterise`; with
        ``tags`` (one value per segment) also the tag of the lowest segment per cell."""
        import moderngl

        segs = np.ascontiguousarray(segs, np.float32).reshape(-1, 2, 3)
        t_in = None if tags is None else np.asarray(tags, np.float64).reshape(-1)
        if t_in is not None and t_in.shape[0] != segs.shape[0]:
            raise ValueError(f"{t_in.shape[0]} tags for {segs.shape[0]} segments")
        y0, x0, h, w = win if win is not None else window(segs.astype(np.float64), radius)
        if h <= 0 or w <= 0 or segs.shape[0] == 0:
            shape = (max(h, 0), max(w, 0))
            return FootprintMaps(y0, x0, np.zeros(shape, np.float32),
                                 np.full(shape, NO_DEPTH, np.float32),
                                 None if t_in is None else np.full(shape, np.nan, np.float32))
        fbo = self._target(w, h)
        inst = self.ctx.buffer(segs.reshape(-1, 6).tobytes())
        progs = [self.prog] if t_in is None else [self.prog, self.tag_prog]
        vaos = [self.ctx.vertex_array(p, [(self._corners, "2f", "corner"),
                                          (inst, "3f 3f/i", "seg_a", "seg_b")]) for p in progs]
        for p in progs:
            p["origin"].value = (float(x0), float(y0))
            p["size"].value = (float(w), float(h))
            p["radius"].value = float(radius)
        fbo.use()
        fbo.viewport = (0, 0, w, h)
        fbo.clear(0.0, NO_DEPTH, 0.0, 0.0)
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.ONE, moderngl.ONE
        self.ctx.blend_equation = self._max
        vaos[0].render(moderngl.TRIANGLE_STRIP, instances=segs.shape[0])
        tag = None
        if t_in is not None:
            n = segs.shape[0]
            tag_fbo = self._tag_target(w, h)
            tag_fbo.use()
            tag_fbo.viewport = (0, 0, w, h)
            tag_fbo.clear(float(n))  # no segment: a number past the last
            self.ctx.blend_equation = self._min
            fbo.color_attachments[0].use(location=0)
            self.tag_prog["deepest"].value = 0
            vaos[1].render(moderngl.TRIANGLE_STRIP, instances=n)
            idx = np.frombuffer(tag_fbo.read(components=1, dtype="f4"),
                                np.float32).reshape(h, w).astype(np.int64)
            lut = np.append(t_in, np.nan).astype(np.float32)
            tag = lut[np.clip(idx, 0, n)]
        self.ctx.disable(moderngl.BLEND)
        data = np.frombuffer(fbo.read(components=2, dtype="f4"), np.float32).reshape(h, w, 2)
        for v in vaos:
            v.release()
        inst.release()
        return FootprintMaps(y0, x0, np.ascontiguousarray(data[..., 0]),
                             np.ascontiguousarray(data[..., 1]), tag)

    def close(self) -> None:
        self._release_targets()
        if self._own:
            self.ctx.release()
