#version 430
// fold.comp: reference operations.fold_accumulators, every FOLD_EVERY steps: the per-cell
// evaporated water (water.z) moves into a float64 total: summed per work group in double
// precision into the group's own slot of the Folded buffer, then set to 0 in both
// textures of the water pair (so tiles outside the dispatch list stay equal in both).
#include "common.glsl"

layout(local_size_x = 16, local_size_y = 16) in;

layout(rgba32f, binding = 1) uniform image2D water_a;
layout(rgba32f, binding = 2) uniform image2D water_b;

layout(std430, binding = 7) buffer Folded { double folded[]; };

#define NINV (16 * 16)
shared double red[NINV];

void main() {
    ivec2 c = ivec2(gl_GlobalInvocationID.xy);
    float e = 0.0;
    if (inside(c)) {
        vec4 a = imageLoad(water_a, c);
        vec4 b = imageLoad(water_b, c);
        e = a.z;
        imageStore(water_a, c, vec4(a.xy, 0.0, a.w));
        imageStore(water_b, c, vec4(b.xy, 0.0, b.w));
    }
    uint li = gl_LocalInvocationIndex;
    red[li] = double(e);
    barrier();
    for (uint stride = uint(NINV) / 2u; stride > 0u; stride /= 2u) {
        if (li < stride) red[li] += red[li + stride];
        barrier();
    }
    if (li == 0u) folded[gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x] += red[0];
}
