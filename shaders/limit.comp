#version 430
// limit.comp: after the last Jacobi iteration.
//  * velocity: pass 2's result (0 on non-wet cells), then pass 3 water_height_and_boundary:
//    v <- (1 - omega_h) v + omega_h v_h, v_h = -height_gain ((wE - wW)/2, (wS - wN)/2) with
//    closed faces reading the cell's own height; no flow through closed faces; clamp v_max.
//  * implicit_diffusion's donor limiter for water (pass 4) and pigment (pass 5): face fluxes
//    F = k b (x_i - x_n) from the converged iterate; s = u / out where the outflow exceeds u.
// Writes vel_out (final velocity) and jd_out = s (pigment layers; water in layer NPL .x).
#include "common.glsl"
#include "tiles.glsl"

layout(rg32f, binding = 1) uniform readonly image2D jv_in;
layout(rgba32f, binding = 2) uniform readonly image2DArray jd_in;
layout(rgba32f, binding = 3) uniform readonly image2D water_in;
layout(rgba32f, binding = 4) uniform readonly image2DArray pig_in;
layout(rgba32f, binding = 5) uniform readonly image2D aux_in;
layout(rg32f, binding = 6) uniform writeonly image2D vel_out;
layout(rgba32f, binding = 7) uniform writeonly image2DArray jd_out;

uniform float u_kw;
uniform float u_kp;
uniform float u_omega_h;
uniform float u_omega_i;    // float32(1 - omega_h), as the reference rounds it
uniform float u_half_gain;  // float32(-0.5 * height_gain)
uniform float u_vmax;

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (!valid) return;
    vec4 a = imageLoad(aux_in, c);
    bool wet = aux_wet(a);
    float w = imageLoad(water_in, c).x;
    float xw = imageLoad(jd_in, ivec3(c, NPL)).x;
    vec4 xp[NPL];
    vec4 outp[NPL];
    for (int l = 0; l < NPL; ++l) {
        xp[l] = imageLoad(jd_in, ivec3(c, l));
        outp[l] = vec4(0.0);
    }
    float outw = 0.0;
    bool open_f[4];
    float wn[4];
    for (int f = 0; f < 4; ++f) {
        ivec2 n = c + OFFS[f];
        open_f[f] = false;
        wn[f] = w;
        if (!wet || !inside(n)) continue;
        vec4 an = imageLoad(aux_in, n);
        if (!aux_wet(an)) continue;
        open_f[f] = true;
        wn[f] = imageLoad(water_in, n).x;
        float b = min(a.y, an.y);
        // flux leaving this cell over face f (the reference's face flux, signed to us)
        float fw = u_kw * (xw - imageLoad(jd_in, ivec3(n, NPL)).x);
        outw += max(fw, 0.0);
        float kb = u_kp * b;
        for (int l = 0; l < NPL; ++l)
            outp[l] += max(kb * (xp[l] - imageLoad(jd_in, ivec3(n, l))), vec4(0.0));
    }
    // velocity: passes 2 (non-wet -> 0) and 3
    vec2 v = wet ? imageLoad(jv_in, c).xy : vec2(0.0);
    vec2 nv;
    nv.x = u_omega_i * v.x + u_omega_h * (u_half_gain * (wn[0] - wn[1]));
    nv.y = u_omega_i * v.y + u_omega_h * (u_half_gain * (wn[2] - wn[3]));
    if (!open_f[0]) nv.x = min(nv.x, 0.0);
    if (!open_f[1]) nv.x = max(nv.x, 0.0);
    if (!open_f[2]) nv.y = min(nv.y, 0.0);
    if (!open_f[3]) nv.y = max(nv.y, 0.0);
    nv = wet ? clamp(nv, -u_vmax, u_vmax) : vec2(0.0);
    imageStore(vel_out, c, vec4(nv, 0.0, 0.0));
    // donor limiters
    float sw = outw > w ? w / outw : 1.0;
    imageStore(jd_out, ivec3(c, NPL), vec4(sw, 0.0, 0.0, 0.0));
    for (int l = 0; l < NPL; ++l) {
        vec4 u = imageLoad(pig_in, ivec3(c, l));
        vec4 s = vec4(1.0);
        for (int k = 0; k < 4; ++k)
            if (outp[l][k] > u[k]) s[k] = u[k] / outp[l][k];
        imageStore(jd_out, ivec3(c, l), s);
    }
}
