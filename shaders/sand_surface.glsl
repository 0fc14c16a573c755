// The sand material: shade_sand(point, lighting, mode, spread) for any surface that includes this
// file (after lighting.glsl). One model at every distance: d'Eon's Lambertian-sphere BRDF with the
// subsurface terms for the diffuse light, and the Cook–Torrance light of the clear grains' facets
// for the specular, on the rippled macro normal. Close up the footprint's own albedo, grain normals
// and facets shade it, the mirroring facets drawn as sparkles; far away the tile's average and its
// whole distribution of facets, which is what the close range tends to; between them the preset's
// sigmoid of distance only decides which work is done. Uniforms are set by
// sand_editor/render/material.py (SandMaterial.bind). The facet model and sparkle are in
// sand_glints.glsl and glint_facets.glsl, ripples and d'Eon's BRDF in sand_far.glsl.

#include "common.glsl"
#include "glint_facets.glsl"

struct SurfacePoint {
    vec3 position;   // world (metres)
    vec3 normal;     // macro normal, unit, world
    vec3 tangent;    // unit, world, direction of +u
    vec3 bitangent;  // unit, world, direction of +v
    vec2 uv;         // metres along the surface; the material applies its scale
    // The ripples' slopes that the pixel's footprint averages away (sand_far.glsl's
    // rippled_point): their deviation along the axis they lie on, in the tangent plane, and
    // their profile: x its steepest slope over that deviation, y its asymmetry (0: a sine).
    vec2 unresolved;
    vec2 ripple_profile;
};

uniform sampler2D u_albedo;          // linear albedo
uniform sampler2D u_glint_moments;   // w, w·bx, w·by, w·bx·by
uniform sampler2D u_spread_moments;  // w·bx², w·by², bx, by
uniform sampler2D u_hole_moments;    // w·exp(−|b|²/2s₀²)
uniform sampler2D u_normal_moments;  // nx, ny, nx², ny² of every texel's unit grain normal
// What the five normals' diffuse light misses of the grains' own over the whole tile, per
// light and eye direction (far_brdf.py's five_normals_correction, on the relief table's axes).
uniform sampler3D u_diffuse_correction;
uniform sampler2D u_detail;
uniform vec3 u_average_albedo;       // linear: the far-field colour
uniform float u_texture_size;        // texels per tile edge of the grain textures
uniform float u_max_lod;
uniform float u_uv_scale;            // tiles per metre
uniform float u_facet_roughness;     // Beckmann α of facets about their grain's normal
uniform float u_grain_ior;           // the grains' index of refraction
uniform float u_sss;
uniform float u_scattering;
uniform float u_absorption;
uniform float u_transmission;
uniform float u_transmission_roughness;
uniform float u_ripple_strength;
uniform float u_wind_direction;  // compass degrees the wind comes from
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
// The share of the pixel's width whose footprint the sand is filtered over: 1, or 1/k where a
// still is drawn as k×k frames, each moved by a k-th of a pixel, and averaged
// (SandRenderer.render_still): each then filters as the frame k times larger does.
uniform float u_footprint_scale;

// How the texture coordinates `p` change from this pixel to the next, across and up, over the
// footprint the sand is filtered over.
vec2 footprint_dx(vec2 p) { return dFdx(p) * u_footprint_scale; }
vec2 footprint_dy(vec2 p) { return dFdy(p) * u_footprint_scale; }

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
#include "tile_variation.glsl"

// The surface point in a tile copy's axes (TileCopy.axes): the copy's texture axes become its
// tangent and bitangent, so that tangent-space vectors and the copy's moments agree.
SurfacePoint in_copy_axes(SurfacePoint s, mat2 axes) {
    SurfacePoint c = s;
    c.tangent = axes[0][0] * s.tangent + axes[1][0] * s.bitangent;
    c.bitangent = axes[0][1] * s.tangent + axes[1][1] * s.bitangent;
    c.unresolved = axes * s.unresolved;
    return c;
}

#include "bench/sand_probe.glsl" if SAND_PROBE

// The densities of mirroring slopes D of two lights over the pixel, by the filter in use
// (production: ours, drawn; the reference's look: the expectation over its kernel).
vec2 glint_factors(Footprint f, HalfVector h0, HalfVector h1, bool sparkle) {
    if (!h0.valid && !h1.valid) return vec2(0.0);
#if defined SAND_PROBE
    return probe_glint_factors(f, h0, h1, sparkle);
#else
    return sparkle ? sparkling_factors(f, h0, h1, true)
                   : expected_factors(f, h0, h1, REFERENCE_FOOTPRINT);
#endif
}

