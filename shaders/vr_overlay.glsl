#version 330 core
// The viewer's overlays, drawn over a finished eye image and depth-tested against the scene:
// the workbench panel (a texture of sRGB-encoded bytes, written as they are, like the
// tone-mapped scene), controller rays and the teleport arc (flat colours, u_textured false).

uniform mat4 u_view_projection;
uniform sampler2D u_panel;
uniform vec4 u_colour;
uniform bool u_textured;

#if defined VERTEX_SHADER

in vec3 a_position;
in vec2 a_uv;
out vec2 v_uv;

void main() {
    v_uv = a_uv;
    gl_Position = u_view_projection * vec4(a_position, 1.0);
}

#elif defined FRAGMENT_SHADER

in vec2 v_uv;
out vec4 out_colour;

void main() {
    out_colour = u_textured ? vec4(texture(u_panel, v_uv).rgb, 1.0) : u_colour;
}

#endif
