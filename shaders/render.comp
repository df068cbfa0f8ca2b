#version 430
// render.comp: the canvas as linear sRGB reflectance (reference render.py:
// to_linear_rgb(km_layer(...)) / to_linear_rgb(gouache_layer(...))), per band:
//   NBANDS 3 (Curtis's RGB channels) or 12 (25 nm spectral bands over 400-700 nm);
//   RENDER_KM: Kubelka-Munk per band over R_composed (t capped at 30; the
//              b -> 0 limit where b < 1e-4);
//   else gouache: opaque blend: body colour R_inf = a - b of the KM mix with an implicit
//              white filler, opacity min(1, d / gouache_opaque).
// Each band is clamped to [0, 1], then u_to_rgb (3 x NBANDS, rows summing to 1: CIE 1931
// x D65 -> linear sRGB) reduces the bands to RGB (the identity for 3 bands).
// NSLOTS_USED (uniform) pigments of the active layer take part.
#include "common.glsl"
#include "sinh.glsl"

#ifndef NBANDS
#define NBANDS 3
#endif
#define NRL ((NBANDS + 3) / 4)

layout(local_size_x = 16, local_size_y = 16) in;

layout(rgba32f, binding = 1) uniform readonly image2DArray pig_in;
layout(rgba32f, binding = 2) uniform readonly image2DArray dep_in;
layout(rgba32f, binding = 3) uniform readonly image2DArray rcomp_in;  // NRL layers of 4 bands
layout(rgba32f, binding = 4) uniform writeonly image2D rgb_out;

uniform int u_used;                      // pigments in the active layer
uniform float u_K[4 * NPL * NBANDS];     // absorption of slot k in band c at k * NBANDS + c
uniform float u_S[4 * NPL * NBANDS];     // scattering, same layout
uniform float u_white;                   // gouache: share of the white filler
uniform float u_white_K[NBANDS];
uniform float u_white_S[NBANDS];
uniform float u_opaque;
uniform float u_to_rgb[3 * NBANDS];      // row-major (3, NBANDS)

void main() {
    ivec2 c = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(c)) return;
    float r_prev[4 * NRL];
    for (int l = 0; l < NRL; ++l) {
        vec4 v = imageLoad(rcomp_in, ivec3(c, l));
        for (int j = 0; j < 4; ++j) r_prev[4 * l + j] = v[j];
    }
    float amount[4 * NPL];
    float d = 0.0;
    for (int l = 0; l < NPL; ++l) {
        vec4 a = imageLoad(pig_in, ivec3(c, l)) + imageLoad(dep_in, ivec3(c, l));
        for (int k = 0; k < 4; ++k) {
            amount[4 * l + k] = a[k];
            if (4 * l + k < u_used) d += a[k];
        }
    }
    float safe_d = d > 0.0 ? d : 1.0;
    float band[NBANDS];
    for (int ch = 0; ch < NBANDS; ++ch) {
        if (u_used == 0) {
            band[ch] = clamp(r_prev[ch], 0.0, 1.0);
            continue;
        }
        float K = 0.0, S = 0.0;
        for (int k = 0; k < u_used; ++k) {
            float s = amount[k] / safe_d;
            K += s * u_K[k * NBANDS + ch];
            S += s * u_S[k * NBANDS + ch];
        }
#ifdef RENDER_KM
        S = max(S, 1e-12);
        float a = (S + K) / S;
        float b = sqrt(max(a * a - 1.0, 0.0));
        float sd = S * safe_d;
        float r, tr;
        if (b < 1e-4) {
            r = sd / (1.0 + sd);
            tr = 1.0 / (1.0 + sd);
        } else {
            float t = min(b * S * safe_d, 30.0);
            float sh = sinh_acc(t), chh = cosh_acc(t);
            float den = a * sh + b * chh;
            r = sh / den;
            tr = b / den;
        }
        float total = r + tr * tr * r_prev[ch] / (1.0 - r * r_prev[ch]);
        band[ch] = clamp(d > 0.0 ? total : r_prev[ch], 0.0, 1.0);
#else
        // body colour: R_inf of the KM mix with an implicit white filler of share u_white
        K = (1.0 - u_white) * K + u_white * u_white_K[ch];
        S = (1.0 - u_white) * S + u_white * u_white_S[ch];
        float a = (S + K) / max(S, 1e-12);
        float colour = a - sqrt(max(a * a - 1.0, 0.0));
        float o = clamp(d / u_opaque, 0.0, 1.0);
        band[ch] = clamp(o * colour + (1.0 - o) * r_prev[ch], 0.0, 1.0);
#endif
    }
    vec3 out_rgb;
#if NBANDS == 3
    out_rgb = vec3(band[0], band[1], band[2]);
#else
    for (int i = 0; i < 3; ++i) {
        float acc = 0.0;
        for (int j = 0; j < NBANDS; ++j) acc += u_to_rgb[i * NBANDS + j] * band[j];
        out_rgb[i] = acc;
    }
#endif
    imageStore(rgb_out, c, vec4(clamp(out_rgb, 0.0, 1.0), 1.0));
}
