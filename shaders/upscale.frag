#version 330 core
// Scales a frame drawn at reduced resolution up to the window (bilinear), for the editor's
// 3D view while the camera or the sand is changing. Drawn with the fullscreen triangle.

uniform sampler2D u_source;
uniform vec2 u_size;  // output size in pixels

out vec4 out_colour;

void main() {
    out_colour = vec4(texture(u_source, gl_FragCoord.xy / u_size).rgb, 1.0);
}
