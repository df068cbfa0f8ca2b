#version 430
// blur_x.comp: once per step, after prep, before the first Jacobi iteration: the first half
// of pass 3's separable blur (reference stencils.blurred_wet): bx = sum_k taps[k] M(x + k -
// R, y), the taps in order (offset -R first), M the own wet area ((w > 0 or wc > moist) and unmasked;
// 0 outside the canvas; with wet_hold > 0 the wet-area mask wet_area that prep.comp
// updated).  pressure.glsl (in jacobi.comp's first iteration) sums bx down the columns.
// Reads the state textures (valid on every cell), so it does not depend on the tiles; with
// u_apron each tile also writes the R rows above and below it (the rows pressure.glsl reads
// around a tile whose neighbour was not dispatched; a neighbour that was writes the same
// values there).  Without tiling every row is its own tile's, so u_apron is 0.
// Two plain passes instead of one through shared memory: llvmpipe runs a program with a
// barrier as coroutines, which cost more than this pass's loads (see docs/gpu.md).
#include "common.glsl"
#include "tiles.glsl"

layout(rgba32f, binding = 1) uniform readonly image2D water_in;
layout(rgba32f, binding = 2) uniform readonly image2D paper_in;
layout(r32f, binding = 4) uniform writeonly image2D bx_out;
layout(r32f, binding = 5) uniform readonly image2D area_in;  // wet_area after prep
#if FRONT_DRY
// standing_front_dry: the not-dry paper (wc >= T c) blurred along x too, for front.comp
layout(r32f, binding = 6) uniform writeonly image2D dx_out;
const float u_fdry = K_FDRY;
const float u_cmin = K_CMIN;
const float u_crange = K_CRANGE;
#endif

// NTAPS (2R + 1 >= 3), TAPS (the float32 Gaussian taps, offset -R first, an array
// constructor of their exact bits: immediates, not a uniform array loaded in every lane) and
// HOLD (1: wet_hold > 0, blur the wet-area mask M that prep wrote) are injected with the
// other defines (compiled per blur and memory)
#define R ((NTAPS - 1) / 2)
const float u_moist = K_MOIST;           // moist_threshold [height]
const int u_apron = TILE_LIST;   // 1: also write the R rows beside the tile (tiling on)
const float taps_x[NTAPS] = TAPS;

// Branch-free (llvmpipe runs both sides of a branch its lanes disagree on); a load past the
// canvas edge is an invalid image load, which GL defines to return 0, and is not used.
float own_wet(ivec2 c) {
#if HOLD
    // M = max(wet_area, own), from prep; past the edge an invalid load's 0
    return imageLoad(area_in, c).x;
#else
    vec4 wa = imageLoad(water_in, c);
    float m = ((wa.x > 0.0 || wa.y > u_moist) && imageLoad(paper_in, c).y == 0.0) ? 1.0 : 0.0;
    return inside(c) ? m : 0.0;
#endif
}

#if FRONT_DRY
// not dry: capillary water at least T of the capacity; 0 outside the canvas (at rest, dry)
float not_dry(ivec2 c) {
    float wc = imageLoad(water_in, c).y;
    float m = wc >= u_fdry * (u_cmin + imageLoad(paper_in, c).x * u_crange) ? 1.0 : 0.0;
    return inside(c) ? m : 0.0;
}
#endif

void blur_row(ivec2 c) {
    float row = 0.0;
    for (int kx = 0; kx < NTAPS; ++kx) row += taps_x[kx] * own_wet(c + ivec2(kx - R, 0));
    imageStore(bx_out, c, vec4(row, 0.0, 0.0, 0.0));
#if FRONT_DRY
    float nd = 0.0;
    for (int kx = 0; kx < NTAPS; ++kx) nd += taps_x[kx] * not_dry(c + ivec2(kx - R, 0));
    imageStore(dx_out, c, vec4(nd, 0.0, 0.0, 0.0));
#endif
}

void main() {
    uint t = tile_of_group();
    ivec2 origin = ivec2(int(t % uint(TILES_X)), int(t / uint(TILES_X))) * TILE;
    ivec2 local = ivec2(gl_WorkGroupID.xy * gl_WorkGroupSize.xy + gl_LocalInvocationID.xy);
    int x = origin.x + local.x;
    if (local.x >= TILE || x >= u_size.x) return;
    // rows origin.y - R .. origin.y + TILE + R - 1 (with the apron), the dispatch's rows
    // apart per invocation (its groups along y times LY; GLCanvas.blur_groups: on a CPU
    // rasterizer a fraction of the tile's rows, so each invocation runs the loop several
    // times and its id and tile mapping once)
    int step = int(gl_NumWorkGroups.y * gl_WorkGroupSize.y);
    int lo = u_apron != 0 ? origin.y - R : origin.y;
    int hi = min(u_apron != 0 ? origin.y + TILE + R : origin.y + TILE, u_size.y);
    for (int y = lo + local.y; y < hi; y += step)
        if (y >= 0) blur_row(ivec2(x, y));
}
