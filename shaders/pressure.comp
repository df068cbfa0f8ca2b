#version 430
// pressure.comp: once per step, after prep.  Reference: flow_pressure (pass 3's levelled
// height): P = (w + relief h) - eta (1 - M') on wet cells, w elsewhere (the free surface
// over the paper's relief; Curtis 1997's flow outward; terms with a 0 parameter left out),
// M' the own wet area ((w > 0 or wc > moist) and unmasked; 0 outside the canvas; with
// wet_hold > 0 the wet-area mask wet_area that prep.comp updated) blurred with the Gaussian
// taps along x, then along y, in the reference's order (stencils.blurred_wet).
// Reads the state textures (valid on every cell), so it does not depend on the tiles.
//
// The blur is separable and goes through shared memory (a (2R+1)^2 loop of image loads
// per cell, 225 at wet_blur 3.5, was 55 % of llvmpipe's step): the work group stages the
// mask of its LX x LY cells and an R-cell apron; invocations blur runs of RUN staged cells
// along x (2R + RUN reads for RUN sums, in registers: NTAPS is compiled in), then runs of
// RUN cells of a column along y; each cell then finishes its own P.  Every sum keeps the
// reference's order (offset -R first).  Shared memory at 32 x 8 and R = 7: 2.0 + 3.0 + 1.0
// KiB (GL 4.3 guarantees 32 KiB; R <= 8 fits any LX, LY <= 32).  Every invocation reaches
// the three barriers (cells past the tile or the canvas edge, and HALO cells out of the
// halo, take part but store nothing).
#include "common.glsl"
#include "tiles.glsl"

layout(rgba32f, binding = 1) uniform readonly image2D water_in;
layout(rgba32f, binding = 2) uniform readonly image2D paper_in;
layout(rgba32f, binding = 3) uniform readonly image2D jv_in;
layout(r32f, binding = 4) uniform writeonly image2D pr_out;
layout(r32f, binding = 5) uniform readonly image2D area_in;  // wet_area after prep

// NTAPS (2R + 1) is injected with the other defines; the program is compiled once per blur
// width.  NTAPS 1: no flow-outward term (flow_outward or wet_blur 0), nothing is blurred.
#define R ((NTAPS - 1) / 2)
#define RUN 8
#define RUNS_X ((LX + RUN - 1) / RUN)      // runs per staged row
#define RUNS_Y ((LY + RUN - 1) / RUN)      // runs per column
#define SW (RUNS_X * RUN + 2 * R)          // staged row stride (whole runs fit)
#define SH (RUNS_Y * RUN + 2 * R)          // staged rows (whole runs fit)
uniform float u_moist;           // moist_threshold [height]
uniform float u_eta;             // flow_outward [height]
uniform float u_relief;          // paper_relief [height]
uniform int u_hold;              // wet_hold > 0: blur the wet-area mask M (prep wrote it)
uniform float u_taps[NTAPS];     // float32 Gaussian taps, offset -R first

#if NTAPS > 1
shared float s_mask[SW * SH];               // the mask of the group's cells and their apron
shared float s_row[RUNS_X * RUN * SH];      // staged rows blurred along x
shared float s_blur[RUNS_X * RUN * RUNS_Y * RUN];  // M' of the group's cells

float own_wet(ivec2 c) {
    if (!inside(c)) return 0.0;
    if (u_hold != 0) return imageLoad(area_in, c).x;  // M = max(wet_area, own), from prep
    vec4 wa = imageLoad(water_in, c);
    return ((wa.x > 0.0 || wa.y > u_moist) && imageLoad(paper_in, c).y == 0.0) ? 1.0 : 0.0;
}

// M' at this invocation's cell (every invocation calls it: it holds the barriers)
float blurred_mask() {
    const int n = LX * LY;
    const int rw = RUNS_X * RUN;  // s_row's stride
    int lid = int(gl_LocalInvocationIndex);
    uint t = tile_list[gl_WorkGroupID.z] & ~HALO_BIT;
    ivec2 corner = ivec2(int(t % uint(u_tiles_x)), int(t / uint(u_tiles_x))) * TILE
        + ivec2(gl_WorkGroupID.xy * gl_WorkGroupSize.xy) - ivec2(R);
    for (int k = lid; k < SW * SH; k += n) {
        int y = k / SW;
        int x = k - y * SW;
        s_mask[k] = own_wet(corner + ivec2(x, y));
    }
    memoryBarrierShared();
    barrier();
    for (int k = lid; k < RUNS_X * SH; k += n) {  // one run of RUN sums along x
        int y = k / RUNS_X;
        int x0 = (k - y * RUNS_X) * RUN;
        float v[RUN + 2 * R];
        for (int i = 0; i < RUN + 2 * R; ++i) v[i] = s_mask[y * SW + x0 + i];
        for (int j = 0; j < RUN; ++j) {
            float row = 0.0;
            for (int kx = 0; kx < NTAPS; ++kx) row += u_taps[kx] * v[j + kx];
            s_row[y * rw + x0 + j] = row;
        }
    }
    memoryBarrierShared();
    barrier();
    for (int k = lid; k < rw * RUNS_Y; k += n) {  // one run of RUN sums down a column
        int ry = k / rw;
        int x = k - ry * rw;
        int y0 = ry * RUN;
        float v[RUN + 2 * R];
        for (int i = 0; i < RUN + 2 * R; ++i) v[i] = s_row[(y0 + i) * rw + x];
        for (int j = 0; j < RUN; ++j) {
            float acc = 0.0;
            for (int ky = 0; ky < NTAPS; ++ky) acc += u_taps[ky] * v[j + ky];
            s_blur[(y0 + j) * rw + x] = acc;
        }
    }
    memoryBarrierShared();
    barrier();
    ivec2 l = ivec2(gl_LocalInvocationID.xy);
    return s_blur[l.y * rw + l.x];
}
#endif

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
#if NTAPS > 1
    float mb = blurred_mask();
#endif
    if (!valid) return;
    float w = imageLoad(water_in, c).x;
    bool wet = is_wet(imageLoad(jv_in, c).w);
    float p = w;
    if (wet && u_relief > 0.0) p = w + u_relief * imageLoad(paper_in, c).x;
#if NTAPS > 1
    if (wet) p = p - u_eta * (1.0 - mb);
#endif
    imageStore(pr_out, c, vec4(p, 0.0, 0.0, 0.0));
}