// The footprint's longer axis cut into taps, each about as long as its shorter axis (at most
// ANISOTROPIC_TAPS): a mip level is square, and one level for a whole footprint seen at a
// grazing angle is its long axis's, a blur across the short one that stretches the grains
// sideways into streaks. The taps keep the grains as sharp across as the pixel is.
const int ANISOTROPIC_TAPS = 8;
uniform int u_anisotropic;  // 1: up to ANISOTROPIC_TAPS taps; 0: one, the longer axis's level

struct Taps {
    vec2 step;    // from one tap's centre to the next, in tiles
    vec2 across;  // the footprint's shorter axis, in tiles
    int count;
};

Taps anisotropic_taps(vec2 dx, vec2 dy) {
    bool y_longer = dot(dy, dy) > dot(dx, dx);
    vec2 along = y_longer ? dy : dx;
    Taps t;
    t.across = y_longer ? dx : dy;
    float ratio = length(along) / max(length(t.across), 1e-12);
    // The 0.05 keeps a footprint a hair longer than wide to one tap.
    float most = u_anisotropic != 0 ? float(ANISOTROPIC_TAPS) : 1.0;
    t.count = int(clamp(ceil(ratio - 0.05), 1.0, most));
    t.step = along / float(t.count);
    return t;
}

// Texels along a tap's longer edge: what its mip level is chosen by.
float tap_texels(Taps t) {
    return max(length(t.step), length(t.across)) * u_texture_size;
}

// Albedo, mean slope and the grain normals' moments of the footprint: the mean of its taps t
// (the ground truth averages its finest-level taps).
void footprint_surface(Footprint f, Taps t, out vec3 albedo, out vec2 slope, out vec4 normals) {
#if defined SAND_PROBE
    if (probe_footprint_surface(f, albedo, slope, normals)) return;
#endif
    albedo = vec3(0.0);
    slope = vec2(0.0);
    normals = vec4(0.0);
    for (int i = 0; i < t.count; ++i) {
        vec2 tc = f.tc + t.step * (float(i) + 0.5 - 0.5 * float(t.count));
        albedo += textureGrad(u_albedo, tc, t.across, t.step).rgb;
        slope += textureGrad(u_spread_moments, tc, t.across, t.step).zw;
        normals += textureGrad(u_normal_moments, tc, t.across, t.step);
    }
    float share = 1.0 / float(t.count);
    albedo *= share;
    slope *= share;
    normals *= share;
}

#include "sand_far.glsl"
#include "sand_relief.glsl"

// The diffuse light of the sand for one light on a shading normal n with albedo kd, the same
// close up (the footprint's albedo and mean grain normal) as far away (the tile's, on the
// macro normal): d'Eon's BRDF of a half space of Lambertian spheres, with the reference's
// subsurface terms — a share fs of the light wraps around the grains (scattering), and
// absorption dims that share by fe along its path through them. The grains' colours are what
// their surfaces send back: absorption never darkens them, so a sand keeps the colour it was
// given whatever its subsurface settings (the reference dimmed all light by fe, which at the
// fields' far ends is e^−100: black whatever the colours).
// The BRDF is taken per unit albedo at the tile's average albedo, so that it is linear in the
// albedo: the mean over a footprint of many grains is then the BRDF of their mean, and the
// close range's average is the far range's exactly, whatever the grains' colours.
float subsurface_share() { return clamp(u_scattering * u_sss, 0.0, 1.0); }
float subsurface_transmittance() { return exp(-u_absorption * u_sss); }

// `phase`: sphere_phase(l, v).
vec3 sand_diffuse(vec3 kd, vec3 n, vec3 l, vec3 v, vec3 irradiance, float phase) {
    float fs = subsurface_share();
    vec3 per_albedo = sphere_brdf_per_albedo(n, l, v, phase);
    vec3 direct = kd * ((1.0 - fs) * per_albedo * max(dot(n, l), 0.0)
                        + fs * subsurface_transmittance() / PI);
    return direct * irradiance;
}

// Sky light on the sand: the cosine-weighted sky irradiance of an upward surface, less as the
// normal turns from the sky.
vec3 sand_sky(vec3 kd, vec3 n, vec3 sky) {
    return kd / PI * sky * (0.5 + 0.5 * n.y);
}

// Light passing through thin grain edges towards a viewer who looks into the light, absorbed
// along its way through them.
vec3 grain_transmission(vec3 albedo, vec3 l, vec3 v, vec3 irradiance) {
    float exponent = mix(TRANSMISSION_SHARPEST, 1.0, clamp(u_transmission_roughness, 0.0, 1.0));
    float forward = pow(max(dot(-v, l), 0.0), exponent);
    return u_transmission * subsurface_transmittance() * albedo * irradiance * forward / PI;
}

