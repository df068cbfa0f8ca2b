#version 430
// pressure.comp: once per step, after prep and blur_x.  Reference: flow_pressure (pass 3's
// levelled height): P = (w + relief h) - eta (1 - M') on wet cells, w elsewhere (the free
// surface over the paper's relief; Curtis 1997's flow outward; terms with a 0 parameter left
// out), M' the own wet area blurred with the Gaussian taps along x (blur_x.comp wrote bx),
// then along y here, in the reference's order (stencils.blurred_wet: rows outside the canvas
// add taps[k] * 0).
// A separable blur: 2 (2R + 1) image loads per cell, not the (2R + 1)^2 of a 2-D loop
// (225 at wet_blur 3.5, 55 % of llvmpipe's wash step).
#include "common.glsl"
#include "tiles.glsl"

layout(rgba32f, binding = 1) uniform readonly image2D water_in;
layout(rgba32f, binding = 2) uniform readonly image2D paper_in;
layout(rgba32f, binding = 3) uniform readonly image2D jv_in;
layout(r32f, binding = 4) uniform writeonly image2D pr_out;
layout(r32f, binding = 5) uniform readonly image2D bx_in;  // the mask blurred along x

// NTAPS (2R + 1) is injected with the other defines (compiled per blur width); NTAPS 1: no
// flow-outward term (flow_outward or wet_blur 0), nothing is blurred.
#define R ((NTAPS - 1) / 2)
uniform float u_eta;             // flow_outward [height]
uniform float u_relief;          // paper_relief [height]
uniform float u_taps[NTAPS];     // float32 Gaussian taps, offset -R first

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (!valid) return;
    float w = imageLoad(water_in, c).x;
    bool wet = is_wet(imageLoad(jv_in, c).w);
    float p = w;
    if (wet && u_relief > 0.0) p = w + u_relief * imageLoad(paper_in, c).x;
#if NTAPS > 1
    if (wet) {
        float acc = 0.0;
        for (int ky = 0; ky < NTAPS; ++ky) {
            int y = c.y + ky - R;
            acc += u_taps[ky] * ((y >= 0 && y < u_size.y) ? imageLoad(bx_in, ivec2(c.x, y)).x
                                                           : 0.0);
        }
        p = p - u_eta * (1.0 - acc);
    }
#endif
    imageStore(pr_out, c, vec4(p, 0.0, 0.0, 0.0));
}
