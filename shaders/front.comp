#version 430
// front.comp: once per step, after prep and blur_x, when the standing gate's front factor
// is on (standing_front_pull; compiled per blur like blur_x).  Reference: standing_front
// and blocking: beta_c's own share is 1 - drop g (1 - F), g = smoothstep(min(w / depth,
// 1)), F = smoothstep(min(eta (1 - M') / pull, 1)), with FRONT_DRY times min(2 (1 - D'),
// 1), M' the wet area blurred (bx along x, here along y, as pressure.glsl), D' the
// not-dry paper (wc >= T c) blurred the same (dx, blur_x.comp).  M' is only known after
// blur_x, so this pass rewrites prep's wb (jv.w) on wet cells: the first Jacobi iteration
// reads it at the neighbours, so it cannot be formed there.  Having M', it also writes
// pass 3's levelled height P (pressure.glsl's sum, the same taps in the same order) into
// pr, and the first Jacobi iteration (PR_DONE) does not blur bx again.
#include "common.glsl"
#include "tiles.glsl"
#include "pull.glsl"

layout(rg32f, binding = 1) uniform readonly image2D vel_in;
layout(rgba32f, binding = 2) uniform readonly image2D water_in;
layout(rgba32f, binding = 3) uniform readonly image2D paper_in;
layout(r32f, binding = 4) uniform readonly image2D bx_in;   // the wet area blurred along x
#if FRONT_DRY
layout(r32f, binding = 5) uniform readonly image2D dx_in;   // the not-dry paper along x
#endif
layout(rg32f, binding = 6) uniform readonly image2D fibre_in;
layout(rgba32f, binding = 7) uniform image2D jv_io;         // prep's (v1, w, wb)
layout(r32f, binding = 0) uniform writeonly image2D pr_out;  // pass 3's levelled height

#define R ((NTAPS - 1) / 2)
uniform float u_sim_time;     // [s]
const float u_block_fade = K_BLOCK_FADE;
const float u_block_paper = K_BLOCK_PAPER;
const float u_disperse = K_DISPERSE;
const float u_fibre_flow_max = K_FIBRE_FLOW_MAX;
const float u_sinv = K_SINV;
const float u_sdrop = K_SDROP;
const float u_eta = K_ETA;
const float u_relief = K_RELIEF;     // paper_relief [height]
const float u_finv = K_FINV;         // 1 / standing_front_pull
const float taps_y[NTAPS] = TAPS;

float smooth_t(float x) {
    float t = min(x, 1.0);
    return (t * t) * (3.0 - 2.0 * t);
}

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (!valid) return;
    vec4 j = imageLoad(jv_io, c);
    vec4 wa = imageLoad(water_in, c);
    if (!is_wet(j.w)) {  // not wet: prep's -1 stays, P is w (pressure.glsl)
        imageStore(pr_out, c, vec4(wa.x, 0.0, 0.0, 0.0));
        return;
    }
    float am = 0.0;
#if FRONT_DRY
    float ad = 0.0;
#endif
    for (int ky = 0; ky < NTAPS; ++ky) {
        // a row outside the canvas: an invalid load's 0, the reference's zero padding
        ivec2 n = ivec2(c.x, c.y + ky - R);
        am += taps_y[ky] * imageLoad(bx_in, n).x;
#if FRONT_DRY
        ad += taps_y[ky] * imageLoad(dx_in, n).x;
#endif
    }
    vec4 pa = imageLoad(paper_in, c);
    // pressure.glsl's levelled_height on a wet cell, with this M'
    float pv = wa.x;
    if (u_relief > 0.0) pv = wa.x + u_relief * pa.x;
    imageStore(pr_out, c, vec4(pv - u_eta * outward_pull(1.0 - am), 0.0, 0.0, 0.0));
    float fr = smooth_t((u_eta * (1.0 - am)) * u_finv);
#if FRONT_DRY
    fr = fr * min(2.0 * (1.0 - ad), 1.0);
#endif
    float age = u_block_fade > 0.0 ? clamp((u_sim_time - pa.w) / u_block_fade, 0.0, 1.0) : 1.0;
    float eff = pa.z + (1.0 - pa.z) * age;
    float beta_c = min(1.0 - u_block_paper * (1.0 - pa.x), eff);
    float own_p = 1.0 - u_sdrop * (smooth_t(wa.x * u_sinv) * (1.0 - fr));
    if (u_disperse > 0.0) {
        vec2 fd = imageLoad(fibre_in, c).xy;
        vec2 v0 = imageLoad(vel_in, c).xy;
        float s = min(sqrt(v0.x * v0.x + v0.y * v0.y), u_fibre_flow_max);
        beta_c = beta_c * (own_p + u_disperse * (max(fd.x, fd.y) * s));
    } else {
        beta_c = beta_c * own_p;
    }
    imageStore(jv_io, c, vec4(j.xyz, max(beta_c, 0.0)));
}