// DIFFUSE_CENTRE, DIFFUSE_RING, MAX_SLOPE2, FACING_BAND, MIN_FACING and TRANSMISSION_SHARPEST
// are #defined from sand_editor/render/far_brdf.py, whose numpy model of this light they are.

// Mip levels, over a grain cell's, from which the five normals' correction fades in to where
// it is whole: a footprint of a share of a grain has its normals' spread close enough to the
// five's; one of many grains, the whole tile's.
const vec2 DIFFUSE_CORRECTION_LODS = vec2(-1.0, 3.0);

// How many grain cells a texel of mip level `lod` spans, as a power of 2.
float grain_cells_lod(float lod) {
    return lod - log2(max(grain_cell_texels(), 1.0));
}

// The five normals' correction for a light along tangent-space l and an eye along e, where
// the footprint's taps read mip level `lod` (far_brdf.py's five_normals_correction).
float diffuse_correction(vec3 l, vec3 e, float lod) {
    if (l.z <= 0.0) return 1.0;
    float cells = grain_cells_lod(lod);
    float whole = smoothstep(DIFFUSE_CORRECTION_LODS.x, DIFFUSE_CORRECTION_LODS.y, cells);
    if (whole <= 0.0) return 1.0;
    return mix(1.0, texture(u_diffuse_correction, direction_table_at(l, e)).r, whole);
}

// The light of the five normals of a footprint of grains whose normals have mean m and
// variance `variance` (their x, y in the tangent plane of s), added with `share` of its weight
// to sum and to the moments of its luminance (mean, mean square, the sun's mean).
void five_normals_light(vec3 kd, vec2 m, vec2 variance, float lod, SurfacePoint s, vec3 v,
                        Lighting L, float share, inout vec3 sum, inout vec3 moments) {
    vec3 e = to_tangent(v, s);
    vec2 towards = e.xy;
    float reach = length(towards);
    vec2 along = reach > 1e-5 ? towards / reach : vec2(1.0, 0.0);
    vec2 across = vec2(-along.y, along.x);
    // The variance along a unit axis a, without the covariance (not kept): a·a weighted.
    vec2 spread_along = along * (DIFFUSE_RING * sqrt(dot(along * along, variance)));
    vec2 spread_across = across * (DIFFUSE_RING * sqrt(dot(across * across, variance)));
    vec2 points[5] = vec2[5](m, m + spread_along, m - spread_along,
                             m + spread_across, m - spread_across);
    float sun_share = diffuse_correction(to_tangent(L.sun_direction, s), e, lod);
    float moon_share = L.moon_radiance != vec3(0.0)
        ? diffuse_correction(to_tangent(L.moon_direction, s), e, lod) : 1.0;
    // The grains' phase function depends on the light and the eye alone: once, not per normal.
    float sun_phase = sphere_phase(L.sun_direction, v);
    float moon_phase = sphere_phase(L.moon_direction, v);
    for (int i = 0; i < 5; ++i) {
        vec2 p = points[i];
        float len2 = dot(p, p);
        if (len2 > MAX_SLOPE2) p *= sqrt(MAX_SLOPE2 / len2);
        vec3 n = to_world(vec3(p, sqrt(max(1.0 - dot(p, p), 0.0))), s);
        // A grain side facing away from the eye sends it nothing; one turning away fades out
        // over a band of n·v rather than stopping along a line across the frame (d'Eon's BRDF
        // does not vanish at grazing views).
        float facing = dot(n, v);
        float seen = smoothstep(-FACING_BAND, FACING_BAND, facing);
        if (facing < MIN_FACING) n = normalize(n + (MIN_FACING - facing) * v);
        vec3 sunlit = vec3(0.0), direct = vec3(0.0);
        // Lights that are off (below the horizon) are skipped: the same branch for every pixel.
        if (L.sun_radiance != vec3(0.0)) {
            sunlit = seen * sun_share * sand_diffuse(kd, n, L.sun_direction, v, L.sun_radiance,
                                                     sun_phase);
        }
        if (L.moon_radiance != vec3(0.0)) {
            direct = seen * moon_share * sand_diffuse(kd, n, L.moon_direction, v,
                                                      L.moon_radiance, moon_phase);
        }
        direct += sunlit;
        float weight = share * (i == 0 ? DIFFUSE_CENTRE : 0.25 * (1.0 - DIFFUSE_CENTRE));
        sum += weight * direct;
        float luminance = dot(direct, LUMINANCE_WEIGHTS);
        moments += weight * vec3(luminance, luminance * luminance,
                                 dot(sunlit, LUMINANCE_WEIGHTS));
    }
}

