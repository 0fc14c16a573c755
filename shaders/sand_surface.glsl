// The sand material: shade_sand(point, lighting, mode) for any surface that includes this file
// (after lighting.glsl). Close up: grain albedo and normals, glints, subsurface-flavoured diffuse,
// Fresnel and forward transmission; far away: d'Eon's Lambertian-sphere BRDF of the average
// colour on the rippled macro normal; between them the preset's sigmoid of distance. Uniforms are
// set by sand_editor/render/material.py (SandMaterial.bind). The glints' maths and sparkle are in
// sand_glints.glsl, the far range in sand_far.glsl.

#include "common.glsl"
#include "glint_facets.glsl"

struct SurfacePoint {
    vec3 position;   // world (metres)
    vec3 normal;     // macro normal, unit, world
    vec3 tangent;    // unit, world, direction of +u
    vec3 bitangent;  // unit, world, direction of +v
    vec2 uv;         // metres along the surface; the material applies its scale
};

uniform sampler2D u_albedo;          // linear albedo, glint value g
uniform sampler2D u_glint_moments;   // w, w·bx, w·by, w·bx·by
uniform sampler2D u_spread_moments;  // w·bx², w·by², bx, by
uniform sampler2D u_hole_moments;    // w·exp(−|b|²/2s₀²)
uniform sampler2D u_ripple_steep;    // tangent-space slope (∂h/∂u, ∂h/∂v) of ripples, 1 m tile
uniform sampler2D u_ripple_shallow;
uniform sampler2D u_detail;
uniform vec3 u_average_albedo;       // linear: the far-field colour
uniform float u_texture_size;        // texels per tile edge of the grain textures
uniform float u_max_lod;
uniform float u_uv_scale;            // tiles per metre
uniform float u_glint_shininess;
uniform float u_glint_mu;
uniform float u_glint_sigma;
uniform int u_sample_count;
uniform float u_sample_spread;
uniform float u_sss;
uniform float u_scattering;
uniform float u_absorption;
uniform float u_fresnel_roughness;
uniform float u_transmission;
uniform float u_transmission_roughness;
uniform float u_ripple_strength;
uniform float u_detail_strength;
uniform float u_sigmoid_a;
uniform float u_sigmoid_b;
// Close-range work is skipped where the blend weight exceeds this (its share is below 1 − it),
// which happens beyond u_close_limit metres. Surfaces are drawn twice in full mode: once with
// this file as is, discarding beyond the limit, and once compiled with SAND_FAR_ONLY, discarding
// within it; a fragment discarded first costs nothing even on CPU rasterizers, which run both
// sides of a branch.
uniform float u_close_cutoff;
uniform float u_close_limit;

float blend_weight(float distance_m) {
    // Clamped so exp() never overflows at 1 km with a steep sigmoid.
    return 1.0 / (1.0 + exp(clamp(-u_sigmoid_a * (distance_m - u_sigmoid_b), -80.0, 80.0)));
}

vec3 to_tangent(vec3 v, SurfacePoint s) {
    return vec3(dot(v, s.tangent), dot(v, s.bitangent), dot(v, s.normal));
}

vec3 to_world(vec3 t, SurfacePoint s) {
    return normalize(t.x * s.tangent + t.y * s.bitangent + t.z * s.normal);
}

#include "sand_glints.glsl"

#include "bench/sand_probe.glsl" if SAND_PROBE

// The glint E[w·lobe] of two lights over the pixel, by the filter in use (production: ours).
vec2 glint_factors(Footprint f, HalfVector h0, HalfVector h1, bool sparkle) {
    if (!h0.valid && !h1.valid) return vec2(0.0);
#if defined SAND_PROBE
    return probe_glint_factors(f, h0, h1, sparkle);
#else
    return sparkle ? sparkling_factors(f, h0, h1, true)
                   : expected_factors(f, h0, h1, reference_footprint());
#endif
}

// Albedo and mean slope of the footprint (the ground truth averages its finest-level taps).
void footprint_surface(Footprint f, out vec3 albedo, out vec2 slope) {
#if defined SAND_PROBE
    if (probe_footprint_surface(f, albedo, slope)) return;
#endif
    albedo = textureGrad(u_albedo, f.tc, f.dx, f.dy).rgb;
    slope = textureGrad(u_spread_moments, f.tc, f.dx, f.dy).zw;
}

// Subsurface-flavoured diffuse of the reference: a share fs of the light wraps around the grain
// (scattering), and absorption along the subsurface path dims everything by fe.
vec3 grain_diffuse(vec3 albedo, float n_dot_l, vec3 irradiance, vec3 sky) {
    float fs = clamp(u_scattering * u_sss, 0.0, 1.0);
    float fe = exp(-u_absorption * u_sss);
    return fe * albedo / PI * (irradiance * (fs + (1.0 - fs) * max(n_dot_l, 0.0)) + sky);
}

// Light passing through thin grain edges towards a viewer who looks into the light.
vec3 grain_transmission(vec3 albedo, vec3 l, vec3 v, vec3 irradiance) {
    float exponent = mix(16.0, 1.0, clamp(u_transmission_roughness, 0.0, 1.0));
    float forward = pow(max(dot(-v, l), 0.0), exponent);
    return u_transmission * albedo * irradiance * forward / PI;
}

