#version 430
// Deformable brush footprint: the lowest point of a bristle tube over this cell.
// The blend equation is MAX, so cover and depth are the maxima over all tubes.

#include "brush_tube.glsl"

flat in vec3 a;
flat in vec3 b;

uniform vec2 origin;
uniform float radius;

out vec4 result;  // (cover, depth below the plane, 0, 0)

void main() {
    vec2 c = origin + gl_FragCoord.xy;  // cell centre (pixel centres are at .5)
    float cover;
    float zl;
    if (!tube_low(a, b, c, radius, cover, zl)) {
        discard;
    }
    result = vec4(cover, -zl, 0.0, 0.0);
}
