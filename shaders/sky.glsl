#version 330 core
#include "common.glsl"
// The sky dome behind everything: zenith-to-horizon gradient, sun and moon discs, stars and a
// ground colour below the horizon. Drawn first, at the far plane, into the HDR scene target.

uniform mat4 u_inverse_view_projection;  // of the view without its translation: directions only
uniform vec2 u_resolution;
uniform vec3 u_sun_direction;
uniform vec3 u_sun_radiance;       // irradiance of the sun (the disc's radiance × solid angle)
uniform vec3 u_moon_direction;
uniform vec3 u_moon_radiance;
uniform vec3 u_sky_zenith;
uniform vec3 u_sky_horizon;
uniform vec3 u_sky_irradiance;
uniform vec3 u_ground_albedo;
uniform float u_star_visibility;
uniform float u_gradient_exponent;  // sky.py's SKY_GRADIENT_EXPONENT
uniform float u_sun_radius;         // angular radii, radians
uniform float u_moon_radius;

#if defined VERTEX_SHADER

void main() {
    vec2 corner = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(corner * 2.0 - 1.0, 1.0, 1.0);
}

#elif defined FRAGMENT_SHADER

out vec4 out_radiance;

// A disc of angular radius r around direction c with a soft edge one pixel-ish wide, and its
// radiance chosen so the disc delivers the given irradiance.
vec3 disc(vec3 dir, vec3 c, float r, vec3 irradiance) {
    float angle = acos(clamp(dot(dir, c), -1.0, 1.0));
    float edge = max(fwidth(angle), 1e-5);
    float coverage = 1.0 - smoothstep(r - edge, r + edge, angle);
    float solid_angle = PI * r * r;
    return coverage * min(irradiance / solid_angle, vec3(MAX_HALF));
}

// Stars fixed to directions: one candidate per cell of a grid on the cube around the eye.
float stars(vec3 dir) {
    vec3 a = abs(dir);
    int face = a.x > a.y ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
    vec3 q = dir / a[face];
    vec2 p = face == 0 ? q.yz : face == 1 ? q.xz : q.xy;
    const float CELLS = 220.0;
    vec2 grid = (p * 0.5 + 0.5) * CELLS;
    ivec2 cell = ivec2(floor(grid));
    uint key = uint(cell.x) * 73856093u ^ uint(cell.y) * 19349663u ^ uint(face * 2 + int(dir[face] > 0.0)) * 83492791u;
    float chance = hash01(key);
    if (chance < 0.93) return 0.0;
    vec2 centre = vec2(0.25) + 0.5 * vec2(hash01(key + 1u), hash01(key + 2u));
    float d = length(grid - vec2(cell) - centre);
    float size = max(fwidth(grid.x), 0.02) * 1.2;
    float brightness = pow(hash01(key + 3u), 6.0) * 0.6 + 0.02;
    return brightness * (1.0 - smoothstep(0.0, size, d));
}

// The sky's radiance towards unit direction dir (world space), below the horizon a lit ground.
vec3 sky_radiance(vec3 dir) {
    float mu = max(dir.y, 0.0);
    vec3 sky = mix(u_sky_horizon, u_sky_zenith, pow(mu, u_gradient_exponent));
    // The sun brightens the sky around it (forward scattering), more so when it is low.
    float toward_sun = max(dot(dir, u_sun_direction), 0.0);
    sky += u_sun_radiance * 0.02 * pow(toward_sun, 8.0);
    sky += u_star_visibility * vec3(stars(dir)) * 0.02;
    sky += disc(dir, u_sun_direction, u_sun_radius, u_sun_radiance);
    sky += disc(dir, u_moon_direction, u_moon_radius, u_moon_radiance) * 0.2;

    // Below the horizon: a lit ground plane, fading in over a sliver of degrees.
    vec3 ground_light = u_sun_radiance * max(u_sun_direction.y, 0.0)
                      + u_moon_radiance * max(u_moon_direction.y, 0.0) + u_sky_irradiance;
    vec3 ground = u_ground_albedo / PI * ground_light;
    return min(mix(ground, sky, smoothstep(-0.01, 0.0, dir.y)), vec3(MAX_HALF));
}

void main() {
    vec2 ndc = gl_FragCoord.xy / u_resolution * 2.0 - 1.0;
    vec4 far_point = u_inverse_view_projection * vec4(ndc, 1.0, 1.0);
    vec4 near_point = u_inverse_view_projection * vec4(ndc, -1.0, 1.0);
    vec3 dir = normalize(far_point.xyz / far_point.w - near_point.xyz / near_point.w);
    out_radiance = vec4(sky_radiance(dir), 0.0);  // alpha: no spread (tone.glsl)
}

#endif
