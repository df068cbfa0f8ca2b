"""The GL canvas's sub-cell fields, on the GPU: what :func:`station.kiosk.subcell.fields`
computes on the CPU for the numpy and cpu backends, so the window's shader draws the
same ½-level contour of the paint for every backend.

Compute passes over the whole canvas, in the canvas's own context, after its
render pass (the GPU renders the whole canvas every frame anyway):

1. the painted-cell indicator (:func:`subcell.painted_cells`): pigment ``p + q`` of the
   layer's pigments over :data:`subcell.PAINTED_AMOUNT`, or dried layers whose
   reflectance is off the bare paper by :data:`subcell.DRIED_DIFF` in some band;
2. the indicator blurred (the 5×5 Gaussian of :data:`subcell.EDGE_SIGMA`, zero outside
   the canvas);
3. per cell: the colour extended into blank cells that touch paint (the mean of their
   painted 3×3 neighbours) and the contour level (the blur over its 3×3 peak) — the
   RGBA texture the window's shader samples as it samples the CPU displays';
4. the hard steps inside the paint (:func:`subcell.step_fields`): the cells' density,
   the steps' high sides with their mid-levels, the side indicator, its blur (pass 2's
   program), and the high side's colour into that texture with the low side's colour and
   the steps' contour level into :attr:`GlFields.steps`.
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


# Hard steps inside the paint (:func:`subcell.step_fields`, its numba kernel the spec):
# four more passes after the fields pass.
DENSITY = _HEAD + """
layout(rgba32f, binding = 0) uniform readonly image2D rgb_in;
layout(r32f, binding = 1) uniform readonly image2D paper_in;
layout(r32f, binding = 2) uniform writeonly image2D s_out;
void main() {
    ivec2 c = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(c)) return;
    vec3 rgb = imageLoad(rgb_in, c).rgb;
    float m = (rgb.r + rgb.g + rgb.b) / 3.0;
    imageStore(s_out, c, vec4(-log(max(m, 1e-4) / max(imageLoad(paper_in, c).r, 1e-4))));
}
"""

_ACROSS = """
uniform vec4 u_consts;  // least, ratio, share, isolation (upscale.hard_pairs)
ivec2 cl(ivec2 q) { return clamp(q, ivec2(0), u_size - 1); }
float sv(ivec2 q) { return imageLoad(s_in, cl(q)).r; }
bool painted(ivec2 q) { return imageLoad(ind_in, q).r > 0.5; }
// q and its neighbours on the canvas all painted (the low side of a step)
bool inside_paint(ivec2 q) {
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 r = q + ivec2(dx, dy);
            if (inside(r) && !painted(r)) return false;
        }
    return true;
}
// from a up to its neighbour g a hard step (before: the cell before a, after: the one
// after g; known: both painted)
bool across(float a, float g, float before, float after, bool known) {
    float rise = g - a;
    float ramp = max(max(a - before, after - g), 0.0);
    return rise > u_consts.x && (a < u_consts.y * g
                                 || (known && rise > u_consts.z * g && rise * u_consts.w > ramp));
}
"""

TOPS = _HEAD + """
layout(r32f, binding = 0) uniform readonly image2D s_in;
layout(r32f, binding = 1) uniform readonly image2D ind_in;
layout(r32f, binding = 2) uniform writeonly image2D mid_out;
""" + _ACROSS + """
void main() {
    ivec2 c = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(c)) return;
    float mid = 3.0e38;  // no step here
    if (painted(c)) {
        float a = sv(c);
        float n = 0.0;
        float acc = 0.0;
        for (int dy = -1; dy <= 1; ++dy) {
            for (int dx = -1; dx <= 1; ++dx) {
                ivec2 d = ivec2(dx, dy);
                ivec2 q = c + d;
                if ((dx == 0 && dy == 0) || !inside(q) || !painted(q)) continue;
                bool known = painted(cl(c - d)) && painted(cl(c + 2 * d));
                if (inside_paint(q) && across(sv(q), a, sv(c + 2 * d), sv(c - d), known)) {
                    n += 1.0;
                    acc += sv(q);
                }
            }
        }
        if (n > 0.0) mid = 0.5 * (a + acc / n);
    }
    imageStore(mid_out, c, vec4(mid));
}
"""

SIDE = _HEAD + """
layout(r32f, binding = 0) uniform readonly image2D s_in;
layout(r32f, binding = 1) uniform readonly image2D mid_in;
layout(r32f, binding = 2) uniform writeonly image2D high_out;
uniform int u_reach;
void main() {
    ivec2 c = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(c)) return;
    float level = 3.0e38;
    for (int r = 0; r <= u_reach; ++r) {
        for (int dy = -r; dy <= r; ++dy) {
            for (int dx = -r; dx <= r; ++dx) {
                ivec2 q = c + ivec2(dx, dy);
                if (inside(q)) level = min(level, imageLoad(mid_in, q).r);
            }
        }
        if (level < 1.0e38) break;
    }
    imageStore(high_out, c, vec4(imageLoad(s_in, c).r >= level ? 1.0 : 0.0));
}
"""

STEPS = _HEAD + """
layout(r32f, binding = 0) uniform readonly image2D s_in;
layout(r32f, binding = 1) uniform readonly image2D ind_in;
layout(r32f, binding = 2) uniform readonly image2D high_in;
layout(r32f, binding = 3) uniform readonly image2D blur_in;
layout(rgba32f, binding = 4) uniform readonly image2D rgb_in;
layout(rgba32f, binding = 5) uniform image2D fields_io;
layout(rgba32f, binding = 6) uniform writeonly image2D steps_out;
""" + _ACROSS + """
void main() {
    ivec2 c = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(c)) return;
    float peak = 0.0;
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = c + ivec2(dx, dy);
            if (inside(q)) peak = max(peak, imageLoad(blur_in, q).r);
        }
    float level = peak > 0.0 ? imageLoad(blur_in, c).r / max(peak, 1e-6) : 0.0;
    vec4 own = imageLoad(fields_io, c);
    vec3 hi = own.rgb;
    vec3 lo = own.rgb;
    if (painted(c)) {
        bool is_high = imageLoad(high_in, c).r > 0.5;
        float a = sv(c);
        float vals[8];
        vec3 cols[8];
        int n = 0;
        for (int dy = -1; dy <= 1; ++dy) {
            for (int dx = -1; dx <= 1; ++dx) {
                ivec2 d = ivec2(dx, dy);
                ivec2 q = c + d;
                if ((dx == 0 && dy == 0) || !inside(q) || !painted(q)) continue;
                float g = sv(q);
                bool known = painted(cl(c - d)) && painted(cl(c + 2 * d));
                bool ok = is_high
                    ? inside_paint(q) && across(g, a, sv(c + 2 * d), sv(c - d), known)
                    : inside_paint(c) && across(a, g, sv(c - d), sv(c + 2 * d), known);
                if (ok) {
                    vals[n] = g;
                    cols[n] = imageLoad(rgb_in, q).rgb;
                    n += 1;
                }
            }
        }
        if (n > 0) {
            float vmin = vals[0];
            float vmax = vals[0];
            for (int i = 1; i < n; ++i) { vmin = min(vmin, vals[i]); vmax = max(vmax, vals[i]); }
            float cut = 0.5 * (vmin + vmax);
            vec3 acc = vec3(0.0);
            float m = 0.0;
            for (int i = 0; i < n; ++i) {
                if (is_high ? vals[i] >= cut : vals[i] <= cut) { acc += cols[i]; m += 1.0; }
            }
            if (is_high) lo = acc / m; else hi = acc / m;
        }
    }
    imageStore(fields_io, c, vec4(hi, own.a));
    imageStore(steps_out, c, vec4(lo, level));
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
        # hard steps inside the paint (subcell.step_fields)
        self.density = ctx.compute_shader(DENSITY)
        self.tops = ctx.compute_shader(TOPS)
        self.side = ctx.compute_shader(SIDE)
        self.steps_prog = ctx.compute_shader(STEPS)
        consts = [float(v) for v in subcell._STEP_CONSTS]
        for prog in (self.density, self.tops, self.side, self.steps_prog):
            prog["u_size"].value = (width, height)
        self.tops["u_consts"].value = consts
        self.steps_prog["u_consts"].value = consts
        self.side["u_reach"].value = subcell.STEP_SIDE_REACH
        self.s = ctx.texture((width, height), 1, dtype="f4")
        self.mid = ctx.texture((width, height), 1, dtype="f4")
        self.high = ctx.texture((width, height), 1, dtype="f4")
        self.high_blur = ctx.texture((width, height), 1, dtype="f4")
        #: rgb: the low side's colour of hard steps inside the paint (:attr:`texture`'s
        #: rgb holds the high side's); a: their contour level (the window's ``steps``)
        self.steps = ctx.texture((width, height), 4, dtype="f4")
        self.steps.filter = (ctx.LINEAR, ctx.LINEAR)
        self.steps.repeat_x = self.steps.repeat_y = False

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
        self._steps(rgb, paper)
        return self.texture

    def _steps(self, rgb: moderngl.Texture, paper: moderngl.Texture) -> None:
        """The hard steps' passes: density, the steps' high sides and mid-levels, the side
        indicator, its blur, and the two sides' colours with the contour level."""
        g = self._groups
        rgb.bind_to_image(0, read=True, write=False)
        paper.bind_to_image(1, read=True, write=False)
        self.s.bind_to_image(2, read=False, write=True)
        self.density.run(*g)
        self._barrier()
        self.s.bind_to_image(0, read=True, write=False)
        self.ind.bind_to_image(1, read=True, write=False)
        self.mid.bind_to_image(2, read=False, write=True)
        self.tops.run(*g)
        self._barrier()
        self.s.bind_to_image(0, read=True, write=False)
        self.mid.bind_to_image(1, read=True, write=False)
        self.high.bind_to_image(2, read=False, write=True)
        self.side.run(*g)
        self._barrier()
        self.high.bind_to_image(0, read=True, write=False)
        self.high_blur.bind_to_image(1, read=False, write=True)
        self.blur.run(*g)
        self._barrier()
        self.s.bind_to_image(0, read=True, write=False)
        self.ind.bind_to_image(1, read=True, write=False)
        self.high.bind_to_image(2, read=True, write=False)
        self.high_blur.bind_to_image(3, read=True, write=False)
        rgb.bind_to_image(4, read=True, write=False)
        self.texture.bind_to_image(5, read=True, write=True)
        self.steps.bind_to_image(6, read=False, write=True)
        self.steps_prog.run(*g)

    def read_steps(self) -> np.ndarray:
        """The steps' texture (float32 (H, W, 4)), row 0 = the canvas's top row."""
        w, h = self.size
        self.ctx.memory_barrier()
        return np.frombuffer(self.steps.read(), np.float32).reshape(h, w, 4).copy()

    def read(self) -> np.ndarray:
        """The fields (float32 (H, W, 4)), row 0 = the canvas's top row."""
        w, h = self.size
        self.ctx.memory_barrier()
        return np.frombuffer(self.texture.read(), np.float32).reshape(h, w, 4).copy()

    def release(self) -> None:
        for t in (self.ind, self.blurred, self.texture, self.indicator, self.blur,
                  self.fields, self.density, self.tops, self.side, self.steps_prog, self.s,
                  self.mid, self.high, self.high_blur, self.steps):
            t.release()