// The ripple profile's slopes, in units of its steepest, at the four Gauss–Legendre quantiles
// of a third (0, 1, 2: from the most negative) of its slope distribution, for asymmetry
// `sharp` (far_brdf.ripple_quantile_fit's quadratics).
vec4 ripple_quantiles(int third, float sharp) {
    if (third == 0) {
        return RIPPLE_QUANTILES_00 + sharp * (RIPPLE_QUANTILES_01 + sharp * RIPPLE_QUANTILES_02);
    }
    if (third == 1) {
        return RIPPLE_QUANTILES_10 + sharp * (RIPPLE_QUANTILES_11 + sharp * RIPPLE_QUANTILES_12);
    }
    return RIPPLE_QUANTILES_20 + sharp * (RIPPLE_QUANTILES_21 + sharp * RIPPLE_QUANTILES_22);
}

// The slope of each third of the unresolved ripples' slopes at its mean angle, in units of
// their deviation (along s.unresolved): three tilts of a third each that hold the ripples'
// skew (a short steep lee, a long gentle windward side) and the light of slopes too steep for a
// mean of slopes to hold (far_brdf.ripple_tilt_slopes).
vec3 ripple_nodes(SurfacePoint s) {
    float deviation = length(s.unresolved);
    float steepest = deviation * s.ripple_profile.x;
    vec3 angles = vec3(
        dot(RIPPLE_QUANTILE_WEIGHTS, atan(steepest * ripple_quantiles(0, s.ripple_profile.y))),
        dot(RIPPLE_QUANTILE_WEIGHTS, atan(steepest * ripple_quantiles(1, s.ripple_profile.y))),
        dot(RIPPLE_QUANTILE_WEIGHTS, atan(steepest * ripple_quantiles(2, s.ripple_profile.y))));
    return tan(angles) / max(deviation, 1e-30);
}

// Whether the ripples too fine for the pixel (s.unresolved) tilt it: not where their slopes'
// deviation is under RIPPLE_UNRESOLVED_LEAST, whose tilts change the light by under 0.2 % (the
// cosine's second order): not worth three evaluations in place of one.
bool ripples_tilt(SurfacePoint s) {
    float least = RIPPLE_UNRESOLVED_LEAST;
    return dot(s.unresolved, s.unresolved) > least * least;
}

// The point turned as a ripple's side of tangent-space `slope` turns it, bent to face the eye
// as the resolved ripples are (rippled_point).
SurfacePoint ripple_tilted(SurfacePoint s, vec2 slope, vec3 v) {
    return turned_to(s, to_world(vec3(-slope, 1.0), s), v);
}

// The mean share of the light along tangent-space l0 (the sun) and l1 (the moon) that reaches
// the grains an eye along e sees (sand_relief.glsl).
vec2 mean_relief_visibilities(vec3 l0, vec3 l1, vec3 e) {
    return vec2(mean_relief_visibility(l0, e), mean_relief_visibility(l1, e));
}

// The lights L, whose radiance holds the grains' shadows on a point where `reaching` of each
// reaches them (mean_relief_visibilities), as they reach the grains of the point turned to t:
// a ripple's side turned to a low sun has its grains' shadows shorter, the side turned away
// longer.
Lighting relief_turned(Lighting L, SurfacePoint t, vec3 v, vec2 reaching) {
    vec2 here = mean_relief_visibilities(to_tangent(L.sun_direction, t),
                                         to_tangent(L.moon_direction, t), to_tangent(v, t));
    vec2 turned = mix(vec2(1.0), here / max(reaching, vec2(1e-30)),
                      greaterThan(reaching, vec2(1e-3)));
    L.sun_radiance *= turned.x;
    L.moon_radiance *= turned.y;
    return L;
}

