#version 430
// Deformable brush footprint: the lowest point of a bristle tube over this cell.
// Same formulas as footprint._raster (the NumPy/numba reference); the blend
// equation is MAX, so cover and depth are the maxima over all tubes.
// CLIP_ABOVE (define): the back clip plane's height above the canvas, cells.

flat in vec3 a;
flat in vec3 b;

uniform vec2 origin;
uniform float radius;

out vec4 result;  // (cover, depth below the plane, 0, 0)

void main() {
    vec2 c = origin + gl_FragCoord.xy;  // cell centre (pixel centres are at .5)
    vec2 e = b.xy - a.xy;
    float ll = dot(e, e);
    float tau = 0.0;
    if (ll > 1e-12) {
        tau = clamp(dot(c - a.xy, e) / ll, 0.0, 1.0);
    }
    vec2 q = a.xy + tau * e - c;
    float d2 = dot(q, q);
    float d = sqrt(d2);
    float cover = clamp(radius - d + 0.5, 0.0, 1.0);
    if (cover <= 0.0) {
        discard;
    }
    float zl = a.z + tau * (b.z - a.z) - sqrt(max(radius * radius - d2, 0.0));
    if (zl > CLIP_ABOVE) {
        discard;
    }
    result = vec4(cover, -zl, 0.0, 0.0);
}
