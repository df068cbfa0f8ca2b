#version 430
// Deformable brush footprint (station/brush/footprint_gl.py): one instance per
// bristle tube segment, drawn as the axis-aligned quad that holds the tube's
// shadow on the canvas window.  Cell (row i, column j) of the window is pixel
// (j, i): looking up from below the canvas mirrors y, which is exactly GL's
// bottom-up rows.

in vec2 corner;        // per vertex: (0|1, 0|1)
in vec3 seg_a;         // per instance: segment ends, cells (x, y, z up)
in vec3 seg_b;

uniform vec2 origin;   // window cell (x0, y0)
uniform vec2 size;     // window size in cells (w, h)
uniform float radius;  // tube radius, cells

flat out vec3 a;
flat out vec3 b;
flat out float seg;   // the instance's number (the tag pass)

void main() {
    a = seg_a;
    b = seg_b;
    seg = float(gl_InstanceID);
    vec2 lo = min(seg_a.xy, seg_b.xy) - vec2(radius + 1.0);
    vec2 hi = max(seg_a.xy, seg_b.xy) + vec2(radius + 1.0);
    vec2 p = mix(lo, hi, corner);
    vec2 ndc = (p - origin) / size * 2.0 - 1.0;
    gl_Position = vec4(ndc, 0.0, 1.0);
}
