#version 430
// jacobi.comp: one Jacobi iteration of the three implicit diffusions at once, which share
// their open faces (both cells wet):
//   pass 2 diffuse_velocity: x <- (v1 + k_v sum_open x_n) / (1 + k_v n_open)
//   pass 4 diffuse_water:    x <- (w + k_w sum_open x_n) / (1 + k_w n_open)
//   pass 5 diffuse_pigment:  x <- (p + k_p sum b_n x_n) / (1 + k_p sum b_n),
//                            b_n = min(beta_c, beta_c_n) on open faces.
// FIRST_ITER (define): the iterate starts at the right-hand side (x0 = u).
// jd layers 0..NPL-1: pigment iterate; layer NPL: water iterate in .x.
#include "common.glsl"
#include "tiles.glsl"

layout(rgba32f, binding = 1) uniform readonly image2D aux_in;
layout(rgba32f, binding = 2) uniform readonly image2D water_in;
layout(rgba32f, binding = 3) uniform readonly image2DArray pig_in;
layout(rg32f, binding = 4) uniform readonly image2D jv_in;
layout(rgba32f, binding = 5) uniform readonly image2DArray jd_in;
layout(rg32f, binding = 6) uniform writeonly image2D jv_out;
layout(rgba32f, binding = 7) uniform writeonly image2DArray jd_out;

uniform float u_kv;  // viscosity * dt
uniform float u_kw;  // nu_w * dt
uniform float u_kp;  // nu_p * dt

vec2 xv_at(ivec2 n) {
#ifdef FIRST_ITER
    return imageLoad(aux_in, n).zw;
#else
    return imageLoad(jv_in, n).xy;
#endif
}
float xw_at(ivec2 n) {
#ifdef FIRST_ITER
    return imageLoad(water_in, n).x;
#else
    return imageLoad(jd_in, ivec3(n, NPL)).x;
#endif
}
vec4 xp_at(ivec2 n, int l) {
#ifdef FIRST_ITER
    return imageLoad(pig_in, ivec3(n, l));
#else
    return imageLoad(jd_in, ivec3(n, l));
#endif
}

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (!valid) return;
    vec4 a = imageLoad(aux_in, c);
    bool wet = aux_wet(a);
    vec2 sv = vec2(0.0);
    float sw = 0.0;
    float nopen = 0.0;
    float bsum = 0.0;
    vec4 sp[NPL];
    for (int l = 0; l < NPL; ++l) sp[l] = vec4(0.0);
    for (int f = 0; f < 4; ++f) {
        ivec2 n = c + OFFS[f];
        if (!wet || !inside(n)) continue;
        vec4 an = imageLoad(aux_in, n);
        if (!aux_wet(an)) continue;
        nopen += 1.0;
        sv += xv_at(n);
        sw += xw_at(n);
        float b = min(a.y, an.y);
        bsum += b;
        for (int l = 0; l < NPL; ++l) sp[l] += b * xp_at(n, l);
    }
    vec2 v1 = a.zw;
    vec2 xv = (v1 + u_kv * sv) / (1.0 + u_kv * nopen);
    float w = imageLoad(water_in, c).x;
    float xw = (w + u_kw * sw) / (1.0 + u_kw * nopen);
    float dp = 1.0 + u_kp * bsum;
    for (int l = 0; l < NPL; ++l) {
        vec4 p = imageLoad(pig_in, ivec3(c, l));
        imageStore(jd_out, ivec3(c, l), (p + u_kp * sp[l]) / dp);
    }
    imageStore(jd_out, ivec3(c, NPL), vec4(xw, 0.0, 0.0, 0.0));
    imageStore(jv_out, c, vec4(xv, 0.0, 0.0));
}
