#version 330 core
// The comfort vignette over an eye's finished image: the edges of the view darken towards
// black as u_strength rises (1: all but a small disc at the middle), covering a teleport or a
// snap turn. Drawn blended over the image (source alpha).

uniform vec4 u_viewport;  // x, y, width, height of the eye in window pixels
uniform float u_strength;

out vec4 out_colour;

void main() {
    vec2 p = (gl_FragCoord.xy - u_viewport.xy) / u_viewport.zw * 2.0 - 1.0;
    float r = length(p);
    float open = mix(1.6, 0.25, u_strength);  // radius of the clear disc
    float dark = smoothstep(open, open + 0.35, r) * min(u_strength * 3.0, 1.0);
    out_colour = vec4(0.0, 0.0, 0.0, dark);
}
