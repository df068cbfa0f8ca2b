#version 430
// advect_apply.comp: pass 6 fluxes.  Limited rate r' = (r s_out[donor]) s_in[receiver];
// water flux w_donor r', pigment flux p_donor[k] r' (pigment moves with its water);
// applied in the reference order u - F_E + F_W - F_S + F_N.
#include "common.glsl"
#include "tiles.glsl"

layout(rg32f, binding = 1) uniform readonly image2D vel_in;
layout(rgba32f, binding = 2) uniform readonly image2D wet_in;  // limiters (s_out, s_in, 0, wb)
layout(rgba32f, binding = 3) uniform readonly image2D water_in;
layout(rgba32f, binding = 4) uniform readonly image2DArray pig_in;
layout(rgba32f, binding = 5) uniform writeonly image2D water_out;
layout(rgba32f, binding = 6) uniform writeonly image2DArray pig_out;

STEP_CONST(float, u_q4, K_Q4);


void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (!valid) return;
    vec4 lc = imageLoad(wet_in, c);
    bool wet = is_wet(lc.w);
    vec4 wa = imageLoad(water_in, c);
    vec4 pc[NPL], p[NPL];
    for (int l = 0; l < NPL; ++l) {
        pc[l] = layer_used(l) ? imageLoad(pig_in, ivec3(c, l)) : vec4(0.0);
        p[l] = pc[l];
    }
    float w = wa.x;
    vec2 vc = imageLoad(vel_in, c).xy;
    // branch-free over the faces: a closed face has rate 0 and moves +-0.  Water first,
    // remembering each face's signed limited rate and donor; then the pigment layers.
    float srl[4];   // (sign of the update) * (sign of the flux): +-1
    float rls[4];   // limited rate of each face
    bool donor_c[4];
    for (int f = 0; f < 4; ++f) {
        ivec2 n = clamp(c + OFFS[f], ivec2(0), u_size - 1);
        vec4 ln = imageLoad(wet_in, n);
        bool open_ = wet && inside(c + OFFS[f]) && is_wet(ln.w);
        vec2 vn = imageLoad(vel_in, n).xy;
        float uf = open_ ? ((f < 2) ? 0.5 * (vc.x + vn.x) : 0.5 * (vc.y + vn.y)) : 0.0;
        bool lower = lower_side(f);
        bool pos = uf > 0.0;
        bool c_donor = (pos == lower);
        float r = abs(uf) * u_q4;
        float rl = c_donor ? (r * lc.x) * ln.y : (r * ln.x) * lc.y;
        float sgn = pos ? 1.0 : -1.0;
        float wn = imageLoad(water_in, n).x;
        float wd = c_donor ? wa.x : wn;
        float sign_ = lower ? -1.0 : 1.0;
        w = w + sign_ * ((sgn * wd) * rl);
        // (sign_ * sgn) is +-1, so sign_ * ((sgn * pd) * rl) == (sign_ * sgn) * (pd * rl)
        srl[f] = sign_ * sgn;
        rls[f] = rl;
        donor_c[f] = c_donor;
    }
    for (int l = 0; l < NPL; ++l) {
        if (!layer_used(l)) continue;
        for (int f = 0; f < 4; ++f) {
            ivec2 n = clamp(c + OFFS[f], ivec2(0), u_size - 1);
            vec4 pd = donor_c[f] ? pc[l] : imageLoad(pig_in, ivec3(n, l));
            p[l] = p[l] + srl[f] * (pd * rls[f]);
        }
    }
    imageStore(water_out, c, vec4(w, wa.yzw));
    for (int l = 0; l < NPL; ++l)
        if (layer_used(l)) imageStore(pig_out, ivec3(c, l), p[l]);
}
