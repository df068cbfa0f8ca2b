// tiles.glsl: the work of a pass is a list of dirty tiles (TILE x TILE cells).
// Dispatch: (ceil(TILE/LX), ceil(TILE/LY), number of tiles in the list), usually
// indirect, the z count written by tile_list.comp on the GPU.  Tiling off is the
// same dispatch over the list of all tiles.

layout(local_size_x = LX, local_size_y = LY) in;

layout(std430, binding = 0) readonly buffer TileList { uint tile_list[]; };

uniform int u_tiles_x;  // tiles per row

ivec2 tile_origin() {
    uint t = tile_list[gl_WorkGroupID.z];
    return ivec2(int(t % uint(u_tiles_x)), int(t / uint(u_tiles_x))) * TILE;
}

// Cell of this invocation; *valid is false past the tile or the canvas edge.
ivec2 tile_cell(out bool valid) {
    ivec2 local = ivec2(gl_WorkGroupID.xy * gl_WorkGroupSize.xy + gl_LocalInvocationID.xy);
    ivec2 c = tile_origin() + local;
    valid = all(lessThan(local, ivec2(TILE))) && inside(c);
    return c;
}
