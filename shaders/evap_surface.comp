#version 430
// evap_surface.comp: three point-wise passes fused (each needs only this cell's values,
// except the evaporation's count of dry neighbours):
//   pass 7 evaporate: loss = min(w, e + edge_evap n_dry w e), e = eps_shallow dt, n_dry =
//          4-neighbours without fluid water (the canvas border counts as dry);
//   pass 8 surface_exchange (wet cells): deposition/lifting with granulation, density and
//          staining per slot;
//   pass 9a capillary absorption: d = min(alpha dt, w, c - wc) on open cells with w > 0.
// pig and dep are updated in place (point-wise); water goes to water_out.
#include "common.glsl"
#include "tiles.glsl"

layout(rgba32f, binding = 1) uniform readonly image2D water_in;
layout(rgba32f, binding = 2) uniform writeonly image2D water_out;
layout(rgba32f, binding = 3) uniform image2DArray pig_io;
layout(rgba32f, binding = 4) uniform image2DArray dep_io;
layout(rgba32f, binding = 5) uniform readonly image2D paper_in;
layout(rgba32f, binding = 6) uniform readonly image2D wet_in;  // .w = wb

STEP_CONST(float, u_e, K_E);          // float32(eps_shallow * dt)
const float u_edge_evap = K_EDGE_EVAP;  // float32(edge_evap)
const float u_wmax = K_WMAX;
STEP_CONST(float, u_rate, K_RATE);       // float32(surface_rate * dt)
#if SLOT_CONST
// the pigment slots' values as constants (K_GAMMA, K_DELTA, K_DOB: their exact float32 bits;
// GLCanvas.slot_constants, a CPU rasterizer's choice: there each uniform component is a
// load per vector of lanes, these 12 about 3 ms of an 800x600 pass; the program is
// recompiled when a slot's pigment changes)
const vec4 u_gamma[NPL] = K_GAMMA;
const vec4 u_delta[NPL] = K_DELTA;
const vec4 u_dob[NPL] = K_DOB;
#else
uniform vec4 u_gamma[NPL];  // granulation per slot
uniform vec4 u_delta[NPL];  // density per slot (0 for free slots)
uniform vec4 u_dob[NPL];    // float32(delta / beta) per slot, beta = float32(staining / lift_gain)
#endif
STEP_CONST(float, u_absorb, K_ABSORB);     // float32(alpha * dt)
const float u_cmin = K_CMIN;
const float u_crange = K_CRANGE;     // float32(c_max - c_min)

void main() {
    bool valid;
    ivec2 c = tile_cell(valid);
    if (!valid) return;
    vec4 wa = imageLoad(water_in, c);
    vec4 pa = imageLoad(paper_in, c);
    bool wet = is_wet(imageLoad(wet_in, c).w);
    float w = wa.x, wc = wa.y, evap = wa.z;
    float h = pa.x;
    // pass 7
    if (w > 0.0) {
        float n_dry = 0.0;
        for (int f = 0; f < 4; ++f) {
            ivec2 n = c + OFFS[f];
            float wn = imageLoad(water_in, clamp(n, ivec2(0), u_size - 1)).x;
            n_dry += (!inside(n) || !(wn > 0.0)) ? 1.0 : 0.0;
        }
        float loss = min(u_e + u_edge_evap * n_dry * w * u_e, w);
        w = w - loss;
        evap = evap + loss;
    }
    // pass 8
    if (wet) {
        float f = clamp(w / u_wmax, 0.0, 1.0);
        for (int l = 0; l < NPL; ++l) {
            if (!layer_used(l)) continue;
            vec4 p = imageLoad(pig_io, ivec3(c, l));
            vec4 q = imageLoad(dep_io, ivec3(c, l));
            vec4 down = u_rate * p * (1.0 - f) * (1.0 - h * u_gamma[l]) * u_delta[l];
            vec4 up = u_rate * q * f * (1.0 - (1.0 - h) * u_gamma[l]) * u_dob[l];
            down = min(min(down, p), 1.0 - q);
            up = min(min(up, q), 1.0 - p);
            vec4 net = down - up;
            imageStore(pig_io, ivec3(c, l), p - net);
            imageStore(dep_io, ivec3(c, l), q + net);
        }
    }
    // pass 9a
    if (w > 0.0 && pa.y == 0.0) {
        float cap = u_cmin + h * u_crange;
        float d = min(min(u_absorb, w), max(cap - wc, 0.0));
        w = w - d;
        wc = wc + d;
    }
    imageStore(water_out, c, vec4(w, wc, evap, wa.w));
}
