// advect.glsl: face quantities of pass 6 (advect_water_and_pigment), shared by
// advect_limit.comp and advect_apply.comp.  Needs images vel_in and wet_in (.w = wb).

// Face velocity between c and its neighbour over face f (E, W, S, N): the mean of the
// two cell velocities on open faces, 0 on closed faces and at the canvas border.
float face_velocity(ivec2 c, int f, bool wet_c, vec2 vc) {
    ivec2 n = clamp(c + OFFS[f], ivec2(0), u_size - 1);
    bool open_ = wet_c && inside(c + OFFS[f]) && is_wet(imageLoad(wet_in, n).w);
    vec2 vn = imageLoad(vel_in, n).xy;
    // reference: 0.5 * (v_lower + v_higher) (the sum is commutative, so one form serves)
    float uf = (f < 2) ? 0.5 * (vc.x + vn.x) : 0.5 * (vc.y + vn.y);
    return open_ ? uf : 0.0;
}

// true when cell c is the donor of face f with face velocity uf (positive: from the
// lower-index cell to the higher)
bool donates(int f, float uf) {
    return lower_side(f) ? (uf > 0.0) : !(uf > 0.0);
}
