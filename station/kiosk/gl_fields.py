"""The GL canvas's sub-cell fields, on the GPU: what :func:`station.kiosk.subcell.fields`
computes on the CPU for the numpy and cpu backends, so the window's shader draws the
same ½-level contour of the paint for every backend.

Three compute passes over the whole canvas, in the canvas's own context, after its
render pass (the GPU renders the whole canvas every frame anyway):

1. the painted-cell indicator (:func:`subcell.painted_cells`): pigment ``p + q`` of the
   layer's pigments over :data:`subcell.PAINTED_AMOUNT`, or dried layers whose
   reflectance is off the bare paper by :data:`subcell.DRIED_DIFF` in some band;
2. the indicator blurred (the 5×5 Gaussian of :data:`subcell.EDGE_SIGMA`, zero outside
   the canvas);
3. per cell: the colour extended into blank cells that touch paint (the mean of their
   painted 3×3 neighbours) and the contour level (the blur over its 3×3 peak) — the
   RGBA texture the window's shader samples as it samples the CPU displays'.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from station.kiosk import subcell

if TYPE_CHECKING:
    import moderngl

    from station.backends.gl.canvas import GLCanvas

_HEAD = """
#version 430
layout(local_size_x = 16, local_size_y = 16) in;
uniform ivec2 u_size;
bool inside(ivec2 c) { return c.x >= 0 && c.y >= 0 && c.x < u_size.x && c.y < u_size.y; }
"""

INDICATOR = _HEAD + f"""
layout(rgba32f, binding = 0) uniform readonly image2DArray pig_in;
layout(rgba32f, binding = 1) uniform readonly image2DArray dep_in;
layout(rgba32f, binding = 2) uniform readonly image2DArray rcomp_in;
layout(r32f, binding = 3) uniform readonly image2D paper_in;
layout(r32f, binding = 4) uniform writeonly image2D ind_out;
uniform int u_used;   // pigments of the active layer
uniform int u_layers; // pigment layers of 4 slots
uniform int u_bands;  // render bands of r_composed
void main() {{
    ivec2 c = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(c)) return;
    float d = 0.0;
    for (int l = 0; l < u_layers; ++l) {{
        vec4 a = imageLoad(pig_in, ivec3(c, l)) + imageLoad(dep_in, ivec3(c, l));
        for (int k = 0; k < 4; ++k) if (4 * l + k < u_used) d += a[k];
    }}
    bool painted = d > {subcell.PAINTED_AMOUNT!r};
    float paper = imageLoad(paper_in, c).r;
    for (int b = 0; b < u_bands; ++b) {{
        float r = imageLoad(rcomp_in, ivec3(c, b / 4))[b % 4];
        if (abs(r - paper) > {subcell.DRIED_DIFF!r}) painted = true;
    }}
    imageStore(ind_out, c, vec4(painted ? 1.0 : 0.0));
}}
"""

BLUR = _HEAD + """
layout(r32f, binding = 0) uniform readonly image2D ind_in;
layout(r32f, binding = 1) uniform writeonly image2D blur_out;
uniform float u_w[5];
void main() {
    ivec2 c = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(c)) return;
    float acc = 0.0;
    for (int i = -2; i <= 2; ++i) {
        float row = 0.0;
        for (int j = -2; j <= 2; ++j) {
            ivec2 q = c + ivec2(j, i);
            if (inside(q)) row += u_w[j + 2] * imageLoad(ind_in, q).r;
        }
        acc += u_w[i + 2] * row;
    }
    imageStore(blur_out, c, vec4(acc));
}
"""

FIELDS = _HEAD + """
layout(r32f, binding = 0) uniform readonly image2D ind_in;
layout(r32f, binding = 1) uniform readonly image2D blur_in;
layout(rgba32f, binding = 2) uniform readonly image2D rgb_in;
layout(rgba32f, binding = 3) uniform writeonly image2D fields_out;
void main() {
    ivec2 c = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(c)) return;
    float peak = 0.0;
    float n = 0.0;
    vec3 sum = vec3(0.0);
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = c + ivec2(dx, dy);
            if (!inside(q)) continue;
            peak = max(peak, imageLoad(blur_in, q).r);
            if (imageLoad(ind_in, q).r > 0.5) {
                n += 1.0;
                sum += imageLoad(rgb_in, q).rgb;
            }
        }
    }
    vec3 own = imageLoad(rgb_in, c).rgb;
    bool painted = imageLoad(ind_in, c).r > 0.5;
    vec3 colour = (painted || n == 0.0) ? own : sum / n;
    float level = peak > 0.0 ? imageLoad(blur_in, c).r / max(peak, 1e-6) : 0.0;
    imageStore(fields_out, c, vec4(colour, level));
}
"""


class GlFields:
    """The passes and their textures for a ``width`` × ``height`` GL canvas."""

    def __init__(self, ctx: moderngl.Context, width: int, height: int) -> None:
        self.ctx = ctx
        self.size = (width, height)
        self.indicator = ctx.compute_shader(INDICATOR)
        self.blur = ctx.compute_shader(BLUR)
        self.fields = ctx.compute_shader(FIELDS)
        for prog in (self.indicator, self.blur, self.fields):
            prog["u_size"].value = (width, height)
        self.blur["u_w"].value = [float(v) for v in subcell.EDGE_WEIGHTS]
        self.ind = ctx.texture((width, height), 1, dtype="f4")
        self.blurred = ctx.texture((width, height), 1, dtype="f4")
        #: rgb: linear reflectance extended into blank cells by the paint; a: the contour
        #: level (what the window's shader samples)
        self.texture = ctx.texture((width, height), 4, dtype="f4")
        self.texture.filter = (ctx.LINEAR, ctx.LINEAR)
        self.texture.repeat_x = self.texture.repeat_y = False
        self._groups = (-(-width // 16), -(-height // 16), 1)

    def _barrier(self) -> None:
        self.ctx.memory_barrier(self.ctx.SHADER_IMAGE_ACCESS_BARRIER_BIT)

    def run(self, canvas: GLCanvas, rgb: moderngl.Texture,
            paper: moderngl.Texture) -> moderngl.Texture:
        """The fields of the GL ``canvas`` (its state textures), whose render pass wrote
        ``rgb``, over the bare ``paper`` (an R32F texture of the cells' reflectance);
        returns :attr:`texture`."""
        f = canvas.f
        ind = self.indicator
        ind["u_used"].value = len(canvas.slots)
        ind["u_layers"].value = int(canvas.npl)
        ind["u_bands"].value = int(canvas.bands)
        f["pig"].src.bind_to_image(0, read=True, write=False)
        f["dep"].src.bind_to_image(1, read=True, write=False)
        f["rcomp"].src.bind_to_image(2, read=True, write=False)
        paper.bind_to_image(3, read=True, write=False)
        self.ind.bind_to_image(4, read=False, write=True)
        ind.run(*self._groups)
        self._barrier()
        self.ind.bind_to_image(0, read=True, write=False)
        self.blurred.bind_to_image(1, read=False, write=True)
        self.blur.run(*self._groups)
        self._barrier()
        self.ind.bind_to_image(0, read=True, write=False)
        self.blurred.bind_to_image(1, read=True, write=False)
        rgb.bind_to_image(2, read=True, write=False)
        self.texture.bind_to_image(3, read=False, write=True)
        self.fields.run(*self._groups)
        return self.texture

    def read(self) -> np.ndarray:
        """The fields (float32 (H, W, 4)), row 0 = the canvas's top row."""
        w, h = self.size
        self.ctx.memory_barrier()
        return np.frombuffer(self.texture.read(), np.float32).reshape(h, w, 4).copy()

    def release(self) -> None:
        for t in (self.ind, self.blurred, self.texture, self.indicator, self.blur,
                  self.fields):
            t.release()
