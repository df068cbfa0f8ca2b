#version 430
// advect_limit.comp: pass 6 limiters.  Rate per face r = |u_f| dt / 4.
//   s_out = (w - min(w, w_min)) / (w R_out) where the donor would go below min(w, w_min);
//   s_in  = min(1, (max(w, w_max) - w) / I_w, min_k (1 - p_k) / I_p,k) on inflows.
// Writes lim_out = (s_out, s_in, 0, wb).
#include "common.glsl"
#include "tiles.glsl"

layout(rg32f, binding = 1) uniform readonly image2D vel_in;
layout(rgba32f, binding = 2) uniform readonly image2D wet_in;
layout(rgba32f, binding = 3) uniform readonly image2D water_in;
layout(rgba32f, binding = 4) uniform readonly image2DArray pig_in;
layout(rgba32f, binding = 5) uniform writeonly image2D lim_out;

STEP_CONST(float, u_q4, K_Q4);  // float32(0.25 * dt)
const float u_wmin = K_WMIN;
const float u_wmax = K_WMAX;

#include "advect.glsl"

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (!valid) return;
    float wb = imageLoad(wet_in, c).w;
    bool wet = is_wet(wb);
    float s_out = 1.0, s_in = 1.0;
    if (wet) {
        vec2 vc = imageLoad(vel_in, c).xy;
        float w = imageLoad(water_in, c).x;
        float uf[4];
        for (int f = 0; f < 4; ++f) uf[f] = face_velocity(c, f, wet, vc);
        // donor side, order E, W, S, N
        float r_out = 0.0;
        for (int f = 0; f < 4; ++f)
            if (donates(f, uf[f])) r_out += abs(uf[f]) * u_q4;
        float lo = min(w, u_wmin);
        float want = w * r_out;
        float room = w - lo;
        s_out = want > room ? room / want : 1.0;
        // receiver side, reference order W, E, N, S
        const int RECV[4] = int[4](1, 0, 3, 2);
        float i_w = 0.0;
        vec4 i_p[NPL];
        for (int l = 0; l < NPL; ++l) i_p[l] = vec4(0.0);
        for (int jj = 0; jj < 4; ++jj) {
            int f = RECV[jj];
            if (uf[f] == 0.0 || donates(f, uf[f])) continue;
            ivec2 n = c + OFFS[f];
            float r = abs(uf[f]) * u_q4;
            i_w += imageLoad(water_in, n).x * r;
            for (int l = 0; l < NPL; ++l)
                if (layer_used(l)) i_p[l] += imageLoad(pig_in, ivec3(n, l)) * r;
        }
        float hi = max(w, u_wmax);
        s_in = i_w > 0.0 ? max(hi - w, 0.0) / i_w : 1.0;
        float s_in_p = 1.0;
        for (int l = 0; l < NPL; ++l) {
            if (!layer_used(l)) continue;
            vec4 room_p = max(vec4(1.0) - imageLoad(pig_in, ivec3(c, l)), vec4(0.0));
            for (int k = 0; k < 4; ++k)
                if (i_p[l][k] > 0.0) s_in_p = min(s_in_p, room_p[k] / i_p[l][k]);
        }
        s_in = min(min(s_in, s_in_p), 1.0);
    }
    imageStore(lim_out, c, vec4(s_out, s_in, 0.0, wb));
}
