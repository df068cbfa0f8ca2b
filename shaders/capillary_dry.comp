#version 430
// capillary_dry.comp:
//   pass 9b capillary diffusion (all cells): F = kappa dt min(c_i, c_j) (s_i - s_j),
//          s = wc / c, on faces whose two cells are unmasked; wc = max(wc, 0);
//   pass 9c capillary evaporation where w == 0: e = min(eps_cap dt, wc);
//   pass 10 dry_cells: 0 < w < w_dry_eps evaporates; cells with w == 0 deposit
//          t = min(p, 1 - q) and lose their velocity; with suspend_sat > 0 a cell whose
//          wc > suspend_sat c keeps its pigment suspended (damp paper); then, with
//          wet_hold > 0, the wet-area memory fades (reference wet_area_update).
// Also flags the tile alive (any w > 0 or wc > 0) for the dirty-tile update: every cell that
// holds water stores 1 (a benign race, all writers store the same value).  No barrier and
// no shared flag: on llvmpipe a barrier turns the whole program into coroutines, which cost
// more than the pass's own work (this pass took 2x its loads' time with one).
#include "common.glsl"
#include "tiles.glsl"

layout(rgba32f, binding = 1) uniform readonly image2D water_in;
layout(rgba32f, binding = 2) uniform writeonly image2D water_out;
layout(rgba32f, binding = 3) uniform readonly image2D paper_in;
layout(rgba32f, binding = 4) uniform image2DArray pig_io;
layout(rgba32f, binding = 5) uniform image2DArray dep_io;
layout(rg32f, binding = 6) uniform image2D vel_io;
layout(r32f, binding = 7) uniform image2D area_io;  // wet_area (Curtis's wet-area mask)

layout(std430, binding = 1) buffer TileAlive { uint tile_alive[]; };

STEP_CONST(float, u_kcap, K_KCAP);    // float32(cap_diffusion * dt)
STEP_CONST(float, u_ecap, K_ECAP);    // float32(eps_cap * dt)
const float u_dry_eps = K_DRY_EPS;
const float u_cmin = K_CMIN;
const float u_crange = K_CRANGE;
const float u_susp = K_SUSP;    // suspend_sat [1] (0: off)
STEP_CONST(float, u_fade, K_FADE);    // float32(dt / wet_hold) (0: wet_hold off)
const float u_moist = K_MOIST;   // moist_threshold [height]

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (valid) {
        vec4 wa = imageLoad(water_in, c);
        vec4 pa = imageLoad(paper_in, c);
        float w = wa.x, wc = wa.y, evap = wa.z;
        if (u_kcap > 0.0) {
            float cap = u_cmin + pa.x * u_crange;
            float s = wc / cap;
            float acc = wc;
            for (int f = 0; f < 4; ++f) {  // branch-free: a closed face adds 0
                ivec2 n = clamp(c + OFFS[f], ivec2(0), u_size - 1);
                vec4 pn = imageLoad(paper_in, n);
                float k = (inside(c + OFFS[f]) && pa.y == 0.0 && pn.y == 0.0) ? u_kcap : 0.0;
                float capn = u_cmin + pn.x * u_crange;
                float sn = imageLoad(water_in, n).y / capn;
                bool lower = lower_side(f);
                float F = lower ? k * min(cap, capn) * (s - sn) : k * min(capn, cap) * (sn - s);
                acc = lower ? acc - F : acc + F;
            }
            wc = max(acc, 0.0);
        }
        if (w == 0.0) {
            float e = min(u_ecap, wc);
            wc = wc - e;
            evap = evap + e;
        }
        if (w > 0.0 && w < u_dry_eps) {
            evap = evap + w;
            w = 0.0;
        }
        bool settle = !(u_susp > 0.0 && wc > u_susp * (u_cmin + pa.x * u_crange));
        if (w == 0.0 && settle) {
            for (int l = 0; l < NPL; ++l) {
                if (!layer_used(l)) continue;
                vec4 p = imageLoad(pig_io, ivec3(c, l));
                vec4 q = imageLoad(dep_io, ivec3(c, l));
                if (any(greaterThan(p, vec4(0.0)))) {
                    vec4 t = min(p, 1.0 - q);
                    imageStore(dep_io, ivec3(c, l), q + t);
                    imageStore(pig_io, ivec3(c, l), p - t);
                }
            }
        }
        if (w == 0.0) imageStore(vel_io, c, vec4(0.0));
        imageStore(water_out, c, vec4(w, wc, evap, wa.w));
        if (u_fade > 0.0) {
            // reference wet_area_update: 1 where own-wet, else fades while the paper is
            // damp, 0 on dry paper
            float a = 0.0;
            if ((w > 0.0 || wc > u_moist) && pa.y == 0.0) a = 1.0;
            else if (wc > 0.0) a = max(imageLoad(area_io, c).x - u_fade, 0.0);
            imageStore(area_io, c, vec4(a, 0.0, 0.0, 0.0));
        }
        if (w > 0.0 || wc > 0.0) tile_alive[tile_of_group()] = 1u;
    }
}
