#version 430
// tile_list.comp: builds this step's dispatch list on the GPU (no read-back).
// A tile is dispatched when a tile in its 3x3 neighbourhood is active (TTL > 0: the
// active tiles plus every tile holding their one-cell halo), or when it was dispatched
// for that reason in the previous step: that one extra step rewrites both textures of
// every ping-pong pair in a tile that just left the set (an inactive cell with inactive
// neighbours is a fixed point of every pass), so tiles outside the list always hold the
// same values in both.
layout(local_size_x = 64) in;

layout(std430, binding = 0) writeonly buffer TileList { uint tile_list[]; };
layout(std430, binding = 2) buffer TileTTL { int tile_ttl[]; };
layout(std430, binding = 3) buffer TileNear { uint tile_near[]; };  // near-active last step
layout(std430, binding = 4) buffer Args { uint groups[3]; uint cells; };

uniform ivec2 u_tiles;  // tiles per row, rows
uniform ivec2 u_size;

void main() {
    int t = int(gl_GlobalInvocationID.x);
    if (t >= u_tiles.x * u_tiles.y) return;
    ivec2 tc = ivec2(t % u_tiles.x, t / u_tiles.x);
    bool near = false;
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 n = tc + ivec2(dx, dy);
            if (all(greaterThanEqual(n, ivec2(0))) && all(lessThan(n, u_tiles))
                && tile_ttl[n.y * u_tiles.x + n.x] > 0)
                near = true;
        }
    bool dispatch = near || tile_near[t] != 0u;
    tile_near[t] = near ? 1u : 0u;
    if (dispatch) {
        uint i = atomicAdd(groups[2], 1u);
        tile_list[i] = uint(t);
        ivec2 lo = tc * TILE;
        ivec2 hi = min(lo + TILE, u_size);
        atomicAdd(cells, uint((hi.x - lo.x) * (hi.y - lo.y)));
    }
}
