#version 430
// Deformable brush footprint, second pass: which tube is the lowest over this cell.
// The first pass left the deepest depth per cell in `deepest`; a tube whose own
// depth equals it (brush_tube.glsl computes it bit for bit the same) writes its
// instance number, and the blend equation MIN keeps the first such tube: the
// reference's rule (a later segment replaces the tag only when strictly deeper).

#include "brush_tube.glsl"

flat in vec3 a;
flat in vec3 b;
flat in float seg;

uniform vec2 origin;
uniform float radius;
uniform sampler2D deepest;  // R: cover, G: depth below the plane (first pass)

out vec4 result;  // (segment number, 0, 0, 0)

void main() {
    vec2 c = origin + gl_FragCoord.xy;
    float cover;
    float zl;
    if (!tube_low(a, b, c, radius, cover, zl)) {
        discard;
    }
    if (-zl != texelFetch(deepest, ivec2(gl_FragCoord.xy), 0).g) {
        discard;
    }
    result = vec4(seg, 0.0, 0.0, 0.0);
}
