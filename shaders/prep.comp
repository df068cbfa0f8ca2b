#version 430
// prep.comp: once per step, after the sources.  Reference: wet_mask (own water, or the
// advancing contact line), wet_memory (with wet_hold > 0 an own-wet cell's wet_area is 1),
// blocking (diffusion
// controller beta_c, times the fibre dispersion) and pass 1 advect_velocity (semi-Lagrangian back-trace, bilinear).
// Writes aux = (v1, w) (the right-hand sides of the velocity and water diffusions, read
// by every Jacobi iteration in one load) and the first Jacobi
// iterate jv = (v1x, v1y, w, wb), wb = beta_c on wet cells, -1 elsewhere.
#include "common.glsl"
#include "tiles.glsl"

layout(rg32f, binding = 1) uniform readonly image2D vel_in;
layout(rgba32f, binding = 2) uniform readonly image2D water_in;
layout(rgba32f, binding = 3) uniform readonly image2D paper_in;
layout(rgba32f, binding = 4) uniform writeonly image2D aux_out;
layout(rgba32f, binding = 5) uniform writeonly image2D jv_out;
layout(rg32f, binding = 6) uniform readonly image2D fibre_in;   // fibre along x, along y
layout(r32f, binding = 7) uniform image2D area_io;  // wet_area: Curtis's wet-area mask memory

STEP_CONST(float, u_dt, K_DT);
const float u_moist = K_MOIST;        // moist_threshold [height]
uniform float u_sim_time;     // [s]
const float u_block_fade = K_BLOCK_FADE;   // [s]
const float u_block_paper = K_BLOCK_PAPER;  // share of paper height in the blocking value
const float u_advance = K_ADVANCE;      // advance_height [height] (0: contact line pinned)
const float u_adv_base = K_ADV_BASE;     // 1 + advance_grain / 2
const float u_adv_grain = K_ADV_GRAIN;    // advance_grain: how much the paper height sets it
const float u_curv = K_CURV;         // advance_curvature: the meniscus's curvature on drier paper
const float u_curv_n = K_CURV_N;       // float32(1 + 2 advance_curvature)
const float u_wick = K_WICK;         // fibre_wick: a fibre along the axis lowers the advancing height
const float u_disperse = K_DISPERSE;     // fibre_dispersivity / nu_p [s/cell]: dispersion along fibre channels
const float u_sinv = K_SINV;         // 1 / standing_depth (0: off): pigment diffusion in standing water
const float u_sdrop = K_SDROP;       // float32(1 - standing_nu_p / nu_p)
const float u_fibre_flow_max = K_FIBRE_FLOW_MAX;  // [cell/s] water moves through the fibre channels no faster
const float u_ease = K_EASE;         // damp_ease: damp paper's suction eases the advancing height
const float u_dsat = K_DSAT;         // damp_sat [1]
const float u_dspan = K_DSPAN;        // float32(1 - damp_sat)
const float u_cmin = K_CMIN;         // c_min [height]
const float u_crange = K_CRANGE;       // float32(c_max - c_min) [height]
const int u_hold = K_HOLD;           // wet_hold > 0: the wet-area mask M = max(wet_area, own) grows

bool wet_at(ivec2 c) {
    vec4 wa = imageLoad(water_in, c);
    float mask = imageLoad(paper_in, c).y;
    return (wa.x > 0.0 || wa.y > u_moist) && mask == 0.0;
}

// velocity of the advected source field vs = v * wet
vec2 vs_at(ivec2 c) {
    return wet_at(c) ? imageLoad(vel_in, c).xy : vec2(0.0);
}

// fluid water of a cell, 0 outside the canvas
float w_at(ivec2 n) {
    return inside(n) ? imageLoad(water_in, n).x : 0.0;
}