// The diffuse light averaged over the footprint's grain normals (the mean of nx, ny and of
// their squares), as the grains themselves give it when each is resolved: at the mean normal
// and four more whose nx, ny hold that mean and the variance along two axes exactly. Unit
// normals rather than slopes: bounded, and the cosine of the light is linear in them. The axes
// are the eye's azimuth and its perpendicular, since what is not linear in the normal (a side
// turning away from the eye) depends on the eye: fixed texture axes would make the average
// jump where the eye's azimuth crosses them. The same average at every scale, so that the far
// range's diffuse light is the close range's: the five's light is corrected by what they
// miss of the grains' own, as the footprint's level `lod` grows to hold whole grains
// (diffuse_correction). The ripples too fine for the pixel (s.unresolved) tilt the footprint's
// grains along the ripples' axis: the five are taken at three tilts (ripple_nodes), each
// a third of the ripples' slopes, with the grains' shadows as each tilt casts them
// (relief_turned) and the sky as each tilt sees it, in both ranges alike (the far range is the
// close range's limit). The sky at the untilted normal alone left strong ripples (slopes to 8)
// 17 % too bright at a low sun, against frames supersampled with the ripples unfiltered: a
// ripple's steep sides see less of it. `spread`: x the variance of the sun's and the moon's
// luminance over the five at every tilt (their light's spread across the footprint), y the
// sun's mean luminance, z the variance of the luminance between the tilts (the ripples' share
// of x, with the sky each tilt sees). `reaching`: the mean share of each light that reaches
// the grains of s (mean_relief_visibilities), which L's radiance holds.
vec3 filtered_diffuse_light(vec3 kd, vec4 normals, float lod, SurfacePoint s, vec3 v,
                            Lighting L, vec2 reaching, out vec3 spread) {
    vec2 m = normals.xy;
    vec2 variance = max(normals.zw - m * m, 0.0);
    vec3 sum = vec3(0.0);
    vec3 moments = vec3(0.0);  // of the luminance: its mean, its mean square, the sun's mean
    vec2 tilt_moments = vec2(0.0);  // of each tilt's luminance: its mean, its mean square
    int tilts = ripples_tilt(s) ? 3 : 1;
    vec3 nodes = tilts == 3 ? ripple_nodes(s) : vec3(0.0);
    for (int j = 0; j < 3; ++j) {
        if (j >= tilts) break;
        SurfacePoint t = s;
        Lighting lit = L;
        if (tilts == 3) {
            float node = j == 0 ? nodes.x : (j == 1 ? nodes.y : nodes.z);
            t = ripple_tilted(s, node * s.unresolved, v);
            lit = relief_turned(L, t, v, reaching);
        }
        vec3 before = sum;
        five_normals_light(kd, m, variance, lod, t, v, lit, 1.0 / float(tilts), sum, moments);
        // The sky's light is linear in the normal: once per tilt, at its mean normal (it adds
        // nothing to the variance over the five: a share of the light that does not vary
        // across the footprint's grains, but does across the ripples).
        vec3 sky = sand_sky(kd, to_world(vec3(m, sqrt(max(1.0 - dot(m, m), 0.0))), t),
                            L.sky_irradiance);
        float luminance = dot((sum - before) * float(tilts) + sky, LUMINANCE_WEIGHTS);
        tilt_moments += vec2(luminance, luminance * luminance) / float(tilts);
        sum += sky / float(tilts);
    }
    spread = vec3(max(moments.y - moments.x * moments.x, 0.0), moments.z,
                  max(tilt_moments.y - tilt_moments.x * tilt_moments.x, 0.0));
    // The light through grain edges does not depend on the normal: once.
    return sum + grain_transmission(kd, L.sun_direction, v, L.sun_radiance)
         + grain_transmission(kd, L.moon_direction, v, L.moon_radiance);
}

// The frame the tone curve's spread is that of: this many times finer each way than the frame
// drawn, each of its pixels through the curve and averaged (the supersampled frame FLIP is
// measured against).
const float SPREAD_PARTS = 8.0;

struct Shaded {
    vec3 radiance;
    // The variance of the luminance across the footprint over its squared mean: what the tone
    // curve takes of it (tone.glsl's aces_over_spread).
    float spread;
    vec3 glint;         // the specular part of radiance
    vec3 micro_normal;  // the diffuse shading normal
    float lod;          // the mip level the footprint's taps read
};

// The specular light of both lights for densities D of mirroring slopes.
vec3 sand_specular(vec2 densities, HalfVector h0, HalfVector h1, Lighting L) {
    return L.sun_radiance * specular_radiance(densities.x, h0)
         + L.moon_radiance * specular_radiance(densities.y, h1);
}

void lights_in_tangent(SurfacePoint s, Lighting L, inout Footprint f) {
    f.to_eye = to_tangent(L.eye - s.position, s);
    f.light0 = to_tangent(L.sun_direction, s);
    f.light1 = to_tangent(L.moon_direction, s);
    // A light that is off (below the horizon) draws no sparkle: it would only cost time.
    f.lit0 = dot(L.sun_radiance, L.sun_radiance) > 0.0;
    f.lit1 = dot(L.moon_radiance, L.moon_radiance) > 0.0;
}

// The light the tile's facets (m) mirror on the point tilted by a ripple's side of `slope`
// along s.unresolved, in units of its deviation.
vec3 tile_specular_at(SurfacePoint s, Footprint f, Lighting L, vec3 v, SlopeMoments m,
                      float slope) {
    lights_in_tangent(ripple_tilted(s, slope * s.unresolved, v), L, f);
    HalfVector h0, h1;
    half_vectors_at(f, vec2(0.0), h0, h1);
    return sand_specular(moments_factors(m, h0, h1), h0, h1, L);
}

