#version 330 core
// Terrain and sphere: surfaces shaded by the sand material into the HDR scene target.
// Vertex positions are relative to u_origin, so clip positions keep millimetre precision far
// from the world origin; u_view_projection already includes the translation by u_origin.

uniform mat4 u_view_projection;
uniform vec3 u_origin;

#include "lighting.glsl"
#include "shadows.glsl"

#if defined VERTEX_SHADER

in vec3 a_position;
in vec3 a_normal;
in vec3 a_tangent;
in vec2 a_uv;

out vec3 v_world;
out vec3 v_normal;
out vec3 v_tangent;
out vec2 v_uv;

void main() {
    v_world = u_origin + a_position;
    v_normal = a_normal;
    v_tangent = a_tangent;
    v_uv = a_uv;
    shadow_coordinates(a_position, a_normal);
    gl_Position = u_view_projection * vec4(a_position, 1.0);
}

#elif defined FRAGMENT_SHADER

// The material uses screen-space derivatives, which exist only in fragment shaders.
#include "sand_surface.glsl"

uniform int u_mode;

in vec3 v_world;
in vec3 v_normal;
in vec3 v_tangent;
in vec2 v_uv;

out vec4 out_radiance;

void main() {
    if (!sand_covers(v_world, u_eye, u_mode)) discard;
    SurfacePoint s;
    s.position = v_world;
    s.normal = normalize(v_normal);
    // Interpolation bends the frame; Gram-Schmidt makes it orthonormal again.
    s.tangent = normalize(v_tangent - s.normal * dot(s.normal, v_tangent));
    s.bitangent = cross(s.tangent, s.normal);
    s.uv = v_uv;
    s.unresolved = vec2(0.0);
    s.ripple_profile = vec2(0.0);
    float spread;
    vec3 radiance = shade_sand(s, shadowed(scene_lighting(u_eye), v_world, s.normal), u_mode,
                               spread);
    // Half floats overflow to inf past 65504, and bloom would smear an inf over the frame.
    // alpha: the spread of the light across the pixel, which the tone curve takes (tone.glsl).
    out_radiance = vec4(clamp(radiance, 0.0, MAX_HALF), clamp(spread, 0.0, MAX_SPREAD));
}

#endif
