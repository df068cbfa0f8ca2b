#version 430
// diffuse_apply.comp: implicit_diffusion's last step for water (pass 4) and pigment
// (pass 5): each face flux F = k b (x_lower - x_higher) is scaled by the donor's limiter s
// and applied to both cells: u_new = u - F_E + F_W - F_S + F_N (reference order).
#include "common.glsl"
#include "tiles.glsl"

layout(rgba32f, binding = 1) uniform readonly image2D js_in;       // (xw, 0, s_w, wb)
layout(rgba32f, binding = 2) uniform readonly image2DArray jx_in;  // pigment iterate
layout(rgba32f, binding = 3) uniform readonly image2DArray jps_in; // pigment limiters
layout(rgba32f, binding = 4) uniform readonly image2D water_in;
layout(rgba32f, binding = 5) uniform readonly image2DArray pig_in;
layout(rgba32f, binding = 6) uniform writeonly image2D water_out;
layout(rgba32f, binding = 7) uniform writeonly image2DArray pig_out;

STEP_CONST(float, u_kw, K_KW);
STEP_CONST(float, u_kp, K_KP);

// Donor-scaled face flux between c and its neighbour over face f, in the reference's
// sign convention (positive from the lower-index cell to the higher).
float face(bool lower, float xc, float xn, float sc, float sn, float kb) {
    float F = lower ? kb * (xc - xn) : kb * (xn - xc);
    return F * (((F > 0.0) == lower) ? sc : sn);
}
vec4 face4(bool lower, vec4 xc, vec4 xn, vec4 sc, vec4 sn, float kb) {
    vec4 r;
    for (int k = 0; k < 4; ++k) r[k] = face(lower, xc[k], xn[k], sc[k], sn[k], kb);
    return r;
}

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (!valid) return;
    vec4 js = imageLoad(js_in, c);
    bool wet = is_wet(js.w);
    vec4 wa = imageLoad(water_in, c);
    float w = wa.x;
    // branch-free over the faces: a closed face has conductance 0 and adds 0
    float kb[4];
    for (int f = 0; f < 4; ++f) {
        ivec2 n = clamp(c + OFFS[f], ivec2(0), u_size - 1);
        vec4 jn = imageLoad(js_in, n);
        float o = (wet && inside(c + OFFS[f]) && is_wet(jn.w)) ? 1.0 : 0.0;
        bool lower = lower_side(f);
        float sign_ = lower ? -1.0 : 1.0;  // - F_E + F_W - F_S + F_N
        w = w + sign_ * face(lower, js.x, jn.x, js.z, jn.z, o * u_kw);
        kb[f] = o * u_kp * min(js.w, jn.w);
    }
    imageStore(water_out, c, vec4(w, wa.yzw));
    // pigment: a loop of its own (nested in the face loop it runs far slower)
    for (int l = 0; l < NPL; ++l) {
        if (!layer_used(l)) continue;
        vec4 p = imageLoad(pig_in, ivec3(c, l));
        vec4 xp = imageLoad(jx_in, ivec3(c, l));
        vec4 sp = imageLoad(jps_in, ivec3(c, l));
        for (int f = 0; f < 4; ++f) {
            ivec2 n = clamp(c + OFFS[f], ivec2(0), u_size - 1);
            bool lower = lower_side(f);
            vec4 Fp = face4(lower, xp, imageLoad(jx_in, ivec3(n, l)), sp,
                            imageLoad(jps_in, ivec3(n, l)), kb[f]);
            p = p + (lower ? -1.0 : 1.0) * Fp;
        }
        imageStore(pig_out, ivec3(c, l), p);
    }
}
