// The sand material: shade_sand(point, lighting, mode) for any surface that includes this file
// (after lighting.glsl). Close up: grain albedo and normals, glints, subsurface-flavoured diffuse,
// Fresnel and forward transmission; far away: d'Eon's Lambertian-sphere BRDF of the average
// colour on the rippled macro normal; between them the preset's sigmoid of distance. Uniforms are
// set by sand_editor/render/material.py (SandMaterial.bind).
//
// Glints: their expected value comes from moments (LEAN mapping, Olano & Baker 2010): the
// material's mipmaps hold the w-weighted mean and covariance of grain-normal slopes, w being each
// grain's glint selection weight, so the expected glint of a whole footprint is one closed-form
// Gaussian integral per light instead of many taps. From it each pixel draws its sparkle: the
// grain facets that mirror the sun in its footprint (glint_facets.glsl).

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
// Glints are drawn sparkles (glint_facets.glsl), except in MODE_REFERENCE_LOOK: the reference's
// look, its gain and distance boost on the expected glint.
// Close-range work is skipped where the blend weight exceeds this (its share is below 1 − it),
// which happens beyond u_close_limit metres. Surfaces are drawn twice in full mode: once with
// this file as is, discarding beyond the limit, and once compiled with SAND_FAR_ONLY, discarding
// within it; a fragment discarded first costs nothing even on CPU rasterizers, which run both
// sides of a branch.
uniform float u_close_cutoff;
uniform float u_close_limit;

const float REFERENCE_GLINT_GAIN = 5000.0;  // the reference's glint radiance scale
const float REFERENCE_BOOST = 5.0;   // and its distance boost e^(5m), m the mip level / the top
// Our glint brightness: the reference's at its boost level m = 0.4 (where it shows sand about
// 0.4 m away at 480×270), the same at every distance: the drawn sparkle loses no energy.
const float GLINT_GAIN = REFERENCE_GLINT_GAIN * 7.38905609893;  // e^(5·0.4)
const float SILICA_F0 = 0.03478;     // ((1.458 − 1) / (1.458 + 1))², Schlick's F0 of quartz
const float RIPPLE_SLOPE_GAIN = 8.0; // ripple strength 1 means slopes 8× the map's
const float MIN_FACING = 0.05;       // least n·v of a shading normal
// HOLE_SCALE2, s₀², the width² of the slope hole the moments record, is #defined by material.py.

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

// Width² of the glint lobe in slope space: a Phong lobe of exponent Gs about the mirror direction
// is a Gaussian of variance 1/(4·Gs) in the angle of the normal to the half vector; slopes
// stretch angles by 1 + |b_h|² around slope b_h.
float lobe_variance(vec2 b_half) {
    float stretch = 1.0 + dot(b_half, b_half);
    return stretch * stretch / (4.0 * max(u_glint_shininess, 0.1));
}

// The glint lobe of one normal slope b: 1 at the mirror configuration.
float glint_lobe(vec2 b, vec2 b_half, float variance) {
    vec2 d = b - b_half;
    return exp(-0.5 * dot(d, d) / variance);
}

float glint_selection(float g) {
    float z = (g - u_glint_mu) / u_glint_sigma;
    return exp(-0.5 * z * z);
}

// The w-weighted slope distribution of a footprint as LEAN mapping sees it: mass, mean and
// covariance, from one fetch of each moment texture.
struct SlopeMoments {
    float w;
    vec2 mean;
    vec3 cov;    // xx, yy, xy
    float hole;  // E[w·exp(−|b|²/2s₀²)]/w: the exact slope density near zero, at scale s₀
};

SlopeMoments slope_moments(vec4 glint_moments, vec4 spread_moments, float hole_moment) {
    SlopeMoments s;
    s.w = glint_moments.x;
    float w = max(s.w, 1e-30);
    s.mean = glint_moments.yz / w;
    // Filtering in half floats can leave a covariance a hair from positive semi-definite.
    float cxx = max(spread_moments.x / w - s.mean.x * s.mean.x, 0.0);
    float cyy = max(spread_moments.y / w - s.mean.y * s.mean.y, 0.0);
    float cxy = clamp(glint_moments.w / w - s.mean.x * s.mean.y, -sqrt(cxx * cyy), sqrt(cxx * cyy));
    s.cov = vec3(cxx, cyy, cxy);
    s.hole = hole_moment / w;
    return s;
}

