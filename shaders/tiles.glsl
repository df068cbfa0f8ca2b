// tiles.glsl: the work of a pass is a list of dirty tiles (TILE x TILE cells).
// Dispatch: (ceil(TILE/LX), ceil(TILE/LY), number of list entries), indirect when the
// list is built on the GPU (tile_list.comp).  An entry is a tile index; bit 31 set marks
// a HALO entry: a tile that is not active itself but borders an active one, of which only
// the cells within two cells of an active tile (the reference's halo, tiles.HALO) are
// simulated.  Tiling off is the same dispatch over the list of all tiles, none HALO.

layout(local_size_x = LX, local_size_y = LY) in;

layout(std430, binding = 0) readonly buffer TileList { uint tile_list[]; };
layout(std430, binding = 2) readonly buffer TileTTLr { int tile_ttl_r[]; };

uniform int u_tiles_x;  // tiles per row
uniform int u_tiles_y;  // tile rows

const uint HALO_BIT = 0x80000000u;

bool tile_active(int tx, int ty) {
    return tx >= 0 && ty >= 0 && tx < u_tiles_x && ty < u_tiles_y
        && tile_ttl_r[ty * u_tiles_x + tx] > 0;
}

// Is a cell of an active tile within two cells (Chebyshev) of c?  (tiles.HALO: a dry cell
// can join the wet area, absorb and pass capillary water one cell further in one step.)
bool near_active(ivec2 c) {
    ivec2 lo = max(c - 2, ivec2(0)) / TILE;
    ivec2 hi = min(c + 2, u_size - 1) / TILE;
    for (int ty = lo.y; ty <= hi.y; ++ty)
        for (int tx = lo.x; tx <= hi.x; ++tx)
            if (tile_active(tx, ty)) return true;
    return false;
}

// Cell of this invocation; valid is false past the tile or the canvas edge, and for
// cells of a HALO tile that are not in the halo.
ivec2 tile_cell(out bool valid) {
    uint entry = tile_list[gl_WorkGroupID.z];
    uint t = entry & ~HALO_BIT;
    ivec2 origin = ivec2(int(t % uint(u_tiles_x)), int(t / uint(u_tiles_x))) * TILE;
    ivec2 local = ivec2(gl_WorkGroupID.xy * gl_WorkGroupSize.xy + gl_LocalInvocationID.xy);
    ivec2 c = origin + local;
    valid = all(lessThan(local, ivec2(TILE))) && inside(c);
    if (valid && (entry & HALO_BIT) != 0u) valid = near_active(c);
    return c;
}

uint tile_of_group() { return tile_list[gl_WorkGroupID.z] & ~HALO_BIT; }
