// tiles.glsl: the work of a pass is a list of dirty tiles (TILE x TILE cells).
// Dispatch: (ceil(TILE/LX), ceil(TILE/LY), number of list entries), indirect when the
// list is built on the GPU (tile_list.comp).  An entry is a tile index (bits 0-22); bit 31
// set marks a HALO entry: a tile that is not active itself but borders an active one, of
// which only the cells within two cells of an active tile (the reference's halo,
// tiles.HALO) are simulated; its bits 23-30 flag its active neighbours (E, W, S, N, NE, SE,
// NW, SW).  Tiling off is the same dispatch over the list of all tiles, none HALO.
// TILES_X (tiles per row) is a define: a division by a uniform is a scalar division per
// lane on llvmpipe, in every pass.

layout(local_size_x = LX, local_size_y = LY) in;

// TILE_LIST (a define, 1 while tiling is on): the dispatch's z indexes the tile list.  With
// tiling off the list would be the identity, so z is the tile index itself: on llvmpipe the
// list's SSBO load is a gather in every lane of every pass (about 0.9 ms of a 2.2 ms empty
// pass at 800x600), while gl_WorkGroupID is the same scalar for the whole group.
#if TILE_LIST
layout(std430, binding = 0) readonly buffer TileList { uint tile_list[]; };
uint tile_entry() { return tile_list[gl_WorkGroupID.z]; }
#else
uint tile_entry() { return gl_WorkGroupID.z; }
#endif

const uint HALO_BIT = 0x80000000u;
const uint TILE_INDEX = 0x007FFFFFu;

// Is a cell of an active tile within two cells (Chebyshev) of the cell at `local` in a HALO
// tile whose active neighbours are `entry`'s bits 23-30?  (tiles.HALO: a dry cell can join
// the wet area, absorb and pass capillary water one cell further in one step.)  TILE >= 4
// (params), so the 5 x 5 box around a cell reaches the eight neighbours at most.  No loads:
// llvmpipe runs a branch's code for every lane, so this runs in every pass for every cell.
bool near_active(ivec2 local, uint entry) {
    bool e = local.x + 2 >= TILE, w = local.x < 2, s = local.y + 2 >= TILE, n = local.y < 2;
    bvec4 side = bvec4(e, w, s, n);
    bvec4 corner = bvec4(e && n, e && s, w && n, w && s);
    uvec4 bit_side = (uvec4(entry) >> uvec4(23, 24, 25, 26)) & 1u;
    uvec4 bit_corner = (uvec4(entry) >> uvec4(27, 28, 29, 30)) & 1u;
    return any(bvec4(uvec4(side) & bit_side)) || any(bvec4(uvec4(corner) & bit_corner));
}

// Cell of this invocation; valid is false past the tile or the canvas edge, and for
// cells of a HALO tile that are not in the halo.
ivec2 tile_cell(out bool valid) {
    uint entry = tile_entry();
    uint t = entry & TILE_INDEX;
    ivec2 origin = ivec2(int(t % uint(TILES_X)), int(t / uint(TILES_X))) * TILE;
    ivec2 local = ivec2(gl_WorkGroupID.xy * gl_WorkGroupSize.xy + gl_LocalInvocationID.xy);
    ivec2 c = origin + local;
    valid = all(lessThan(local, ivec2(TILE))) && inside(c);
#if TILE_LIST
    if (valid && (entry & HALO_BIT) != 0u) valid = near_active(local, entry);
#endif
    return c;
}

uint tile_of_group() { return tile_entry() & TILE_INDEX; }