// The light the tile's facets (m) mirror where ripples too fine for the pixel tilt it
// (s.unresolved): a ripple's side turns the half vectors of a grazing light and eye into the
// facets' slopes or out of them, sharply and far from linearly in its slope, so the light is
// the mean over the ripples' slopes by Gauss–Legendre at four quantiles of each third of them
// (ripple_quantiles). At the diffuse light's three tilts, the black sand under a low sun ahead
// was 10–17 % too bright about the glints' highlight and 8 % too dark nearer, per row of the
// probe's frame, against it supersampled 8×8 with the ripples unfiltered; at these twelve,
// within 1 % in every row (test_ripple_field.py).
vec3 tilted_tile_specular(SurfacePoint s, Footprint f, Lighting L, vec3 v, SlopeMoments m) {
    vec3 sum = vec3(0.0);
    // One loop of twelve, not four calls a third: a WebGL compiler inlines each call.
    for (int j = 0; j < 12; ++j) {
        vec4 pick = vec4(equal(ivec4(j % 4), ivec4(0, 1, 2, 3)));
        float q = dot(pick, ripple_quantiles(j / 4, s.ripple_profile.y));
        float weight = dot(pick, RIPPLE_QUANTILE_WEIGHTS) / 3.0;
        sum += weight * tile_specular_at(s, f, L, v, m, s.ripple_profile.x * q);
    }
    return sum;
}

// The light the tile's whole distribution of facets mirrors, on the ripples' tilts where they
// tilt the pixel (tilted_tile_specular). h0, h1: the half vectors at the footprint's mean slope
// (half_vectors_at).
vec3 tile_specular(SurfacePoint s, Footprint f, Lighting L, vec3 v, bool copies, HalfVector h0,
                   HalfVector h1) {
    SlopeMoments m = tile_moments(copies);
    if (ripples_tilt(s)) return tilted_tile_specular(s, f, L, v, m);
    return sand_specular(moments_factors(m, h0, h1), h0, h1, L);
}

// Up close the sparkles are drawn at the footprint's mean slope; where ripples too fine for
// the pixel tilt it, their light is brought to what the tilts give the tile's facets (as far
// away, of which the close range is the limit): scaled down where the tilts mirror less, and
// where they mirror more, the rest added evenly (no sparkle is drawn for the facets a tilt
// turns to the light). The sparkles' expectation is the footprint's, which far from the eye,
// where ripples lie below a pixel, is the tile's.
// h0, h1: the half vectors the sparkles were drawn for.
vec3 glints_on_ripples(vec3 glint, SurfacePoint s, Footprint f, Lighting L, vec3 v,
                       HalfVector h0, HalfVector h1) {
    if (!ripples_tilt(s)) return glint;
    SlopeMoments m = tile_moments(u_tile_variation != 0);
    vec3 mean = sand_specular(moments_factors(m, h0, h1), h0, h1, L);
    vec3 tilted = tilted_tile_specular(s, f, L, v, m);
    vec3 share = mix(vec3(1.0), tilted / max(mean, vec3(1e-30)), greaterThan(mean, vec3(0.0)));
    return glint * min(share, vec3(1.0)) + max(tilted - mean, vec3(0.0));
}

