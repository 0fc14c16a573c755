#version 330 core
// The shadow maps' casters (sand_editor/render/shadows.py): depth only, seen from the light.
// Positions are relative to the mesh's origin, as in terrain.glsl; u_light_clip includes it.

uniform mat4 u_light_clip;

#if defined VERTEX_SHADER

in vec3 a_position;

void main() {
    gl_Position = u_light_clip * vec4(a_position, 1.0);
}

#elif defined FRAGMENT_SHADER

void main() {}

#endif
