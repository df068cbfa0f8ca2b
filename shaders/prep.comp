#version 430
// prep.comp: once per step, after the sources.  Reference: wet_mask, blocking (diffusion
// controller beta_c) and pass 1 advect_velocity (semi-Lagrangian back-trace, bilinear).
// Writes aux = v1 (the right-hand side of the velocity diffusion) and the first Jacobi
// iterate jv = (v1x, v1y, w, wb), wb = beta_c on wet cells, -1 elsewhere.
#include "common.glsl"
#include "tiles.glsl"

layout(rg32f, binding = 1) uniform readonly image2D vel_in;
layout(rgba32f, binding = 2) uniform readonly image2D water_in;
layout(rgba32f, binding = 3) uniform readonly image2D paper_in;
layout(rg32f, binding = 4) uniform writeonly image2D aux_out;
layout(rgba32f, binding = 5) uniform writeonly image2D jv_out;

uniform float u_dt;
uniform float u_moist;        // moist_threshold [height]
uniform float u_sim_time;     // [s]
uniform float u_block_fade;   // [s]
uniform float u_block_paper;  // share of paper height in the blocking value

bool wet_at(ivec2 c) {
    vec4 wa = imageLoad(water_in, c);
    float mask = imageLoad(paper_in, c).y;
    return (wa.x > 0.0 || wa.y > u_moist) && mask == 0.0;
}

// velocity of the advected source field vs = v * wet
vec2 vs_at(ivec2 c) {
    return wet_at(c) ? imageLoad(vel_in, c).xy : vec2(0.0);
}

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (!valid) return;
    vec4 pa = imageLoad(paper_in, c);
    vec4 wa = imageLoad(water_in, c);
    bool wet = (wa.x > 0.0 || wa.y > u_moist) && pa.y == 0.0;
    // diffusion controller: beta_c = min(1 - block_paper (1 - h), block_eff)
    float age = u_block_fade > 0.0 ? clamp((u_sim_time - pa.w) / u_block_fade, 0.0, 1.0) : 1.0;
    float eff = pa.z + (1.0 - pa.z) * age;
    float beta_c = min(1.0 - u_block_paper * (1.0 - pa.x), eff);
    vec2 v1 = vec2(0.0);
    if (wet) {
        vec2 v = imageLoad(vel_in, c).xy;
        float bx = clamp(float(c.x) - v.x * u_dt, 0.0, float(u_size.x - 1));
        float by = clamp(float(c.y) - v.y * u_dt, 0.0, float(u_size.y - 1));
        int x0 = min(int(floor(bx)), max(u_size.x - 2, 0));
        int y0 = min(int(floor(by)), max(u_size.y - 2, 0));
        int x1 = min(x0 + 1, u_size.x - 1);
        int y1 = min(y0 + 1, u_size.y - 1);
        float fx = bx - float(x0);
        float fy = by - float(y0);
        vec2 top = (1.0 - fx) * vs_at(ivec2(x0, y0)) + fx * vs_at(ivec2(x1, y0));
        vec2 bot = (1.0 - fx) * vs_at(ivec2(x0, y1)) + fx * vs_at(ivec2(x1, y1));
        v1 = (1.0 - fy) * top + fy * bot;
    }
    imageStore(aux_out, c, vec4(v1, 0.0, 0.0));
    imageStore(jv_out, c, vec4(v1, wa.x, wet ? max(beta_c, 0.0) : -1.0));
}
