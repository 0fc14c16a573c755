// Glints of the sand material: the expected glint of a footprint from its slope moments, and the
// sparkle each pixel draws from it (included by sand_surface.glsl after its uniforms and helpers;
// the probe's filters, sand_probe.glsl, build on these functions).
//
// The expected glint comes from moments (LEAN mapping, Olano & Baker 2010): the material's
// mipmaps hold the w-weighted mean and covariance of grain-normal slopes, w being 1 on clear
// grains and 0 elsewhere, so the density of mirroring facets over a whole footprint is one
// closed-form Gaussian integral per light instead of many taps. From it each pixel draws its
// sparkle: the grain facets that mirror the sun in its footprint (glint_facets.glsl).

// The facet model. Every grain of the top layer is clear (it mirrors) or not, by the preset's
// share of clear grains; a clear grain's surface is facets whose slopes spread about the
// grain's profile slope b by a Beckmann distribution of roughness α (the preset's facet
// roughness): slopes N(b, α²/2·I). The footprint's density of mirroring slopes at the half
// vector's slope b_h, D = E[w·N(b_h; b, α²/2)] (w = 1 on clear grains), then gives everything:
//   the specular radiance (Cook–Torrance)  L = E·F(v·h)·G·D / (4·cos⁴θ_h·cos θ_v),
//   and the chance that one facet mirrors the sun's disc, D times the area in slope space of
//   the half vectors the disc spans: at most 1 by construction, never clamped.

// The reference's look (MODE_REFERENCE_LOOK): its gain and distance boost e^(5m) on its
// Phong lobe of the facet roughness, m the mip level over the top one.
const float REFERENCE_GLINT_GAIN = 5000.0;
const float REFERENCE_BOOST = 5.0;
// Its N×N kernel, 7×7 taps 0.305 pixels apart: the footprint it filters, in pixels.
const float REFERENCE_FOOTPRINT = 7.0 * 0.305;
// Facets smoother than this would need a finer sun than the real one to resolve.
const float MIN_FACET_ROUGHNESS = 0.01;
// HOLE_SCALE2, s₀², the width² of the slope hole the moments record, is #defined by material.py.

// Per-axis variance of facet slopes about their grain's slope.
float facet_variance() {
    float a = max(u_facet_roughness, MIN_FACET_ROUGHNESS);
    return 0.5 * a * a;
}

