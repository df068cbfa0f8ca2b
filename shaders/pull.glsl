// pull.glsl: pass 3's flow-outward pull per unit flow_outward at the dry share u = 1 - M'
// of the blurred neighbourhood (reference stencils.outward_pull), for pressure.glsl and
// front.comp: u, or with rim_sharpness k > 0 (1 - k) u + k min(max((u - onset) inv, 0), 1),
// the share of the pull cut to the cells next to the contact line whatever the stroke's
// width (K_RIMK, K_RIMI, K_RIMA, K_RIMINV: SimParams.rim_profile's float32 bits).
float outward_pull(float u) {
    const float rk = K_RIMK;
    if (rk > 0.0) {
        float s = min(max((u - K_RIMA) * K_RIMINV, 0.0), 1.0);
        return K_RIMI * u + rk * s;
    }
    return u;
}
