// The scene's light as the sand material sees it (sand_editor/render/sky.py computes it; the
// renderer sets these uniforms). Included by programs that shade surfaces.

uniform vec3 u_eye;
uniform vec3 u_sun_direction;
uniform vec3 u_sun_radiance;
uniform vec3 u_moon_direction;
uniform vec3 u_moon_radiance;
uniform vec3 u_sky_irradiance;

struct Lighting {
    vec3 eye;             // world position of the eye (metres)
    vec3 sun_direction;   // unit vector towards the sun
    vec3 sun_radiance;    // sun irradiance at normal incidence, linear RGB, HDR (0 below the horizon)
    vec3 moon_direction;  // unit vector towards the moon
    vec3 moon_radiance;   // moonlight irradiance at normal incidence (0 below the horizon)
    vec3 sky_irradiance;  // cosine-weighted sky light on an upward surface, linear RGB
};

Lighting scene_lighting(vec3 eye) {
    return Lighting(eye, u_sun_direction, u_sun_radiance, u_moon_direction, u_moon_radiance,
                    u_sky_irradiance);
}
