#version 430
// pressure.comp: once per step, after prep.  Reference: flow_pressure (pass 3's levelled
// height): P = (w + relief h) - eta (1 - M') on wet cells, w elsewhere (the free surface
// over the paper's relief; Curtis 1997's flow outward; terms with a 0 parameter left out),
// M' the own wet area ((w > 0 or wc > moist) and unmasked; 0 outside the canvas; with
// wet_hold > 0 the wet-area mask wet_area that prep.comp updated) blurred with the Gaussian taps along x, then along y, in the reference's order.
// Reads the state textures (valid on every cell), so it does not depend on the tiles.
#include "common.glsl"
#include "tiles.glsl"

layout(rgba32f, binding = 1) uniform readonly image2D water_in;
layout(rgba32f, binding = 2) uniform readonly image2D paper_in;
layout(rgba32f, binding = 3) uniform readonly image2D jv_in;
layout(r32f, binding = 4) uniform writeonly image2D pr_out;
layout(r32f, binding = 5) uniform readonly image2D area_in;  // wet_area after prep

#define MAX_TAPS 17
uniform float u_moist;           // moist_threshold [height]
uniform float u_eta;             // flow_outward [height]
uniform float u_relief;          // paper_relief [height]
uniform int u_ntaps;             // 2R + 1 (0: no flow-outward term)
uniform int u_hold;              // wet_hold > 0: blur the wet-area mask M (prep wrote it)
uniform float u_taps[MAX_TAPS];  // float32 Gaussian taps, offset -R first

float own_wet(ivec2 c) {
    if (!inside(c)) return 0.0;
    if (u_hold != 0) return imageLoad(area_in, c).x;  // M = max(wet_area, own), from prep
    vec4 wa = imageLoad(water_in, c);
    return ((wa.x > 0.0 || wa.y > u_moist) && imageLoad(paper_in, c).y == 0.0) ? 1.0 : 0.0;
}

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (!valid) return;
    float w = imageLoad(water_in, c).x;
    bool wet = is_wet(imageLoad(jv_in, c).w);
    float p = w;
    if (wet && u_relief > 0.0) p = w + u_relief * imageLoad(paper_in, c).x;
    if (wet && u_ntaps > 0) {
        int r = (u_ntaps - 1) / 2;
        float acc = 0.0;
        for (int ky = 0; ky < u_ntaps; ++ky) {
            float row = 0.0;
            for (int kx = 0; kx < u_ntaps; ++kx)
                row += u_taps[kx] * own_wet(c + ivec2(kx - r, ky - r));
            acc += u_taps[ky] * row;
        }
        p = p - u_eta * (1.0 - acc);
    }
    imageStore(pr_out, c, vec4(p, 0.0, 0.0, 0.0));
}
