#version 430
// advect_apply.comp: pass 6 fluxes.  Limited rate r' = r s_out[donor] s_in[receiver];
// water flux w_donor r', pigment flux p_donor[k] r' (pigment moves with its water);
// applied in the reference order u - F_E + F_W - F_S + F_N.
#include "common.glsl"
#include "tiles.glsl"

layout(rg32f, binding = 1) uniform readonly image2D vel_in;
layout(rgba32f, binding = 2) uniform readonly image2D water_in;
layout(rgba32f, binding = 3) uniform readonly image2DArray pig_in;
layout(rgba32f, binding = 4) uniform readonly image2D aux_in;
layout(rg32f, binding = 5) uniform readonly image2D lim_in;
layout(rgba32f, binding = 6) uniform writeonly image2D water_out;
layout(rgba32f, binding = 7) uniform writeonly image2DArray pig_out;

uniform float u_q4;

#include "advect.glsl"

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (!valid) return;
    bool wet = aux_wet(imageLoad(aux_in, c));
    vec2 vc = imageLoad(vel_in, c).xy;
    vec4 wa = imageLoad(water_in, c);
    vec2 lc = imageLoad(lim_in, c).xy;
    vec4 pc[NPL], pn[NPL];
    for (int l = 0; l < NPL; ++l) pc[l] = imageLoad(pig_in, ivec3(c, l));
    float w = wa.x;
    vec4 p[NPL];
    for (int l = 0; l < NPL; ++l) p[l] = pc[l];
    for (int f = 0; f < 4; ++f) {
        float uf = face_velocity(c, f, wet, vc);
        if (uf == 0.0) continue;
        ivec2 n = c + OFFS[f];
        bool lower = (f == 0 || f == 2);
        bool pos = uf > 0.0;
        bool c_donor = (pos == lower);
        vec2 ln = imageLoad(lim_in, n).xy;
        float r = abs(uf) * u_q4;
        // s_out of the donor times s_in of the receiver
        float rl = r * (c_donor ? lc.x * ln.y : ln.x * lc.y);
        float sgn = pos ? 1.0 : -1.0;
        float wn = imageLoad(water_in, n).x;
        float wd = c_donor ? wa.x : wn;
        float F = (sgn * wd) * rl;
        float sign_ = lower ? -1.0 : 1.0;
        w = w + sign_ * F;
        for (int l = 0; l < NPL; ++l) {
            vec4 pd = c_donor ? pc[l] : imageLoad(pig_in, ivec3(n, l));
            p[l] = p[l] + sign_ * ((sgn * pd) * rl);
        }
    }
    imageStore(water_out, c, vec4(w, wa.yzw));
    for (int l = 0; l < NPL; ++l) imageStore(pig_out, ivec3(c, l), p[l]);
}
