// common.glsl: constants, canvas geometry and pigment packing shared by every canvas pass.
// Conventions: cell (row i, column j) is texel ivec2(j, i); "E/W" neighbours are x +/- 1,
// "S/N" neighbours y +/- 1 (the reference's order E, W, S, N is kept in every sum).
// Cells outside the canvas are non-wet with zero water, velocity and pigment.
// Injected by Python: NPL (RGBA layers of pigment = slots / 4), TILE, LX, LY.

uniform ivec2 u_size;  // canvas width, height [cells]

const ivec2 OFF_E = ivec2(1, 0);
const ivec2 OFF_W = ivec2(-1, 0);
const ivec2 OFF_S = ivec2(0, 1);
const ivec2 OFF_N = ivec2(0, -1);
const ivec2 OFFS[4] = ivec2[4](OFF_E, OFF_W, OFF_S, OFF_N);

bool inside(ivec2 c) {
    return all(greaterThanEqual(c, ivec2(0))) && all(lessThan(c, u_size));
}

// One cell's pigment: NPL RGBA vectors, 4 slots each.
#define PIG vec4[NPL]

// The aux texture written by prep.comp once per step: x = wet (1/0), y = beta_c of the
// diffusion controller, zw = self-advected velocity v1.
bool aux_wet(vec4 a) { return a.x > 0.5; }
