#version 430
// render.comp: the canvas as linear reflectance (reference render.py).
//   RENDER_KM: Kubelka-Munk per RGB channel over R_composed (t capped at 30; the
//              b -> 0 limit where b < 1e-4);
//   else gouache: opaque blend: body colour R_inf = a - b of the KM mix with an implicit
//              white filler, opacity min(1, d / gouache_opaque).
// NSLOTS_USED (uniform) pigments of the active layer take part.
#include "common.glsl"
#include "sinh.glsl"

layout(local_size_x = 16, local_size_y = 16) in;

layout(rgba32f, binding = 1) uniform readonly image2DArray pig_in;
layout(rgba32f, binding = 2) uniform readonly image2DArray dep_in;
layout(rgba32f, binding = 3) uniform readonly image2D rcomp_in;
layout(rgba32f, binding = 4) uniform writeonly image2D rgb_out;

uniform int u_used;               // pigments in the active layer
uniform vec3 u_K[4 * NPL];        // absorption per slot
uniform vec3 u_S[4 * NPL];        // scattering per slot
uniform float u_white;            // gouache: share of the white filler
uniform vec3 u_white_K;
uniform vec3 u_white_S;
uniform float u_opaque;

void main() {
    ivec2 c = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(c)) return;
    vec3 r_prev = imageLoad(rcomp_in, c).rgb;
    if (u_used == 0) {
        imageStore(rgb_out, c, vec4(r_prev, 1.0));
        return;
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
    vec3 out_rgb;
#ifdef RENDER_KM
    vec3 K = vec3(0.0), S = vec3(0.0);
    for (int k = 0; k < u_used; ++k) {
        float s = amount[k] / safe_d;
        K += s * u_K[k];
        S += s * u_S[k];
    }
    S = max(S, vec3(1e-12));
    vec3 total;
    for (int ch = 0; ch < 3; ++ch) {
        float a = (S[ch] + K[ch]) / S[ch];
        float b = sqrt(max(a * a - 1.0, 0.0));
        float sd = S[ch] * safe_d;
        float r, tr;
        if (b < 1e-4) {
            r = sd / (1.0 + sd);
            tr = 1.0 / (1.0 + sd);
        } else {
            float t = min(b * S[ch] * safe_d, 30.0);
            float sh = sinh_acc(t), chh = cosh_acc(t);
            float den = a * sh + b * chh;
            r = sh / den;
            tr = b / den;
        }
        total[ch] = r + tr * tr * r_prev[ch] / (1.0 - r * r_prev[ch]);
    }
    out_rgb = d > 0.0 ? total : r_prev;
#else
    // body colour: R_inf of the KM mix with an implicit white filler of share u_white
    vec3 K = vec3(0.0), S = vec3(0.0);
    for (int k = 0; k < u_used; ++k) {
        float s = amount[k] / safe_d;
        K += s * u_K[k];
        S += s * u_S[k];
    }
    K = (1.0 - u_white) * K + u_white * u_white_K;
    S = (1.0 - u_white) * S + u_white * u_white_S;
    vec3 a = (S + K) / max(S, vec3(1e-12));
    vec3 colour = a - sqrt(max(a * a - 1.0, vec3(0.0)));
    float o = clamp(d / u_opaque, 0.0, 1.0);
    out_rgb = o * colour + (1.0 - o) * r_prev;
#endif
    imageStore(rgb_out, c, vec4(clamp(out_rgb, 0.0, 1.0), 1.0));
}
