// Glints as the sun mirrored in grain facets, drawn per footprint cell (included by
// sand_surface.glsl after common.glsl).
//
// A grain's surface is a mosaic of facets of about FACET_SIZE_M. A facet that mirrors the sun
// into the eye shows the sun's radiance times quartz's Fresnel reflectance, R = F·E/Ω (E the
// sun's irradiance, Ω its solid angle), over its own area: a pixel of area A holding k such
// facets of area a gets k·R·a/A. The material's expected glint radiance L (the footprint's
// slope moments) therefore fixes the chance that a facet mirrors, P = L/R, and the count in a
// patch of N facets is binomial(N, P), Poisson for small P: its value L·k/(N·P) has expectation
// L, so the sparkle keeps the expected-value filter's energy, and each sparkle is exactly as
// bright as a real facet of that size mirroring the real sun.
//
// The draw is anchored in texture space: a patch is a texel of a mip level near the pixel's
// footprint, hashed with its level and with the half vector's bin in slope space, one bin as
// wide as the cone of half vectors the sun's disc spans (half its angular radius: a facet
// mirrors the sun while the half vector stays within that cone). Camera motion leaves the
// patches and their counts where they are; another half vector (the other eye) falls into
// another bin and draws other facets, as in life.

const float FACET_SIZE_M = 200.0e-6;       // edge of one facet of a grain (metres)       // edge of one facet of a grain (metres)       // edge of one facet of a grain (metres)       // edge of one facet of a grain (metres)       // edge of one facet of a grain (metres)       // edge of one facet of a grain (metres)       // edge of one facet of a grain (metres)       // edge of one facet of a grain (metres)       // edge of one facet of a grain (metres)       // edge of one facet of a grain (metres)       // edge of one facet of a grain (metres)       // edge of one facet of a grain (metres)       // edge of one facet of a grain (metres)
const float LIGHT_ANGULAR_RADIUS = 0.00465; // the sun's (and the moon's) real angular radius

// Half vectors spanned by a light disc of angular radius r around the mirror direction have
// angular radius r/2; slopes stretch angles by 1 + |b|² about slope b (as the lobe's width does).
float cone_radius_slope(vec2 b_half) {
    return 0.5 * LIGHT_ANGULAR_RADIUS * (1.0 + dot(b_half, b_half));
}

// The light's solid angle (a disc of LIGHT_ANGULAR_RADIUS).
const float LIGHT_SOLID_ANGLE = PI * LIGHT_ANGULAR_RADIUS * LIGHT_ANGULAR_RADIUS;

// The bin of half-vector slopes a facet's mirror state holds for: a grid one cone across,
// offset by a random offset in [0, 1)² (per patch, so that bin edges are not lines across the
// image).
ivec2 half_vector_bin(vec2 b_half, vec2 offset) {
    return ivec2(floor(b_half / (2.0 * cone_radius_slope(b_half)) + offset));
}

// A uniform number in (0, 1), never 0 or 1.
float open01(uint h) { return (float(h >> 8u) + 0.5) / 16777216.0; }

// A Poisson-distributed count of mean lambda from one hash, by inverting the distribution
// function; past 24 the normal approximation (Box–Muller on two 16-bit halves).
float poisson_count(float lambda, uint h) {
    if (!(lambda > 0.0)) return 0.0;
    if (lambda > 24.0) {
        float u1 = (float(h >> 16u) + 0.5) / 65536.0;
        float u2 = float(h & 0xffffu) / 65536.0;
        float z = sqrt(-2.0 * log(u1)) * cos(6.28318530718 * u2);
        return max(floor(lambda + sqrt(lambda) * z + 0.5), 0.0);
    }
    // No facet is the common case; its probability 1 − e^(−λ) is taken without cancellation.
    float v = open01(h);
    float any_facet = lambda < 1e-3 ? lambda * (1.0 - 0.5 * lambda) : 1.0 - exp(-lambda);
    if (v >= any_facet) return 0.0;
    float u = 1.0 - v;
    float p = exp(-lambda);
    float cdf = p;
    float k = 0.0;
    for (int i = 0; i < 64 && u > cdf; ++i) {
        k += 1.0;
        p *= lambda / k;
        cdf += p;
    }
    return max(k, 1.0);
}

// The drawn count of mirroring facets over its expectation, for one light.
//   tc: texture coordinates (tiles, the texture repeats every tile)
//   texels: the pixel's footprint in finest-level texels;  texture_size: texels per tile
//   facet_texels: a facet's edge in finest-level texels
//   mirror_chance: P, the chance that one facet mirrors the light (expected radiance / R)
//   light: 0 sun, 1 moon (their facets are drawn independently)
float sparkle_ratio(vec2 tc, float texels, float texture_size, float facet_texels, vec2 b_half,
                    float mirror_chance, uint light) {
    // Patches as large as the footprint (no smaller than a facet): between two mip levels the
    // coarser is taken with the fractional level's probability, decided per coarse patch, which
    // keeps the count's spread near that of a patch the pixel's size.
    float top = log2(texture_size);
    float level = clamp(log2(max(max(texels, facet_texels), 1e-8)), 0.0, top);
    float fine = floor(level);
    float coarse = min(fine + 1.0, top);
    vec2 wrapped = fract(tc);
    ivec2 coarse_cell = ivec2(wrapped * exp2(top - coarse));
    bool take_coarse = hash01(hash_cell(coarse_cell, uint(coarse) * 4u + 1u)) < level - fine;
    float chosen = take_coarse ? coarse : fine;
    ivec2 cell = ivec2(wrapped * exp2(top - chosen));
    float cell_texels = exp2(chosen);
    float facets = max(cell_texels * cell_texels / (facet_texels * facet_texels), 1.0);
    float lambda = facets * min(mirror_chance, 1.0);
    if (!(lambda > 0.0)) return 1.0;
    // Half-vector bins one cone across, their grid offset per patch so that bin edges are not
    // lines across the image.
    uint patch_key = hash_cell(cell, uint(chosen) * 4u + light * 2u);
    vec2 offset = vec2(open01(patch_key), open01(lowbias32(patch_key)));
    ivec2 bin = half_vector_bin(b_half, offset);
    float count = poisson_count(lambda, hash_cell(bin, patch_key));
    return count / lambda;
}
