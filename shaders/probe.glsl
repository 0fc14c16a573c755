#version 330 core
// The material on an endless flat plane (y = 0, tangent +x, bitangent +z, uv = world xz), for
// measurements: no terrain, sky or post-processing between the material and the numbers.

#if defined VERTEX_SHADER

uniform mat4 u_view_projection;
in vec3 in_position;
out vec3 v_position;

void main() {
    v_position = in_position;
    gl_Position = u_view_projection * vec4(in_position, 1.0);
}

#elif defined FRAGMENT_SHADER

#include "lighting.glsl"
#include "sand_surface.glsl"

uniform int u_mode;
in vec3 v_position;
out vec4 out_radiance;

void main() {
    if (!sand_covers(v_position, u_eye, u_mode)) discard;
    SurfacePoint s = SurfacePoint(v_position, vec3(0.0, 1.0, 0.0), vec3(1.0, 0.0, 0.0),
                                  vec3(0.0, 0.0, 1.0), v_position.xz);
    out_radiance = vec4(shade_sand(s, scene_lighting(), u_mode), 1.0);
}

#endif
