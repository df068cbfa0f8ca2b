#version 430
// diffuse_apply.comp: implicit_diffusion's last step for water (pass 4) and pigment
// (pass 5): each face flux F = k b (x_lower - x_higher) is scaled by the donor's limiter s
// and applied to both cells: u_new = u - F_E + F_W - F_S + F_N (reference order).
#include "common.glsl"
#include "tiles.glsl"

layout(rgba32f, binding = 1) uniform readonly image2DArray jx_in;  // converged iterate
layout(rgba32f, binding = 2) uniform readonly image2DArray js_in;  // limiters s
layout(rgba32f, binding = 3) uniform readonly image2D water_in;
layout(rgba32f, binding = 4) uniform readonly image2DArray pig_in;
layout(rgba32f, binding = 5) uniform readonly image2D aux_in;
layout(rgba32f, binding = 6) uniform writeonly image2D water_out;
layout(rgba32f, binding = 7) uniform writeonly image2DArray pig_out;

uniform float u_kw;
uniform float u_kp;

// Face flux of the face between cell c and neighbour n (f: E, W, S, N) in the reference's
// sign convention (positive from the lower-index cell to the higher), donor-scaled.
float face(int f, float xc, float xn, float sc, float sn, float kb) {
    bool lower = (f == 0 || f == 2);  // c is the lower-index cell of E and S faces
    float F = lower ? kb * (xc - xn) : kb * (xn - xc);
    bool from_lower = F > 0.0;
    float s_donor = (from_lower == lower) ? sc : sn;
    return F * s_donor;
}
vec4 face4(int f, vec4 xc, vec4 xn, vec4 sc, vec4 sn, float kb) {
    vec4 r;
    for (int k = 0; k < 4; ++k) r[k] = face(f, xc[k], xn[k], sc[k], sn[k], kb);
    return r;
}

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (!valid) return;
    vec4 a = imageLoad(aux_in, c);
    bool wet = aux_wet(a);
    vec4 wa = imageLoad(water_in, c);
    float xw = imageLoad(jx_in, ivec3(c, NPL)).x;
    float sw = imageLoad(js_in, ivec3(c, NPL)).x;
    vec4 p[NPL], xp[NPL], sp[NPL];
    for (int l = 0; l < NPL; ++l) {
        p[l] = imageLoad(pig_in, ivec3(c, l));
        xp[l] = imageLoad(jx_in, ivec3(c, l));
        sp[l] = imageLoad(js_in, ivec3(c, l));
    }
    float w = wa.x;
    for (int f = 0; f < 4; ++f) {
        ivec2 n = c + OFFS[f];
        if (!wet || !inside(n)) continue;
        vec4 an = imageLoad(aux_in, n);
        if (!aux_wet(an)) continue;
        float sign_ = (f == 0 || f == 2) ? -1.0 : 1.0;  // - F_E + F_W - F_S + F_N
        float Fw = face(f, xw, imageLoad(jx_in, ivec3(n, NPL)).x, sw,
                        imageLoad(js_in, ivec3(n, NPL)).x, u_kw);
        w = w + sign_ * Fw;
        float kb = u_kp * min(a.y, an.y);
        for (int l = 0; l < NPL; ++l) {
            vec4 Fp = face4(f, xp[l], imageLoad(jx_in, ivec3(n, l)), sp[l],
                            imageLoad(js_in, ivec3(n, l)), kb);
            p[l] = p[l] + sign_ * Fp;
        }
    }
    imageStore(water_out, c, vec4(w, wa.yzw));
    for (int l = 0; l < NPL; ++l) imageStore(pig_out, ivec3(c, l), p[l]);
}
