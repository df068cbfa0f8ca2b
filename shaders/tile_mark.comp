#version 430
// tile_mark.comp: sources touched tiles [lo, hi) (reference tiles.mark_cells):
// TTL = max(TTL, drying-time estimate).
layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, binding = 2) buffer TileTTL { int tile_ttl[]; };

uniform ivec2 u_lo;
uniform ivec2 u_hi;
uniform int u_tiles_x;
uniform int u_ttl;

void main() {
    ivec2 t = u_lo + ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(t, u_hi))) return;
    int i = t.y * u_tiles_x + t.x;
    tile_ttl[i] = max(tile_ttl[i], u_ttl);
}
