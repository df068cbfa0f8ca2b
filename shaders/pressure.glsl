// pressure.glsl: pass 3's levelled height, formed in the step's first Jacobi iteration
// (jacobi.comp with FIRST_ITER), after prep and blur_x.  Reference: flow_pressure:
// P = (w + relief h) - eta outward_pull(1 - M') (pull.glsl) on wet cells, w elsewhere (the
// free surface over the paper's relief; Curtis 1997's flow outward; terms with a 0
// parameter left out), M' the own wet area blurred with the Gaussian taps along x (blur_x.comp wrote bx), then along y
// here, in the reference's order (stencils.blurred_wet: rows outside the canvas add
// taps[k] * 0).
// A separable blur: 2 (2R + 1) image loads per cell, not the (2R + 1)^2 of a 2-D loop
// (225 at wet_blur 3.5, 55 % of llvmpipe's wash step).
// Needs paper_in and, with NTAPS > 1, bx_in declared by the includer.

// NTAPS (2R + 1) and TAPS (the float32 Gaussian taps, offset -R first, as an array
// constructor of their exact bits) are injected with the other defines (compiled per blur);
// NTAPS 1: no flow-outward term (flow_outward or wet_blur 0), nothing is blurred.
#include "pull.glsl"
#define R ((NTAPS - 1) / 2)
const float u_eta = K_ETA;             // flow_outward [height]
const float u_relief = K_RELIEF;          // paper_relief [height]
const float taps_y[NTAPS] = TAPS;

float levelled_height(ivec2 c, float w, bool wet) {
    float p = w;
    if (wet && u_relief > 0.0) p = w + u_relief * imageLoad(paper_in, c).x;
#if NTAPS > 1
    if (wet) {
        float acc = 0.0;
        for (int ky = 0; ky < NTAPS; ++ky) {
            // a row outside the canvas is an invalid image load, which GL defines to
            // return 0: it adds taps[k] * 0, as the reference's zero padding does
            acc += taps_y[ky] * imageLoad(bx_in, ivec2(c.x, c.y + ky - R)).x;
        }
        p = p - u_eta * outward_pull(1.0 - acc);
    }
#endif
    return p;
}