// Close up: the footprint's albedo, mean grain normal and density of mirroring facets, drawn
// as sparkles. reference_look: the reference's glint instead (its gain and distance boost on
// the expectation over its kernel, no sparkle). `plain`: the point before its ripples
// turned it (rippled_point's s), the frame the grains' relief is marched in.
Shaded shade_close(SurfacePoint s, SurfacePoint plain, Lighting L, vec3 v, bool reference_look) {
    Footprint f;
    f.tc = s.uv * u_uv_scale;
    f.dx = footprint_dx(f.tc);
    f.dy = footprint_dy(f.tc);
    Shaded c;
    // The footprint's level as one square (the copies' borders and the reference's boost
    // scale with it).
    float texels = max(length(f.dx), length(f.dy)) * u_texture_size;
    float footprint_lod = clamp(log2(max(texels, 1e-8)), 0.0, u_max_lod);
    if (u_tile_variation != 0) {
        // The tile's copy at this point (tile_variation.glsl), shaded in its own axes.
        // How many grain cells a pixel spans, as a power of 2.
        TileCopy copy = tile_copy(f.tc, grain_cells_lod(footprint_lod));
        f.tc = copy.tc;
        f.dx = copy.axes * f.dx;
        f.dy = copy.axes * f.dy;
        s = in_copy_axes(s, copy.axes);
        plain = in_copy_axes(plain, copy.axes);
    }
    // The footprint's taps, in the copy's axes, and the level they read.
    Taps taps = anisotropic_taps(f.dx, f.dy);
    c.lod = clamp(log2(max(tap_texels(taps), 1e-8)), 0.0, u_max_lod);
    lights_in_tangent(s, L, f);
    // The light that reaches the grains: the pixel's own shadows where the relief is drawn,
    // their mean over many grains where it is not (as far away), and between the two as the
    // relief fades in: by the grains' size against a tap, as sharp as the grains are read.
    vec2 mean_reaching = mean_relief_visibilities(f.light0, f.light1, normalize(f.to_eye));
    // The eye's ray is marched through the grains in the frame of the surface as drawn, not
    // of its ripples: the ripples are a normal, not a shape, and a ray in their frame turns
    // with their slope from pixel to pixel, so that its offset along the surface does too;
    // where they tilt the most (about a crest) that stretched the grains into fins down the
    // screen, one pixel's grain smeared over the next ones'.
    vec3 e = normalize(to_tangent(L.eye - plain.position, plain));
    vec2 reaching = mean_reaching;
    float relief = relief_weight(tap_texels(taps));
    vec2 seen_tc = f.tc + mean_relief_shift(e);
    if (relief > 0.0) {
        // The grains at their depth for this eye, and the light that reaches where it looks.
        Relief r = relief_at(f.tc, e, f.light0, f.light1, bvec2(f.lit0, f.lit1), c.lod);
        seen_tc = mix(seen_tc, r.tc, relief);
        reaching = mix(reaching, vec2(r.sun, r.moon), relief);
    }
    f.tc = seen_tc;
    L.sun_radiance *= reaching.x;
    L.moon_radiance *= reaching.y;
    f.lit0 = f.lit0 && reaching.x > 0.0;
    f.lit1 = f.lit1 && reaching.y > 0.0;
    vec3 albedo;
    vec2 slope;
    vec4 normals;
    footprint_surface(f, taps, albedo, slope, normals);
    c.micro_normal = to_world(normalize(vec3(slope, 1.0)), s);
    HalfVector h[2];
    half_vectors_at(f, vec2(0.0), h[0], h[1]);
    vec2 densities = glint_factors(f, h[0], h[1], !reference_look);
    if (reference_look) {
        // E[w·lobe] = D·2π·var; the lobe 1 at the mirror direction, Fresnel normalised to 1
        // at normal incidence, the light's cosine: the reference's formula.
        float boost = REFERENCE_BOOST * footprint_lod / max(u_max_lod, 1.0);
        float gain = REFERENCE_GLINT_GAIN * exp(boost);
        float f0 = fresnel_dielectric(1.0, u_grain_ior);
        c.glint = vec3(0.0);
        vec3 e[2] = vec3[2](L.sun_radiance, L.moon_radiance);
        for (int i = 0; i < 2; ++i) {
            if (!h[i].valid) continue;
            float lobe = densities[i] * 2.0 * PI * h[i].variance;
            c.glint += e[i] * gain * lobe * h[i].cos_light * h[i].fresnel / f0;
        }
    } else {
        c.glint = glints_on_ripples(sand_specular(densities, h[0], h[1], L), s, f, L, v, h[0],
                                    h[1]);
    }
    vec3 spread;
    c.radiance = filtered_diffuse_light(albedo, normals, c.lod, s, v, L, mean_reaching, spread)
               + c.glint;
    // Where the relief is not drawn, the grains' shadows are not either: of the sun's mean
    // light m on the footprint, a share v (the mean visibility) of its grains is lit by m / v
    // and the rest by none, a variance of m²(1 − v)/v; none of it where the relief is drawn.
    float undrawn = (1.0 - relief) * spread.y;
    float lit_share = max(mean_reaching.x, 1e-3);
    float shadowing = undrawn * undrawn * (1.0 - lit_share) / lit_share;
    // The grains' share of that spread is their light's across the pixel's parts (a frame drawn
    // SPREAD_PARTS times finer, whose pixels the tone curve takes one by one): where each part
    // holds many grains it is their mean's, the grains' own over their count (independent
    // grains), and none of it far below the pixel, as the far range takes none. The ripples'
    // (spread.z) is kept whole. Taken whole at any size, a sand of grains far below the pixel
    // displayed its close frame 10 % darker than its far frame at 10 and 30 m (a one-cell tile
    // of 354 per metre, all of its light wrapped around the grains, under a low sun).
    float pixel_cells = abs(determinant(mat2(f.dx, f.dy))) / (u_grain_cell * u_grain_cell);
    float part_cells = pixel_cells / (SPREAD_PARTS * SPREAD_PARTS);
    float grains = max(spread.x - spread.z, 0.0) + shadowing;
    float mean = dot(c.radiance, LUMINANCE_WEIGHTS);
    float variance = spread.z + grains / (1.0 + part_cells);
    c.spread = mean > 1e-8 ? variance / (mean * mean) : 0.0;
    return c;
}

