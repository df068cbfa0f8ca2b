// common.glsl: constants, canvas geometry and pigment packing shared by every canvas pass.
// Conventions: cell (row i, column j) is texel ivec2(j, i); "E/W" neighbours are x +/- 1,
// "S/N" neighbours y +/- 1 (the reference's order E, W, S, N is kept in every sum).
// Cells outside the canvas are non-wet with zero water, velocity and pigment.
// Injected by Python: NPL (RGBA layers of pigment = slots / 4), TILE, LX, LY, SIZE_X, SIZE_Y.
// Pigment: layer l of a pigment texture array holds slots 4l .. 4l+3; loops run over
// l < NPL (unrolled) and skip layers >= u_layers, which hold no pigment yet.

// canvas width, height [cells]: compile-time (SIZE_X, SIZE_Y), fixed per allocation; on
// llvmpipe a uniform is a load in every vector of lanes, and every pass reads the size
const ivec2 u_size = ivec2(SIZE_X, SIZE_Y);
uniform int u_layers;   // pigment layers in use (ceil(used slots / 4))
// Whether pigment layer l is processed: layer 0 always (a layer without pigment computes
// zeros), so with one layer (NPL 1) no pass reads the uniform: on llvmpipe each uniform
// read is a load in every vector of lanes.
bool layer_used(int l) { return l == 0 || l < u_layers; }

// The step's parameters: those that do not depend on dt are constants (K_*, exact float32
// bits, passes.param_constants); those that do are constants too for the parameters' own
// dt (DT_CONST 1, every caller's case), uniforms of the same name when a step is given
// another dt.  On llvmpipe each uniform a pass reads is a load in every vector of lanes.
#if DT_CONST
#define STEP_CONST(type, name, value) const type name = value
#else
#define STEP_CONST(type, name, value) uniform type name
#endif

const ivec2 OFF_E = ivec2(1, 0);
const ivec2 OFF_W = ivec2(-1, 0);
const ivec2 OFF_S = ivec2(0, 1);
const ivec2 OFF_N = ivec2(0, -1);
const ivec2 OFFS[4] = ivec2[4](OFF_E, OFF_W, OFF_S, OFF_N);

bool inside(ivec2 c) {
    return all(greaterThanEqual(c, ivec2(0))) && all(lessThan(c, u_size));
}

// c is the lower-index cell of its E and S faces (the reference's flux sign convention)
bool lower_side(int f) { return f == 0 || f == 2; }

// The .w channel of the jv scratch texture: beta_c of the diffusion controller for a
// wet cell, -1 for a cell that is not wet this step (wet is fixed once per step).
bool is_wet(float wb) { return wb >= 0.0; }
