#version 430
// sources.comp: spec step 1 / reference operations.add_sources on the rectangle
// [u_origin, u_origin + u_extent): unmasked cells get w <- max(min(w + dw, w_max), w),
// p <- max(min(p + dp, 1), p), v <- clamp(v + dv, -v_max, v_max) (where dv is given).
// What was actually added is summed per work group in double precision into the
// bookkeeping buffer (one slot of 1 + 4 NPL doubles per work group; each dispatch's
// groups own distinct slots, so no atomics are needed).
#include "common.glsl"

layout(local_size_x = 16, local_size_y = 16) in;

layout(rgba32f, binding = 1) uniform readonly image2D srcw_in;       // dw, dvx, dvy, flags
layout(rgba32f, binding = 2) uniform readonly image2DArray srcp_in;  // dp per slot
layout(rgba32f, binding = 3) uniform image2D water_io;
layout(rgba32f, binding = 4) uniform image2DArray pig_io;
layout(rg32f, binding = 5) uniform image2D vel_io;
layout(rgba32f, binding = 6) uniform readonly image2D paper_in;

layout(std430, binding = 5) buffer Added { double added[]; };

uniform ivec2 u_origin;
uniform ivec2 u_extent;
uniform float u_wmax;
uniform float u_vmax;
uniform int u_has_dw;
uniform int u_has_dvx;
uniform int u_has_dvy;
uniform int u_has_dp;

#define NACC (1 + 4 * NPL)
#define NINV (16 * 16)
shared double red[NINV];

void main() {
    ivec2 local = ivec2(gl_GlobalInvocationID.xy);
    ivec2 c = u_origin + local;
    bool valid = all(lessThan(local, u_extent)) && inside(c);
    float add_w = 0.0;
    vec4 add_p[NPL];
    for (int l = 0; l < NPL; ++l) add_p[l] = vec4(0.0);
    if (valid && imageLoad(paper_in, c).y == 0.0) {
        vec4 s = imageLoad(srcw_in, local);
        if (u_has_dw != 0) {
            vec4 wa = imageLoad(water_io, c);
            float after = max(min(wa.x + s.x, u_wmax), wa.x);
            add_w = after - wa.x;
            imageStore(water_io, c, vec4(after, wa.yzw));
        }
        if (u_has_dp != 0) {
            for (int l = 0; l < NPL; ++l) {
                vec4 p = imageLoad(pig_io, ivec3(c, l));
                vec4 after = max(min(p + imageLoad(srcp_in, ivec3(local, l)), 1.0), p);
                add_p[l] = after - p;
                imageStore(pig_io, ivec3(c, l), after);
            }
        }
        if (u_has_dvx != 0 || u_has_dvy != 0) {
            vec2 v = imageLoad(vel_io, c).xy;
            if (u_has_dvx != 0) v.x = clamp(v.x + s.y, -u_vmax, u_vmax);
            if (u_has_dvy != 0) v.y = clamp(v.y + s.z, -u_vmax, u_vmax);
            imageStore(vel_io, c, vec4(v, 0.0, 0.0));
        }
    }
    // booking: tree reduction per accumulated quantity
    uint li = gl_LocalInvocationIndex;
    uint slot = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * uint(NACC);
    for (int q = 0; q < NACC; ++q) {
        float v = q == 0 ? add_w : add_p[(q - 1) / 4][(q - 1) % 4];
        red[li] = double(v);
        barrier();
        for (uint stride = uint(NINV) / 2u; stride > 0u; stride /= 2u) {
            if (li < stride) red[li] += red[li + stride];
            barrier();
        }
        if (li == 0u) added[slot + uint(q)] += red[0];
        barrier();
    }
}