// Far away: the tile's average albedo and its whole distribution of mirroring facets on the
// macro normal, no sparkle: the limit of shade_close as the footprint covers the tile.
// `spread`: the variance of the luminance between the ripples' tilts over the squared mean, for
// the tone curve (Shaded.spread). The grains' own spread is not: each part of a far pixel
// holds many grains, but only a few ripples, whose sides turn to the light and from it. At
// 30 and 100 m against frames supersampled 16×16 with the ripples unfiltered (bench depth's
// view, 07:00 and 16:30), FLIP with it and without: ripples 0.3, 0.032–0.075 and 0.041–0.087;
// ripples 1, 0.072–0.094 and 0.082–0.119.
vec3 shade_far(SurfacePoint s, Lighting L, vec3 v, out float spread) {
    Footprint f = Footprint(s.uv * u_uv_scale, vec2(0.0), vec2(0.0), vec3(0.0), vec3(0.0),
                            vec3(0.0), false, false);
    lights_in_tangent(s, L, f);
    // Many grains to a pixel: their shadows' mean share of each light (sand_relief.glsl).
    vec2 reaching = mean_relief_visibilities(f.light0, f.light1, normalize(f.to_eye));
    L.sun_radiance *= reaching.x;
    L.moon_radiance *= reaching.y;
    vec3 kd = clamp(u_average_albedo, 0.0, 1.0);
    vec2 centre = vec2(0.5);
    vec4 normals = textureLod(u_normal_moments, centre, u_max_lod);
    bool copies = u_tile_variation != 0;
    if (copies) normals = copies_normal_moments(normals);
    vec3 spreads;
    HalfVector h0, h1;
    half_vectors_at(f, vec2(0.0), h0, h1);
    vec3 radiance = filtered_diffuse_light(kd, normals, u_max_lod, s, v, L, reaching, spreads)
                  + tile_specular(s, f, L, v, copies, h0, h1);
    float mean = dot(radiance, LUMINANCE_WEIGHTS);
    spread = mean > 1e-8 ? spreads.z / (mean * mean) : 0.0;
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

// `spread`: the variance of the light's luminance across the pixel over its squared mean, which
// the tone curve takes (tone.glsl's aces_over_spread): each range's, as much of it as the blend
// keeps; 0 where the pixel's light is taken as even (the debug modes).
vec3 shade_sand(SurfacePoint s, Lighting L, int mode, out float spread) {
    spread = 0.0;
    vec3 to_eye = L.eye - s.position;
    float distance_m = length(to_eye);
    vec3 v = distance_m > 0.0 ? to_eye / distance_m : s.normal;
    float blend = blend_weight(distance_m);

    if (mode == MODE_BLEND) return vec3(blend);
    if (mode == MODE_LAMBERT) return shade_lambert(s, L);
    // The grains lie on the ripples: close and far shade the same rippled surface.
    SurfacePoint r = rippled_point(s, v);
    if (mode == MODE_FAR) return shade_far(r, L, v, spread);

    // Past the cutoff the close term's share is negligible: none of its work is done.
#if defined SAND_FAR_ONLY
    return shade_far(r, L, v, spread);
#endif
    bool whole = mode == MODE_FULL || mode == MODE_REFERENCE_LOOK;
    if (whole && blend > u_close_cutoff) return shade_far(r, L, v, spread);
    Shaded close = shade_close(r, s, L, v, mode == MODE_REFERENCE_LOOK);

    if (mode == MODE_CLOSE) {
        spread = close.spread;
        return close.radiance;
    }
    if (mode == MODE_GLINTS) return close.glint;
    if (mode == MODE_NORMALS) return close.micro_normal * 0.5 + 0.5;
    if (mode == MODE_MIP) return lod_colour(close.lod / max(u_max_lod, 1.0));
    // Both ranges hold the same light on average (the far one is the close one's limit), so
    // the blend only decides which work is done.
    float far_spread = 0.0;
    vec3 far = blend > 1e-4 ? shade_far(r, L, v, far_spread) : vec3(0.0);
    vec3 radiance = mix(close.radiance, far, blend);
    // Each share's variance, as each holds it.
    float close_share = (1.0 - blend) * dot(close.radiance, LUMINANCE_WEIGHTS);
    float far_share = blend * dot(far, LUMINANCE_WEIGHTS);
    float mean = dot(radiance, LUMINANCE_WEIGHTS);
    float variance = close.spread * close_share * close_share + far_spread * far_share * far_share;
    spread = mean > 1e-8 ? variance / (mean * mean) : 0.0;
    return radiance;
}
