#version 330 core
// The workbench's desk, tray walls and the controllers: plain-coloured Lambertian surfaces lit
// by the same sun, moon and sky as the sand (sand_editor/render/sky.py), and shadowed by the
// same maps (shaders/shadows.glsl), drawn into the HDR scene before it is exposed, so they
// brighten and darken with the day as the sand does.
// Positions are relative to u_origin (metres), as the renderer's meshes are.

uniform mat4 u_view_projection;  // from positions relative to u_origin
uniform vec3 u_origin;

#include "lighting.glsl"
#include "shadows.glsl"

#if defined VERTEX_SHADER

in vec3 a_position;
in vec3 a_normal;
in vec3 a_albedo;
out vec3 v_world;
out vec3 v_normal;
out vec3 v_albedo;

void main() {
    v_world = u_origin + a_position;
    v_normal = a_normal;
    v_albedo = a_albedo;
    shadow_coordinates(a_position, a_normal);
    gl_Position = u_view_projection * vec4(a_position, 1.0);
}

#elif defined FRAGMENT_SHADER

const float PI = 3.14159265358979;

in vec3 v_world;
in vec3 v_normal;
in vec3 v_albedo;
out vec4 out_radiance;

void main() {
    vec3 n = normalize(v_normal);
    Lighting L = shadowed(scene_lighting(u_eye), v_world, n);
    // Sky light from above, a little bounced up from the sand below.
    vec3 sky = L.sky_irradiance * (0.6 + 0.4 * n.y);
    vec3 light = L.sun_radiance * max(dot(n, L.sun_direction), 0.0)
               + L.moon_radiance * max(dot(n, L.moon_direction), 0.0) + sky;
    out_radiance = vec4(v_albedo / PI * light, 0.0);  // alpha: no spread (tone.glsl)
}

#endif
