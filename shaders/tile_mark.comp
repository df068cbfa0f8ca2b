#version 430
// tile_mark.comp: tiles in which a source was nonzero (reference tiles.mark_nonzero):
// TTL = max(TTL, drying-time estimate).  The list is uploaded by add_sources.
layout(local_size_x = 64) in;

layout(std430, binding = 2) buffer TileTTL { int tile_ttl[]; };
layout(std430, binding = 6) readonly buffer Marks { uint marks[]; };

uniform int u_count;
uniform int u_ttl;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= uint(u_count)) return;
    uint t = marks[i];
    tile_ttl[t] = max(tile_ttl[t], u_ttl);
}
