#version 430
// shelter.comp: once per step, after prep and blur_x, when damp_exposure is on (compiled
// per blur like blur_x).  Reference: stencils.sheltered, applied by wet_mask after the
// pinning: a cell prep let in (wb >= 0) that is not wet by its own water, on paper damper
// than damp_sat, whose exposure 1 - M' is below damp_exposure does not join (M' the
// wet-area mask blurred: bx along x, here along y, the taps in order as pressure.glsl).
// Fresh water in a damp wash pushes the wash's paint on where there is paper around it to
// go to, at the front's bulges; in a bay it holds.  M' is only known after blur_x, so this
// pass takes prep's wet cell back: wb -1 and the back-traced velocity 0 (a non-wet cell's).
#include "common.glsl"
#include "tiles.glsl"

layout(rgba32f, binding = 2) uniform readonly image2D water_in;
layout(rgba32f, binding = 3) uniform readonly image2D paper_in;
layout(r32f, binding = 4) uniform readonly image2D bx_in;   // the wet area blurred along x
layout(rgba32f, binding = 5) uniform image2D aux_io;        // prep's (v1, w)
layout(rgba32f, binding = 7) uniform image2D jv_io;         // prep's (v1, w, wb)

#define R ((NTAPS - 1) / 2)
const float u_moist = K_MOIST;
const float u_dsat = K_DSAT;
const float u_cmin = K_CMIN;
const float u_crange = K_CRANGE;
const float u_dexp = K_DEXP;         // damp_exposure
const float taps_y[NTAPS] = TAPS;

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (!valid) return;
    vec4 j = imageLoad(jv_io, c);
    if (!is_wet(j.w)) return;
    vec4 wa = imageLoad(water_in, c);
    vec4 pa = imageLoad(paper_in, c);
    if (wa.x > 0.0 || wa.y > u_moist) return;  // wet by its own water (unmasked: prep)
    if (!(min(wa.y / (u_cmin + pa.x * u_crange), 1.0) > u_dsat)) return;
    float am = 0.0;
    for (int ky = 0; ky < NTAPS; ++ky) {
        // a row outside the canvas: an invalid load's 0, the reference's zero padding
        am += taps_y[ky] * imageLoad(bx_in, ivec2(c.x, c.y + ky - R)).x;
    }
    if (1.0 - am < u_dexp) {
        imageStore(jv_io, c, vec4(0.0, 0.0, j.z, -1.0));
        vec4 a = imageLoad(aux_io, c);
        imageStore(aux_io, c, vec4(0.0, 0.0, a.z, a.w));
    }
}
