#version 430
// jacobi.comp: one Jacobi iteration of the three implicit diffusions at once; they share
// the open faces (both cells wet):
//   pass 2 diffuse_velocity: x <- (v1 + k_v sum_open x_n) / (1 + k_v n_open)
//   pass 4 diffuse_water:    x <- (w + k_w sum_open x_n) / (1 + k_w n_open)
//   pass 5 diffuse_pigment:  x <- (p + k_p sum b_n x_n) / (1 + k_p sum b_n),
//                            b_n = min(beta_c, beta_c_n) on open faces.
// jv = (xvx, xvy, xw, wb); jd = pigment iterate.
// FIRST_ITER (the step's first iteration, compiled per blur width NTAPS): the pigment
// iterate starts at p itself (read from pig_in), and the iteration also forms pass 3's
// levelled height P (pressure.glsl; limit.comp reads it): one pass and one invocation per
// cell fewer than a pressure pass of its own, which on llvmpipe costs most of its time in
// the invocation, not the loads.  The image units stay within GL's minimum of 8.
#include "common.glsl"
#include "tiles.glsl"

layout(rgba32f, binding = 1) uniform readonly image2D jv_in;
layout(rgba32f, binding = 2) uniform readonly image2D aux_in;  // (v1, w): right-hand sides
layout(rgba32f, binding = 4) uniform readonly image2DArray pig_in;
#ifdef FIRST_ITER
#define jd_in pig_in
layout(rgba32f, binding = 3) uniform readonly image2D paper_in;
layout(r32f, binding = 0) uniform writeonly image2D pr_out;
#if NTAPS > 1
layout(r32f, binding = 5) uniform readonly image2D bx_in;  // the mask blurred along x
#endif
#include "pressure.glsl"
#else
layout(rgba32f, binding = 5) uniform readonly image2DArray jd_in;
#endif
layout(rgba32f, binding = 6) uniform writeonly image2D jv_out;
layout(rgba32f, binding = 7) uniform writeonly image2DArray jd_out;

STEP_CONST(float, u_kv, K_KV);  // viscosity * dt
STEP_CONST(float, u_kw, K_KW);  // nu_w * dt
STEP_CONST(float, u_kp, K_KP);  // nu_p * dt

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (!valid) return;
    vec4 j = imageLoad(jv_in, c);
    bool wet = is_wet(j.w);
    vec4 rhs = imageLoad(aux_in, c);
#ifdef FIRST_ITER
#if !PR_DONE
    // prep wrote w into aux (.z) and wb into the first iterate (.w); with PR_DONE
    // front.comp wrote P already (it blurs bx along y for the standing gate's front)
    imageStore(pr_out, c, vec4(levelled_height(c, rhs.z, wet), 0.0, 0.0, 0.0));
#endif
#endif
    vec3 s = vec3(0.0);  // sums of velocity (xy) and water (z) iterates over open faces
    float nopen = 0.0;
    float bsum = 0.0;
    // Faces first (branch-free: a closed face has conductance 0 and adds 0), then the
    // pigment layers in a loop of their own: nesting the layer loop inside the face loop
    // runs several times slower on llvmpipe.
    float bf[4];
    for (int f = 0; f < 4; ++f) {
        ivec2 n = clamp(c + OFFS[f], ivec2(0), u_size - 1);
        vec4 jn = imageLoad(jv_in, n);
        // open face: both cells wet and the neighbour inside the canvas
        float open_ = (wet && inside(c + OFFS[f]) && is_wet(jn.w)) ? 1.0 : 0.0;
        nopen += open_;
        s += open_ * jn.xyz;
        bf[f] = open_ * min(j.w, jn.w);
        bsum += bf[f];
    }
    vec4 sp[NPL];
    for (int l = 0; l < NPL; ++l) {
        sp[l] = vec4(0.0);
        if (!layer_used(l)) continue;
        for (int f = 0; f < 4; ++f) {
            ivec2 n = clamp(c + OFFS[f], ivec2(0), u_size - 1);
            sp[l] += bf[f] * imageLoad(jd_in, ivec3(n, l));
        }
    }
    vec2 xv = (rhs.xy + u_kv * s.xy) / (1.0 + u_kv * nopen);
    float xw = (rhs.z + u_kw * s.z) / (1.0 + u_kw * nopen);
    imageStore(jv_out, c, vec4(xv, xw, j.w));
    float dp = 1.0 + u_kp * bsum;
    for (int l = 0; l < NPL; ++l) {
        if (!layer_used(l)) continue;
        vec4 p = imageLoad(pig_in, ivec3(c, l));
        imageStore(jd_out, ivec3(c, l), (p + u_kp * sp[l]) / dp);
    }
}
