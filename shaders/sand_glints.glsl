// Glints of the sand material: the expected glint of a footprint from its slope moments, and the
// sparkle each pixel draws from it (included by sand_surface.glsl after its uniforms and helpers;
// the probe's filters, sand_probe.glsl, build on these functions).
//
// The expected glint comes from moments (LEAN mapping, Olano & Baker 2010): the material's
// mipmaps hold the w-weighted mean and covariance of grain-normal slopes, w being each grain's
// glint selection weight, so the expected glint of a whole footprint is one closed-form Gaussian
// integral per light instead of many taps. From it each pixel draws its sparkle: the grain
// facets that mirror the sun in its footprint (glint_facets.glsl).

// Glints are drawn sparkles (glint_facets.glsl), except in MODE_REFERENCE_LOOK: the reference's
// look, its gain and distance boost on the expected glint.
const float REFERENCE_GLINT_GAIN = 5000.0;  // the reference's glint radiance scale
const float REFERENCE_BOOST = 5.0;   // and its distance boost e^(5m), m the mip level / the top
// Our glint brightness: the reference's at its boost level m = 0.4 (where it shows sand about
// 0.4 m away at 480×270), the same at every distance: the drawn sparkle loses no energy.
const float GLINT_GAIN = REFERENCE_GLINT_GAIN * 7.38905609893;  // e^(5·0.4)
const float SILICA_F0 = 0.03478;     // ((1.458 − 1) / (1.458 + 1))², Schlick's F0 of quartz
// HOLE_SCALE2, s₀², the width² of the slope hole the moments record, is #defined by material.py.

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