// The density at b_half of one grain point's facet slopes: Beckmann about the grain's normal
// (slope b), D(m)·m_z⁴/cos θ_grain in slope space, which integrates to 1 for every grain
// (render/facet_lobe.py's rotated_density).
float facet_density(vec2 b, vec2 b_half, float variance) {
    float sb = 1.0 + dot(b, b_half);
    if (sb < 1e-6) return 0.0;
    vec2 d = b_half - b;
    float cross_sb = b_half.x * b.y - b_half.y * b.x;
    float tan2 = (dot(d, d) + cross_sb * cross_sb) / (sb * sb);
    float tilt = 1.0 + dot(b, b);
    float jacobian = tilt * tilt * sqrt(tilt) / (sb * sb * sb * sb);
    return jacobian * exp(-0.5 * tan2 / variance) / (2.0 * PI * variance);
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

// E[w · lobe] of a footprint. A Gaussian of the slopes' mean and covariance (LEAN) misses the
// density near zero slope where the grains' distribution is not Gaussian: ball caps are
// peaked there with long tails out to their rims (steeper grains would leave a hole). The hole
// moment measures that density exactly at scale s₀, and a Gaussian of that width, of the weight
// that matches it (added, or taken out as a hole), corrects it. Measured on the shipped sands'
// ball caps over the footprint average of their texels at mip levels 2–9, for half-vector
// slopes 0–1: the Gaussian alone is off by −56 % to +71 %, with the correction by −23 % (at
// the zenith) to +31 % (slope 1, in the tails); on the earlier cone-shaped grains it held ±3 %.
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

// A grain's facets spread about its normal, a lobe that tilts with the grain; the moments can
// only shift it to the grain's slope. The ratio of the two lobes' light over the tile's clear
// grains at the facets' roughness, per half-vector tilt (0…LOBE_TILT_MAX, LOBE_TILTS steps),
// measured by material.py (render/facet_lobe.py).
uniform float u_lobe_correction[LOBE_TILTS];

float lobe_correction(vec2 b_half) {
    float column = clamp(atan(length(b_half)) / LOBE_TILT_MAX, 0.0, 1.0) * float(LOBE_TILTS - 1);
    int c0 = min(int(column), LOBE_TILTS - 2);
    return mix(u_lobe_correction[c0], u_lobe_correction[c0 + 1], column - float(c0));
}

// The footprint's density of mirroring facet slopes at b_half (the D above).
float mirror_density(SlopeMoments s, vec2 b_half, float variance) {
    return expected_glint(s, b_half, variance) / (2.0 * PI * variance) * lobe_correction(b_half);
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

// Fresnel reflectance of a dielectric of index eta (unpolarised, exact), at cos of incidence c.
float fresnel_dielectric(float c, float eta) {
    float g2 = eta * eta - 1.0 + c * c;
    if (g2 < 0.0) return 1.0;
    float g = sqrt(g2);
    float a = (g - c) / (g + c);
    float b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    return clamp(0.5 * a * a * (1.0 + b * b), 0.0, 1.0);
}

// Smith's masking of a Beckmann surface of roughness alpha seen at cos_theta (Walter et al.'s
// rational fit of Λ).
float smith_lambda(float cos_theta, float alpha) {
    float c = clamp(cos_theta, 1e-4, 1.0);
    float a = c / (alpha * sqrt(max(1.0 - c * c, 1e-12)));
    if (a >= 1.6) return 0.0;
    return (1.0 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a);
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

// One light's half vector, with what the facet model needs of it.
struct HalfVector {
    bool valid;      // the light and the eye are above the surface and some grain can mirror
    vec2 slope;      // of the half vector, in tangent space
    float variance;  // of the facet slopes about a grain's slope
    float cos_light; // of the light to the macro normal
    float cos_view;  // of the eye to the macro normal
    float fresnel;   // F(v·h) of the grains' index of refraction
    float cone;      // area in slope space of the half vectors the light's disc spans
    float scale;     // F(v·h) / (4·cos⁴θ_h·cos θ_v): radiance per density per irradiance, G apart
};

HalfVector half_vector(vec3 l_t, vec3 v_t) {
    HalfVector h;
    float v_dot_h = 0.0;
    h.valid = l_t.z > 0.0 && v_t.z > 0.0 && half_slope(l_t, v_t, h.slope, v_dot_h);
    h.variance = facet_variance();
    h.cos_light = max(l_t.z, 0.0);
    h.cos_view = max(v_t.z, 1e-4);
    // cos θ_h from the slope: 1/√(1 + |b|²). A disc of solid angle Ω spans Ω/(4·v·h) of half
    // vectors, and a solid angle dω about slope b is dω/cos³θ_h of slope space.
    float cos2_half = 1.0 / (1.0 + dot(h.slope, h.slope));
    float cos_half = sqrt(cos2_half);
    float vh = max(v_dot_h, 1e-4);
    h.cone = h.valid ? LIGHT_SOLID_ANGLE / (4.0 * vh * cos2_half * cos_half) : 0.0;
    h.fresnel = fresnel_dielectric(vh, u_grain_ior);
    h.scale = h.valid ? h.fresnel / (4.0 * cos2_half * cos2_half * h.cos_view) : 0.0;
    return h;
}

// Smith's masking–shadowing of a grain's facets (Beckmann of the facets' roughness).
float masking(HalfVector h) {
    float alpha = sqrt(2.0 * h.variance);
    return 1.0 / (1.0 + smith_lambda(h.cos_view, alpha) + smith_lambda(h.cos_light, alpha));
}

// Specular radiance per unit irradiance of a light for a density of mirroring slopes.
float specular_radiance(float density, HalfVector h) {
    return h.valid ? density * h.scale * masking(h) : 0.0;
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

// The facet-slope densities at both half vectors of one grain point of slope b.
vec2 densities(HalfVector h0, HalfVector h1, vec2 b) {
    return vec2(h0.valid ? facet_density(b, h0.slope, h0.variance) : 0.0,
                h1.valid ? facet_density(b, h1.slope, h1.variance) : 0.0);
}

// The densities of mirroring slopes of both lights in a distribution of slopes m.
vec2 moments_factors(SlopeMoments m, HalfVector h0, HalfVector h1) {
    return vec2(h0.valid ? mirror_density(m, h0.slope, h0.variance) : 0.0,
                h1.valid ? mirror_density(m, h1.slope, h1.variance) : 0.0);
}

// The densities of mirroring slopes D of two lights over the footprint widened by `widen`
// pixels, from one trilinear fetch per moment texture.
vec2 expected_factors(Footprint f, HalfVector h0, HalfVector h1, float widen) {
    vec2 gx = f.dx * widen, gy = f.dy * widen;
    SlopeMoments m = slope_moments(textureGrad(u_glint_moments, f.tc, gx, gy),
                                   textureGrad(u_spread_moments, f.tc, gx, gy),
                                   textureGrad(u_hole_moments, f.tc, gx, gy).x);
    return moments_factors(m, h0, h1);
}

// The whole tile's distribution of slopes: its top mip level, far away. Where the tile is
// laid as turned and mirrored copies (``copies``, tile_variation.glsl), the eight symmetries of
// the square come equally often: the distribution far away is their mixture, whose moments
// are the tile's with the means of x, y and x·y gone and x², y² sharing their sum (|b|², and
// so the hole moment, is unchanged).
SlopeMoments tile_moments(bool copies) {
    vec2 centre = vec2(0.5);
    vec4 glint = textureLod(u_glint_moments, centre, u_max_lod);
    vec4 spread = textureLod(u_spread_moments, centre, u_max_lod);
    if (copies) {
        glint.yzw = vec3(0.0);
        spread.xy = vec2(0.5 * (spread.x + spread.y));
    }
    return slope_moments(glint, spread, textureLod(u_hole_moments, centre, u_max_lod).x);
}

// The chance that one facet mirrors a light's disc, from a density of mirroring slopes.
float mirror_chance(float density, HalfVector h) {
    return density * h.cone;
}

// The glints with each light's sparkle drawn (glint_facets.glsl): the mirroring facets of
// the patches under the footprint, each patch's chance from its own mip texel's moments, so
// that the draw belongs to the surface alone; returned as densities, as expected_factors. Without
// `draw`, the expectation alone: the pixel's footprint's expected glint.
vec2 sparkling_factors(Footprint f, HalfVector h0, HalfVector h1, bool draw) {
    if (!draw) return expected_factors(f, h0, h1, 1.0);
    float facet_texels = facet_size_m() * u_uv_scale * u_texture_size;
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
                float chance = mirror_chance(mirror_density(m, p0.slope, p0.variance), p0);
                count.x += facets_in_pixel(p, cell, p.facets * min(chance, 1.0), p0.slope, 0u);
            }
            if (p1.valid) {
                float chance = mirror_chance(mirror_density(m, p1.slope, p1.variance), p1);
                count.y += facets_in_pixel(p, cell, p.facets * min(chance, 1.0), p1.slope, 1u);
            }
        }
    }
    return vec2(per_facet.x > 0.0 ? count.x / per_facet.x : 0.0,
                per_facet.y > 0.0 ? count.y / per_facet.y : 0.0);
}
