// The lowest point of a bristle tube over a cell: footprint._raster's formulas
// (the NumPy/numba reference), shared by the footprint's passes so the tag pass
// recomputes bit for bit the depth the cover/depth pass stored.
// CLIP_ABOVE (define): the back clip plane's height above the canvas, cells.

// Cover of the tube at cell centre c and the height zl of its lowest point;
// false where the tube misses the cell or stays above the clip plane.
bool tube_low(vec3 a, vec3 b, vec2 c, float radius, out float cover, out float zl) {
    vec2 e = b.xy - a.xy;
    float ll = dot(e, e);
    float tau = 0.0;
    if (ll > 1e-12) {
        tau = clamp(dot(c - a.xy, e) / ll, 0.0, 1.0);
    }
    vec2 q = a.xy + tau * e - c;
    float d2 = dot(q, q);
    float d = sqrt(d2);
    cover = clamp(radius - d + 0.5, 0.0, 1.0);
    // precise: no contraction (fma) that could differ between the two programs
    precise float z = a.z + tau * (b.z - a.z) - sqrt(max(radius * radius - d2, 0.0));
    zl = z;
    return cover > 0.0 && z <= CLIP_ABOVE;
}