struct CloseTerms {
    vec3 radiance;
    vec3 glint;
    vec3 micro_normal;
    float lod;
};

// reference_look: the reference's glint instead (its gain and distance boost, no sparkle).
CloseTerms shade_close(SurfacePoint s, Lighting L, vec3 v, bool reference_look) {
    Footprint f;
    f.tc = s.uv * u_uv_scale;
    f.dx = dFdx(f.tc);
    f.dy = dFdy(f.tc);
    CloseTerms c;
    vec3 albedo;
    vec2 slope;
    footprint_surface(f, albedo, slope);
    c.micro_normal = to_world(normalize(vec3(slope, 1.0)), s);
    vec2 texels = vec2(max(length(f.dx), length(f.dy))) * u_texture_size;
    c.lod = clamp(log2(max(texels.x, 1e-8)), 0.0, u_max_lod);

    c.radiance = vec3(0.0);
    c.glint = vec3(0.0);
    vec3 lights[2] = vec3[2](L.sun_direction, L.moon_direction);
    vec3 irradiances[2] = vec3[2](L.sun_radiance, L.moon_radiance);
    vec3 l_t[2] = vec3[2](to_tangent(lights[0], s), to_tangent(lights[1], s));
    f.to_eye = to_tangent(L.eye - s.position, s);
    f.light0 = l_t[0];
    f.light1 = l_t[1];
    // A light that is off (below the horizon) draws no sparkle: it would only cost time.
    f.lit0 = dot(irradiances[0], irradiances[0]) > 0.0;
    f.lit1 = dot(irradiances[1], irradiances[1]) > 0.0;
    HalfVector h[2];
    half_vectors_at(f, vec2(0.0), h[0], h[1]);
    vec2 glints = glint_factors(f, h[0], h[1], !reference_look);
    float gain = reference_look
        ? REFERENCE_GLINT_GAIN * exp(REFERENCE_BOOST * c.lod / max(u_max_lod, 1.0))
        : GLINT_GAIN;
    for (int i = 0; i < 2; ++i) {
        vec3 e = irradiances[i];
        c.glint += e * (gain * glints[i] * h[i].fresnel * max(l_t[i].z, 0.0));
        c.radiance += grain_diffuse(albedo, dot(c.micro_normal, lights[i]), e, vec3(0.0));
        c.radiance += grain_transmission(albedo, lights[i], v, e);
    }
    c.radiance += grain_diffuse(albedo, 0.0, vec3(0.0), L.sky_irradiance);
    c.radiance += c.glint;
    return c;
}

#include "sand_far.glsl"

vec3 shade_lambert(SurfacePoint s, Lighting L) {
    vec3 kd = u_average_albedo / PI;
    return kd * (L.sun_radiance * max(dot(s.normal, L.sun_direction), 0.0)
                 + L.moon_radiance * max(dot(s.normal, L.moon_direction), 0.0) + L.sky_irradiance);
}

vec3 lod_colour(float t) {
    return clamp(vec3(2.0 * t - 0.5, 1.0 - abs(2.0 * t - 1.0), 1.5 - 2.0 * t), 0.0, 1.0);
}

// Whether this program variant shades the point at all (see u_close_limit).
bool sand_covers(vec3 position, vec3 eye, int mode) {
    bool beyond = distance(position, eye) > u_close_limit;
    bool whole = mode == MODE_FULL || mode == MODE_REFERENCE_LOOK;
#if defined SAND_FAR_ONLY
    return whole && beyond;
#else
    return !whole || !beyond;
#endif
}

vec3 shade_sand(SurfacePoint s, Lighting L, int mode) {
    vec3 to_eye = L.eye - s.position;
    float distance_m = length(to_eye);
    vec3 v = distance_m > 0.0 ? to_eye / distance_m : s.normal;
    float blend = blend_weight(distance_m);

    if (mode == MODE_BLEND) return vec3(blend);
    if (mode == MODE_LAMBERT) return shade_lambert(s, L);
    if (mode == MODE_FAR) return shade_far(s, L, v);

    // Past the cutoff the close term's share is negligible: none of its work is done.
#if defined SAND_FAR_ONLY
    return shade_far(s, L, v);
#endif
    if ((mode == MODE_FULL || mode == MODE_REFERENCE_LOOK) && blend > u_close_cutoff) return shade_far(s, L, v);
    CloseTerms close = shade_close(s, L, v, mode == MODE_REFERENCE_LOOK);

    if (mode == MODE_CLOSE) return close.radiance;
    if (mode == MODE_GLINTS) return close.glint;
    if (mode == MODE_NORMALS) return close.micro_normal * 0.5 + 0.5;
    if (mode == MODE_MIP) return lod_colour(close.lod / max(u_max_lod, 1.0));
    vec3 far = blend > 1e-4 ? shade_far(s, L, v) : vec3(0.0);
    // Glints are specular light that the far BRDF (diffuse spheres) does not hold: they are
    // added to the blend rather than blended away, and fade out before the close range ends.
    float glint_fade = 1.0 - smoothstep(0.5 * u_close_limit, u_close_limit, distance_m);
    return mix(close.radiance - close.glint, far, blend) + close.glint * glint_fade;
}
