#version 430
// limit.comp: after the last Jacobi iteration.
//  * velocity: pass 2's result (0 on non-wet cells), then pass 3 water_height_and_boundary:
//    v <- (1 - omega_h) v + omega_h v_h, v_h = -height_gain ((PE - PW)/2, (PS - PN)/2) with
//    closed faces reading the cell's own P (pressure.comp: w lowered near the edge), each axis's
//    term times u_pbase + u_pgain * fibre[axis] when u_pgain != 0 (fibre_permeability: the
//    film's levelling flow runs along the paper's fibres; with u_pgate faded in by the
//    standing water, (1 - g a) + g gain fibre[axis]; off on paper without fibre); no flow through closed faces; tilt
//    gravity added; clamp v_max.
//  * implicit_diffusion's donor limiter for water (pass 4) and pigment (pass 5): face fluxes
//    F = k b (x_i - x_n) from the converged iterate; s = u / out where the outflow exceeds u.
// Writes vel_out (final velocity), js = (xw, 0, s_w, wb) and jd_out = s_p.
#include "common.glsl"
#include "tiles.glsl"

layout(rgba32f, binding = 1) uniform readonly image2D jv_in;
layout(rgba32f, binding = 2) uniform readonly image2DArray jd_in;
layout(rgba32f, binding = 3) uniform readonly image2D water_in;
layout(rgba32f, binding = 4) uniform readonly image2DArray pig_in;
layout(rg32f, binding = 5) uniform writeonly image2D vel_out;
layout(rgba32f, binding = 6) uniform writeonly image2D js_out;
layout(rgba32f, binding = 7) uniform writeonly image2DArray jd_out;
layout(r32f, binding = 0) uniform readonly image2D pr_in;  // pass 3's levelled height P
// the fibre texture (along x, along y) through a sampler: the eight image units are taken
// (eight is all some GPUs give a compute shader)
layout(binding = 0) uniform sampler2D fibre_tex;
layout(binding = 1) uniform sampler2D paper_tex;  // h in .x (the gate's relief term)

STEP_CONST(float, u_kw, K_KW);
STEP_CONST(float, u_kp, K_KP);
const float u_omega_h = K_OMEGA_H;
const float u_omega_i = K_OMEGA_I;    // float32(1 - omega_h), as the reference rounds it
const float u_half_gain = K_HALF_GAIN;  // float32(-0.5 * height_gain)
const float u_vmax = K_VMAX;
STEP_CONST(vec2, u_tilt, vec2(K_TILT_X, K_TILT_Y));  // float32(ax dt, ay dt) of the tilt
const float u_pbase = K_PBASE;  // float32(1 - fibre_permeability)
const float u_pgain = K_PGAIN;  // float32(FIBRE_CHANNEL * fibre_permeability); 0: off
const float u_pa = K_PA;        // fibre_permeability
const float u_pgate = K_PGATE;  // 1 / fibre_gate_depth; 0: the channel ungated
const float u_ppull = K_PPULL;  // 1 / fibre_gate_pull; 0: no front factor
const float u_relief = K_RELIEF;  // paper_relief
uniform float u_fibred;         // 1: the paper has fibre; 0: nothing channels the flow

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (!valid) return;
    vec4 j = imageLoad(jv_in, c);
    bool wet = is_wet(j.w);
    float w = imageLoad(water_in, c).x;
    float pc = imageLoad(pr_in, c).x;
    float outw = 0.0;
    bool open_f[4] = bool[4](false, false, false, false);
    float wn[4] = float[4](pc, pc, pc, pc);
    float kb[4];  // pigment conductance k_p b of each face (0 when closed)
    // branch-free over the faces (llvmpipe runs this markedly faster); closed faces add 0
    for (int f = 0; f < 4; ++f) {
        ivec2 n = clamp(c + OFFS[f], ivec2(0), u_size - 1);
        vec4 jn = imageLoad(jv_in, n);
        bool open_ = wet && inside(c + OFFS[f]) && is_wet(jn.w);
        float o = open_ ? 1.0 : 0.0;
        open_f[f] = open_;
        wn[f] = open_ ? imageLoad(pr_in, n).x : pc;
        // flux leaving this cell over face f (the reference's face flux, signed to us)
        outw += o * max(u_kw * (j.z - jn.z), 0.0);
        kb[f] = o * u_kp * min(j.w, jn.w);
    }
    // pigment outflows: a loop of its own (nested in the face loop it runs far slower)
    vec4 outp[NPL];
    for (int l = 0; l < NPL; ++l) {
        outp[l] = vec4(0.0);
        if (!layer_used(l)) continue;
        vec4 xp = imageLoad(jd_in, ivec3(c, l));
        for (int f = 0; f < 4; ++f) {
            ivec2 n = clamp(c + OFFS[f], ivec2(0), u_size - 1);
            outp[l] += max(kb[f] * (xp - imageLoad(jd_in, ivec3(n, l))), vec4(0.0));
        }
    }
    // velocity: passes 2 (non-wet -> 0) and 3
    vec2 v = wet ? j.xy : vec2(0.0);
    vec2 nv;
    vec2 d = vec2(wn[0] - wn[1], wn[2] - wn[3]);
    if (u_pgain != 0.0 && u_fibred != 0.0) {
        vec2 fb = texelFetch(fibre_tex, c, 0).xy;
        if (u_pgate != 0.0) {  // faded in by the standing water (reference fibre_gate)
            float t = min(w * u_pgate, 1.0);
            float g = (t * t) * (3.0 - 2.0 * t);
            if (u_ppull != 0.0) {  // off where the flow outward pulls (a front into dry paper)
                float top = u_relief > 0.0 ? w + u_relief * texelFetch(paper_tex, c, 0).x : w;
                float u = min(max(top - pc, 0.0) * u_ppull, 1.0);
                g = g * (1.0 - (u * u) * (3.0 - 2.0 * u));
            }
            d = d * ((1.0 - g * u_pa) + (g * u_pgain) * fb);
        } else {
            d = d * (u_pbase + u_pgain * fb);
        }
    }
    nv.x = u_omega_i * v.x + u_omega_h * (u_half_gain * d.x);
    nv.y = u_omega_i * v.y + u_omega_h * (u_half_gain * d.y);
    // the tilt's gravity (reference.tilt_kick); a flat canvas adds nothing
    if (u_tilt.x != 0.0) nv.x = nv.x + u_tilt.x;
    if (u_tilt.y != 0.0) nv.y = nv.y + u_tilt.y;
    if (!open_f[0]) nv.x = min(nv.x, 0.0);
    if (!open_f[1]) nv.x = max(nv.x, 0.0);
    if (!open_f[2]) nv.y = min(nv.y, 0.0);
    if (!open_f[3]) nv.y = max(nv.y, 0.0);
    nv = wet ? clamp(nv, -u_vmax, u_vmax) : vec2(0.0);
    imageStore(vel_out, c, vec4(nv, 0.0, 0.0));
    // donor limiters
    // a cell a rounding error left below 0 holds nothing (no division by a zero outflow)
    float wh = max(w, 0.0);
    float sw = outw > wh ? wh / outw : 1.0;
    imageStore(js_out, c, vec4(j.z, 0.0, sw, j.w));
    for (int l = 0; l < NPL; ++l) {
        if (!layer_used(l)) continue;
        vec4 u = imageLoad(pig_in, ivec3(c, l));
        vec4 s = vec4(1.0);
        for (int k = 0; k < 4; ++k)
            if (outp[l][k] > max(u[k], 0.0)) s[k] = max(u[k], 0.0) / outp[l][k];
        imageStore(jd_out, ivec3(c, l), s);
    }
}