// ∫ N(b; m, C) exp(−|b − b_h|²/2α²) db = α²/√det(C + α²I) · exp(−½ (m − b_h)ᵀ(C + α²I)⁻¹(m − b_h)).
float gaussian_overlap(vec2 m, vec3 cov, vec2 b_half, float variance) {
    float sxx = cov.x + variance, syy = cov.y + variance;
    float det = sxx * syy - cov.z * cov.z;
    vec2 d = m - b_half;
    float quad = (syy * d.x * d.x - 2.0 * cov.z * d.x * d.y + sxx * d.y * d.y) / det;
    return variance / sqrt(det) * exp(-0.5 * quad);
}

// E[w · lobe] of a footprint. A Gaussian of the slopes' mean and covariance (LEAN) overestimates
// the density near zero slope: grains are cone-like, and their slopes leave a hole there. The
// hole moment measures that density exactly at scale s₀, and a Gaussian hole of that width,
// deep enough to match it, is taken out: measured on the shipped grains, this brings the
// expected glint within ±3 % of the exact footprint average at every mip level, where the
// Gaussian alone is off by up to +20 % for near-mirror half vectors.
float expected_glint(SlopeMoments s, vec2 b_half, float variance) {
    if (s.w < 1e-6) return 0.0;
    float gaussian = gaussian_overlap(s.mean, s.cov, b_half, variance);
    float at_zero = gaussian_overlap(s.mean, s.cov, vec2(0.0), HOLE_SCALE2);
    // The hole Gaussian, seen at scale s₀ at zero, is ½; solve (1 + k)·at_zero − k·½ = hole.
    float k = abs(at_zero - 0.5) > 1e-4 ? (s.hole - at_zero) / (at_zero - 0.5) : 0.0;
    k = clamp(k, -0.95, 4.0);
    float hole = variance / (HOLE_SCALE2 + variance)
               * exp(-0.5 * dot(b_half, b_half) / (HOLE_SCALE2 + variance));
    return s.w * max((1.0 + k) * gaussian - k * hole, 0.0);
}

// Half vector slope of a light and view in tangent space; false where no grain facing up can
// mirror one into the other (the half vector below the surface).
bool half_slope(vec3 l_t, vec3 v_t, out vec2 b_half, out float v_dot_h) {
    vec3 h = l_t + v_t;
    float len = length(h);
    if (len < 1e-6) return false;
    h /= len;
    v_dot_h = clamp(dot(v_t, h), 0.0, 1.0);
    if (h.z < 0.02) return false;
    b_half = h.xy / h.z;
    return true;
}

// Schlick's Fresnel for quartz, normalised to 1 at normal incidence; the specular roughness damps
// the grazing rise (rough grains do not mirror at grazing angles).
float glint_fresnel(float v_dot_h) {
    float schlick = SILICA_F0 + (1.0 - SILICA_F0) * pow(1.0 - v_dot_h, 5.0);
    return mix(schlick / SILICA_F0, 1.0, u_fresnel_roughness);
}

struct Footprint {
    vec2 tc;       // texture coordinates (tiles)
    vec2 dx;       // screen derivatives of tc
    vec2 dy;
    // In tangent space: from the pixel's point to the eye (metres), and towards each light
    // (lit: the light is on and above the surface).
    vec3 to_eye;
    vec3 light0, light1;
    bool lit0, lit1;
};

// One light's half vector, as the glint lobe needs it.
struct HalfVector {
    bool valid;      // the light and the eye are above the surface and some grain can mirror
    vec2 slope;      // of the half vector, in tangent space
    float variance;  // of the lobe about it, in slope space
    float fresnel;   // normalised to 1 at normal incidence
    float cos_light; // of the light to the macro normal
};

HalfVector half_vector(vec3 l_t, vec3 v_t) {
    HalfVector h;
    float v_dot_h = 0.0;
    h.valid = l_t.z > 0.0 && v_t.z > 0.0 && half_slope(l_t, v_t, h.slope, v_dot_h);
    h.variance = lobe_variance(h.valid ? h.slope : vec2(0.0));
    h.fresnel = glint_fresnel(v_dot_h);
    h.cos_light = max(l_t.z, 0.0);
    return h;
}

