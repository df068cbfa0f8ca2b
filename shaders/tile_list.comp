#version 430
// tile_list.comp: builds this step's dispatch list on the GPU (no read-back).
//   FULL entry: the tile is active (TTL > 0), or was active in the previous step: that one
//     extra step rewrites both textures of every ping-pong pair in a tile that just left
//     the active set (an inactive cell with inactive neighbours is a fixed point of every
//     pass), so tiles outside the list hold the same values in both textures;
//   HALO entry (bit 31): the tile borders an active tile; only its cells within two cells
//     of an active tile are simulated (tiles.glsl).  Bits 23-30 say which of its eight
//     neighbours are active (E, W, S, N, NE, SE, NW, SW), so the passes tell a halo cell
//     with a few compares instead of reading the TTLs of up to nine tiles per cell.  A halo cell that receives capillary
//     water makes its tile alive, and tile_update.comp activates it.
layout(local_size_x = 64) in;

layout(std430, binding = 0) writeonly buffer TileList { uint tile_list[]; };
layout(std430, binding = 2) buffer TileTTL { int tile_ttl[]; };
layout(std430, binding = 3) buffer TilePrev { uint tile_prev[]; };  // active last step
layout(std430, binding = 4) buffer Args { uint groups[3]; uint cells; };

uniform ivec2 u_tiles;  // tiles per row, rows
uniform ivec2 u_size;

const uint HALO_BIT = 0x80000000u;
const ivec2 NB[8] = ivec2[8](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1),
                             ivec2(1, -1), ivec2(1, 1), ivec2(-1, -1), ivec2(-1, 1));

bool act(ivec2 n) {
    return all(greaterThanEqual(n, ivec2(0))) && all(lessThan(n, u_tiles))
        && tile_ttl[n.y * u_tiles.x + n.x] > 0;
}

// Number of cells of tile tc (size sz) within two cells of an active neighbour tile:
// edge strips towards active E/W/S/N tiles, corner cells towards active diagonal ones.
uint halo_cells(ivec2 tc, ivec2 sz) {
    bool e = act(tc + ivec2(1, 0)), w = act(tc + ivec2(-1, 0));
    bool s = act(tc + ivec2(0, 1)), n = act(tc + ivec2(0, -1));
    int count = 2 * ((e ? sz.y : 0) + (w ? sz.y : 0) + (s ? sz.x : 0) + (n ? sz.x : 0));
    count -= 4 * (int(e && n) + int(e && s) + int(w && n) + int(w && s));
    count += 4 * (int(act(tc + ivec2(1, -1)) && !e && !n) + int(act(tc + ivec2(1, 1)) && !e && !s)
           + int(act(tc + ivec2(-1, -1)) && !w && !n) + int(act(tc + ivec2(-1, 1)) && !w && !s));
    return uint(count);
}

void main() {
    int t = int(gl_GlobalInvocationID.x);
    if (t >= u_tiles.x * u_tiles.y) return;
    ivec2 tc = ivec2(t % u_tiles.x, t / u_tiles.x);
    bool is_active = tile_ttl[t] > 0;
    bool near = false;
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 n = tc + ivec2(dx, dy);
            if (all(greaterThanEqual(n, ivec2(0))) && all(lessThan(n, u_tiles))
                && tile_ttl[n.y * u_tiles.x + n.x] > 0)
                near = true;
        }
    bool full = is_active || tile_prev[t] != 0u;
    tile_prev[t] = is_active ? 1u : 0u;
    if (full || near) {
        uint i = atomicAdd(groups[2], 1u);
        uint nbits = 0u;
        for (int k = 0; k < 8; ++k)
            if (act(tc + NB[k])) nbits |= 1u << (23 + k);
        tile_list[i] = uint(t) | (full ? 0u : HALO_BIT | nbits);
        ivec2 lo = tc * TILE;
        ivec2 sz = min(lo + TILE, u_size) - lo;
        atomicAdd(cells, full ? uint(sz.x * sz.y) : halo_cells(tc, sz));
    }
}
