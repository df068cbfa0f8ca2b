#version 430
// tile_update.comp: after the step (reference tiles.update_tiles): active TTLs count
// down; a tile whose TTL ran out (or a quiet halo tile) that still holds water
// (flagged by capillary_dry.comp) is renewed with the drying-time estimate.
layout(local_size_x = 64) in;

layout(std430, binding = 1) buffer TileAlive { uint tile_alive[]; };
layout(std430, binding = 2) buffer TileTTL { int tile_ttl[]; };

uniform int u_ntiles;
uniform int u_ttl;  // SimParams.tile_ttl_steps()

void main() {
    int t = int(gl_GlobalInvocationID.x);
    if (t >= u_ntiles) return;
    int ttl = tile_ttl[t];
    if (ttl > 0) ttl -= 1;
    if (tile_alive[t] != 0u && ttl <= 0) ttl = u_ttl;
    tile_ttl[t] = ttl;
    tile_alive[t] = 0u;
}