// the contact line reaches this (unmasked) cell: a neighbour's fluid water stands above
// its advancing height advance_height (1 + g/2 - g h) (g: advance_grain), times (1 - fibre_wick * fibre) along the
// axis of that neighbour (x: .x, y: .y), eased on damp paper
bool crept(ivec2 c, vec4 pa, vec4 wa) {
    // the paper's share (stencils.advance_term): 1.5 - h, on damp paper 1 + g/2 - g h
    float sd = min(wa.y / (u_cmin + pa.x * u_crange), 1.0);
    float thr = u_advance * (sd > u_dsat ? u_adv_base - u_adv_grain * pa.x : 1.5 - pa.x);
    if (u_ease > 0.0) {
        // damp paper's suction: times max(1 - damp_ease ((4 s') (1 - s')), 0),
        // s' = max(s - damp_sat, 0) / (1 - damp_sat), s = min(wc / c, 1)
        float s = min(wa.y / (u_cmin + pa.x * u_crange), 1.0);
        float sp = max(s - u_dsat, 0.0) / u_dspan;
        float f = 1.0 - u_ease * ((4.0 * sp) * (1.0 - sp));
        thr = thr * max(f, 0.0);
    }
    if (u_curv > 0.0 && !(sd > u_dsat)) {
        // the meniscus's curvature (stencils.front_curvature): the neighbourhood's water
        // ((E + W) + S) + N + a (((SE + SW) + NE) + NW), cells outside 0, against (1 + 2a) thr
        float s4 = ((w_at(c + ivec2(1, 0)) + w_at(c + ivec2(-1, 0))) + w_at(c + ivec2(0, 1)))
            + w_at(c + ivec2(0, -1));
        float s8 = ((w_at(c + ivec2(1, 1)) + w_at(c + ivec2(-1, 1))) + w_at(c + ivec2(1, -1)))
            + w_at(c + ivec2(-1, -1));
        return (s4 + u_curv * s8) > u_curv_n * thr;
    }
    vec2 fib = u_wick > 0.0 ? imageLoad(fibre_in, c).xy : vec2(0.0);
    for (int f = 0; f < 4; ++f) {
        ivec2 n = c + OFFS[f];
        float along = OFFS[f].x != 0 ? fib.x : fib.y;
        if (inside(n) && imageLoad(water_in, n).x > thr * (1.0 - u_wick * along)) return true;
    }
    return false;
}

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (!valid) return;
    vec4 pa = imageLoad(paper_in, c);
    vec4 wa = imageLoad(water_in, c);
    bool wet = (wa.x > 0.0 || wa.y > u_moist) && pa.y == 0.0;
    // reference wet_memory: the wet-area mask keeps every cell wet in this wet phase
    if (u_hold != 0 && wet) imageStore(area_io, c, vec4(1.0, 0.0, 0.0, 0.0));
    if (!wet && u_advance > 0.0 && pa.y == 0.0 && crept(c, pa, wa)) {
        // on paper no damper than damp_sat the front needs a neighbour beside it: two of
        // this cell's 4-neighbours wet or advancing with it (stencils.pinned)
        float s = min(wa.y / (u_cmin + pa.x * u_crange), 1.0);
        int n = 0;
        for (int f = 0; f < 4; ++f) {
            ivec2 nb = c + OFFS[f];
            if (!inside(nb)) continue;
            vec4 pn = imageLoad(paper_in, nb);
            vec4 wn = imageLoad(water_in, nb);
            bool own = (wn.x > 0.0 || wn.y > u_moist) && pn.y == 0.0;
            if (own || (pn.y == 0.0 && crept(nb, pn, wn))) n += 1;
        }
        wet = n >= 2 || s > u_dsat;
    }
    // diffusion controller: beta_c = min(1 - block_paper (1 - h), block_eff)
    float age = u_block_fade > 0.0 ? clamp((u_sim_time - pa.w) / u_block_fade, 0.0, 1.0) : 1.0;
    float eff = pa.z + (1.0 - pa.z) * age;
    float beta_c = min(1.0 - u_block_paper * (1.0 - pa.x), eff);
    // standing_depth: the pigment's own diffusion standing_nu_p in standing water
    // (passes.blocking's standing: 1 - drop * smoothstep(min(w / depth, 1)))
    float own_p = 1.0;
    if (u_sinv > 0.0) {
        float t = min(wa.x * u_sinv, 1.0);
        own_p = 1.0 - u_sdrop * ((t * t) * (3.0 - 2.0 * t));
    }
    if (u_disperse > 0.0) {
        // times 1 + gd * (max(fibre along x, along y) * min(|v|, fibre_flow_max)), v at the
        // start of the step: moving water disperses its pigment along the fibre channels
        vec2 fd = imageLoad(fibre_in, c).xy;
        vec2 v0 = imageLoad(vel_in, c).xy;
        float s = min(sqrt(v0.x * v0.x + v0.y * v0.y), u_fibre_flow_max);
        beta_c = beta_c * (own_p + u_disperse * (max(fd.x, fd.y) * s));
    } else if (u_sinv > 0.0) {
        beta_c = beta_c * own_p;
    }
    vec2 v1 = vec2(0.0);
    if (wet) {
        // back-trace X = i - v dt, bilinear; the weight comes from the displacement
        // alone, f = (-v dt) - floor(-v dt), i0 = i + floor(-v dt), clamped as in the
        // reference (i0 < 0: i0 = 0, f = 0; i0 >= n - 1: i0 = n - 2, f = 1)
        vec2 off = -(imageLoad(vel_in, c).xy * u_dt);
        vec2 fl = floor(off);
        vec2 fr = off - fl;
        ivec2 i0 = c + ivec2(fl);
        ivec2 d = ivec2(u_size.x > 1 ? 1 : 0, u_size.y > 1 ? 1 : 0);
        for (int a = 0; a < 2; ++a) {
            if (u_size[a] < 2) {
                i0[a] = 0;
                fr[a] = 0.0;
            } else if (i0[a] < 0) {
                i0[a] = 0;
                fr[a] = 0.0;
            } else if (i0[a] >= u_size[a] - 1) {
                i0[a] = u_size[a] - 2;
                fr[a] = 1.0;
            }
        }
        vec2 g = 1.0 - fr;
        vec2 top = g.x * vs_at(i0) + fr.x * vs_at(i0 + ivec2(d.x, 0));
        vec2 bot = g.x * vs_at(i0 + ivec2(0, d.y)) + fr.x * vs_at(i0 + d);
        v1 = g.y * top + fr.y * bot;
    }
    imageStore(aux_out, c, vec4(v1, wa.x, 0.0));  // the right-hand sides v1 and w
    imageStore(jv_out, c, vec4(v1, wa.x, wet ? max(beta_c, 0.0) : -1.0));
}