// The half vectors of both lights at a point `offset` tiles along the surface from the pixel's
// centre: each facet sees the eye from where it lies, so its mirror state belongs to it, not to
// the pixel that happens to cover it.
void half_vectors_at(Footprint f, vec2 offset, out HalfVector h0, out HalfVector h1) {
    vec3 to_eye = f.to_eye - vec3(offset / u_uv_scale, 0.0);
    float distance_m = length(to_eye);
    vec3 v = distance_m > 0.0 ? to_eye / distance_m : vec3(0.0, 0.0, 1.0);
    h0 = half_vector(f.light0, v);
    h1 = half_vector(f.light1, v);
    h0.valid = h0.valid && f.lit0;
    h1.valid = h1.valid && f.lit1;
}

vec2 lobes(HalfVector h0, HalfVector h1, vec2 b) {
    return vec2(h0.valid ? glint_lobe(b, h0.slope, h0.variance) : 0.0,
                h1.valid ? glint_lobe(b, h1.slope, h1.variance) : 0.0);
}

// The footprint of the reference's N×N kernel: the preset's sample count × spread pixels.
float reference_footprint() {
    return max(1.0, float(u_sample_count) * u_sample_spread);
}

// The expected glint E[w·lobe] of two lights over the footprint widened by `widen` pixels, from
// one trilinear fetch per moment texture.
vec2 expected_factors(Footprint f, HalfVector h0, HalfVector h1, float widen) {
    vec2 gx = f.dx * widen, gy = f.dy * widen;
    SlopeMoments m = slope_moments(textureGrad(u_glint_moments, f.tc, gx, gy),
                                   textureGrad(u_spread_moments, f.tc, gx, gy),
                                   textureGrad(u_hole_moments, f.tc, gx, gy).x);
    return vec2(h0.valid ? expected_glint(m, h0.slope, h0.variance) : 0.0,
                h1.valid ? expected_glint(m, h1.slope, h1.variance) : 0.0);
}

// The chance that one facet mirrors a light, from an expected glint E[w·lobe]: the expected
// radiance over a mirroring facet's, R = F·E/Ω (glint_facets.glsl); E and F cancel.
float mirror_chance(float expected, HalfVector h) {
    return GLINT_GAIN * expected * h.cos_light * LIGHT_SOLID_ANGLE / SILICA_F0;
}

// The glints with each light's sparkle drawn (glint_facets.glsl): the mirroring facets of
// the patches under the footprint, each patch's chance from its own mip texel's moments, so
// that the draw belongs to the surface alone; returned in the units of E[w·lobe]. Without
// `draw`, the expectation alone: the pixel's footprint's expected glint.
vec2 sparkling_factors(Footprint f, HalfVector h0, HalfVector h1, bool draw) {
    if (!draw) return expected_factors(f, h0, h1, 1.0);
    float facet_texels = FACET_SIZE_M * u_uv_scale * u_texture_size;
    Patches p = footprint_patches(f.tc, f.dx, f.dy, u_texture_size, facet_texels);
    vec2 per_facet = vec2(mirror_chance(1.0, h0), mirror_chance(1.0, h1)) * p.pixel_facets;
    if (!p.valid || !(max(per_facet.x, per_facet.y) > 0.0)) return vec2(0.0);
    float lod = min(p.level, u_max_lod);
    vec2 count = vec2(0.0);
    for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < 2; ++i) {
            ivec2 cell = p.first + ivec2(i, j);
            if (!patch_overlaps(p, cell)) continue;
            vec2 tc = patch_centre(p, cell, u_texture_size);
            vec4 glint_moments = textureLod(u_glint_moments, tc, lod);
            if (glint_moments.x < 1e-6) continue;  // no selected grain: expected_glint is 0
            SlopeMoments m = slope_moments(glint_moments, textureLod(u_spread_moments, tc, lod),
                                           textureLod(u_hole_moments, tc, lod).x);
            HalfVector p0, p1;
            vec2 offset = ((vec2(cell) + 0.5) * p.size - p.texel) / u_texture_size;
            half_vectors_at(f, offset, p0, p1);
            if (p0.valid) {
                float chance = mirror_chance(expected_glint(m, p0.slope, p0.variance), p0);
                count.x += facets_in_pixel(p, cell, p.facets * min(chance, 1.0), p0.slope, 0u);
            }
            if (p1.valid) {
                float chance = mirror_chance(expected_glint(m, p1.slope, p1.variance), p1);
                count.y += facets_in_pixel(p, cell, p.facets * min(chance, 1.0), p1.slope, 1u);
            }
        }
    }
    return vec2(per_facet.x > 0.0 ? count.x / per_facet.x : 0.0,
                per_facet.y > 0.0 ? count.y / per_facet.y : 0.0);
}

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

