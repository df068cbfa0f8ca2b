// advect.glsl: face quantities of pass 6 (advect_water_and_pigment), shared by
// advect_limit.comp and advect_apply.comp.  Needs images vel_in and aux_in.

// Face velocity between c and its neighbour n over face f (E, W, S, N), in the
// reference's sign convention (positive: from the lower-index cell to the higher);
// 0 on closed faces and at the canvas border.
float face_velocity(ivec2 c, int f, bool wet_c, vec2 vc) {
    ivec2 n = c + OFFS[f];
    if (!wet_c || !inside(n) || !aux_wet(imageLoad(aux_in, n))) return 0.0;
    vec2 vn = imageLoad(vel_in, n).xy;
    // reference: 0.5 * (v_lower + v_higher)
    if (f == 0) return 0.5 * (vc.x + vn.x);
    if (f == 1) return 0.5 * (vn.x + vc.x);
    if (f == 2) return 0.5 * (vc.y + vn.y);
    return 0.5 * (vn.y + vc.y);
}

// true when cell c is the donor of face f with face velocity uf
bool donates(int f, float uf) {
    bool lower = (f == 0 || f == 2);
    return lower ? (uf > 0.0) : !(uf > 0.0);
}