// ---- far range ----------------------------------------------------------------------------

// d'Eon (2021), the fitted form of the BRDF of a half space of Lambertian spheres, for one
// channel: kd is the diffuse colour, c the particles' single-scattering albedo mapped from it.
float lambert_sphere_brdf(float kd, float ui, float uo, float cos_io) {
    float c = (1.0 - pow(1.0 - kd, 2.73556)) / (1.0 - 0.184096 * pow(1.0 - kd, 2.48423));
    float u = clamp(-cos_io, -1.0, 1.0);
    float phase = 2.0 * (sqrt(max(1.0 - u * u, 0.0)) - u * acos(u)) / (3.0 * PI * PI);
    float single = c * phase / max(ui + uo, 1e-4);
    float s = sqrt(max((1.0 - ui * ui) * (1.0 - uo * uo), 0.0));
    // Relative azimuth from cos(io) = ui·uo + s·cos φ; at s → 0 the azimuth is moot.
    float cos_phi = s > 1e-5 ? clamp((cos_io - ui * uo) / s, -1.0, 1.0) : 1.0;
    float s_safe = max(s, 1e-5);
    float multiple = ((acos(cos_phi) + sqrt(ui * uo)) * (c - 0.249978))
                   / (4.50996 * (acos(min(s_safe, 1.0)) / s_safe + 0.113706))
                   + pow(max(1.94208 * kd, 0.0), 1.85432);
    return max(0.995917 * single + 0.0684744 * multiple, 0.0);
}

vec3 lambert_sphere(vec3 kd, vec3 n, vec3 l, vec3 v) {
    float ui = dot(n, l), uo = dot(n, v);
    if (ui <= 0.0 || uo <= 0.0) return vec3(0.0);
    float cos_io = dot(l, v);
    // Every channel with its own albedo.
    return vec3(lambert_sphere_brdf(kd.r, ui, uo, cos_io), lambert_sphere_brdf(kd.g, ui, uo, cos_io),
                lambert_sphere_brdf(kd.b, ui, uo, cos_io));
}

// The macro normal with ripples across the dune slope and fine detail.
vec3 rippled_normal(SurfacePoint s) {
    // Ripple crests run along the contour lines: the ripple axis is the down-slope direction.
    vec3 up = vec3(0.0, 1.0, 0.0);
    vec3 downhill = s.normal - dot(s.normal, up) * up;
    float slope = length(downhill);
    vec2 axis_t = vec2(1.0, 0.0);
    if (slope > 1e-4) {
        vec2 a = vec2(dot(downhill, s.tangent), dot(downhill, s.bitangent));
        float len = length(a);
        axis_t = len > 1e-6 ? a / len : axis_t;
    }
    mat2 frame = mat2(axis_t, vec2(-axis_t.y, axis_t.x));  // columns: along, across
    vec2 ripple_uv = transpose(frame) * s.uv;
    float steep = smoothstep(0.2, 0.45, slope);
    vec2 grad_r = mix(texture(u_ripple_shallow, ripple_uv).xy, texture(u_ripple_steep, ripple_uv).xy, steep);
    vec2 grad = frame * grad_r;
    grad += texture(u_detail, s.uv * 4.0).xy * (u_detail_strength / max(u_ripple_strength, 1e-3));
    vec3 n_t = normalize(vec3(-RIPPLE_SLOPE_GAIN * u_ripple_strength * grad, 1.0));
    return to_world(n_t, s);
}

vec3 shade_far(SurfacePoint s, Lighting L, vec3 v) {
    vec3 n = rippled_normal(s);
    // At grazing views a ripple's back can face away from the eye, where the BRDF is 0: a hard
    // dark patch that no real ripple shows (its back would be hidden by its crest). Bend such
    // normals just far enough towards the eye.
    float facing = dot(n, v);
    if (facing < MIN_FACING) n = normalize(n + (MIN_FACING - facing) * v);
    float fe = exp(-u_absorption * u_sss);
    vec3 kd = clamp(u_average_albedo, 0.0, 1.0);
    vec3 radiance = fe * kd / PI * L.sky_irradiance * (0.5 + 0.5 * n.y);
    radiance += fe * lambert_sphere(kd, n, L.sun_direction, v) * L.sun_radiance * max(dot(n, L.sun_direction), 0.0);
    radiance += fe * lambert_sphere(kd, n, L.moon_direction, v) * L.moon_radiance * max(dot(n, L.moon_direction), 0.0);
    return radiance;
}

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
