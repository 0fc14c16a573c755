// The benchmark's own glint filters, compiled only into the probe's program (sand_editor/bench/
// probe.py), never into the product's: sand_surface.glsl includes this file only when SAND_PROBE
// is defined, and probe.py defines the FILTER_* values from its GLINT_FILTERS table.
//
// Filters: 0 ours (sparkles drawn from the footprint's moments); 1 the expected value of those
// moments alone; 2 the reference's N×N multisampling of mipmapped normals; 3 none (one tap of the
// finest level); 4 ground truth (every facet in the pixel, explicitly, of its own size); 5 and 6: the expectations
// of 0 and 4 over their draws (no sparkle), which measure energy free of the draws' noise; 7 the
// density that one mirroring facet of filter 0, of the largest size, gives its pixel (the draw's
// largest unit).
uniform int u_glint_filter;
// The reference's kernel: N×N taps, this many pixels apart (its saved preview material).
const int REFERENCE_SAMPLES = 7;
const float REFERENCE_SPREAD = 0.305;
uniform int u_ground_truth_samples;  // K: K×K jittered samples of albedo and slope

// A random point in stratum (i, j) of a k×k grid over the pixel, centred on it. Regular taps
// would alias against the texture's tiling far away; jittered ones keep the estimate unbiased.
vec2 stratum_offset(int i, int j, int k) {
    uint h = lowbias32(uint(gl_FragCoord.x) * 1973u + uint(gl_FragCoord.y) * 9277u
                       + uint(i) * 26699u + uint(j) * 7919u);
    vec2 r = vec2(float(h & 0xffffu), float(h >> 16u)) / 65536.0;
    return (vec2(float(i), float(j)) + r) / float(k) - 0.5;
}

// Facets per axis the ground truth visits at most in one pixel; past that it visits every
// n-th row and column (only far views, where a pixel holds tens of thousands of facets).
const int GROUND_TRUTH_FACETS = 128;

// The area (in largest facets') of the facets of one largest facet's cell that mirror a light:
// the cell holds a Poisson number of facets of random sizes, as the draw assumes
// (glint_facets.glsl), each mirroring on its own with the chance. `surface` keys the facets,
// `bin` their mirror states in the half vector's bin.
float mirrored_area(uint surface, uint bin, float chance) {
    float count = poisson_count(FACETS_PER_LARGEST, surface);
    float area = 0.0;
    for (int k = 0; k < 64; ++k) {
        if (float(k) >= count) break;
        surface = lowbias32(surface + 0x9e3779b9u);
        bin = lowbias32(bin + 0x9e3779b9u);
        area += open01(bin) < chance ? facet_area(surface) : 0.0;
    }
    return area;
}

// The light the facets of a largest facet's cell mirror, for each light: with the chance its
// grain's facet density gives them (at the cell's centre, on the finest level), drawn anew in
// every half-vector bin; without `draw`, the chance.
vec2 facet_mirrors(ivec2 facet, float per_tile, Footprint f, bool draw) {
    // The finest level as the renderer shows it up close: texels interpolated.
    vec2 tc = (vec2(facet) + 0.5) / per_tile;
    float w = textureLod(u_glint_moments, tc, 0.0).x;
    if (w < 1e-6) return vec2(0.0);
    vec2 b = textureLod(u_spread_moments, tc, 0.0).zw;
    HalfVector h0, h1;
    half_vectors_at(f, tc - f.tc, h0, h1);
    uint key = hash_cell(ivec2(mod(vec2(facet), per_tile)), 0x5eedu);
    vec2 offset = vec2(open01(key), open01(lowbias32(key)));
    vec2 mirrors = vec2(0.0);
    if (h0.valid) {
        float chance = min(mirror_chance(w * facet_density(b, h0.slope, h0.variance), h0), 1.0);
        uint bin = hash_cell(half_vector_bin(h0.slope, offset), key);
        mirrors.x = draw ? mirrored_area(key, bin, chance) : chance;
    }
    if (h1.valid) {
        float chance = min(mirror_chance(w * facet_density(b, h1.slope, h1.variance), h1), 1.0);
        uint moon_key = lowbias32(key ^ 0x9e3779b9u);
        uint bin = hash_cell(half_vector_bin(h1.slope, offset), moon_key);
        mirrors.y = draw ? mirrored_area(key, bin, chance) : chance;
    }
    return mirrors;
}

// Ground truth: every facet whose centre lies in the pixel's footprint (a parallelogram in
// texture space), each mirroring or not as drawn by facet_mirrors; returned as a density of
// mirroring slopes (mirroring share over the chance per unit of density), so that it compares
// with the other filters one to one.
vec2 ground_truth_factors(Footprint f, HalfVector h0, HalfVector h1, bool draw) {
    float per_tile = max(floor(1.0 / (facet_size_m() * u_uv_scale) + 0.5), 1.0);
    vec2 centre = f.tc * per_tile;
    vec2 dx = f.dx * per_tile, dy = f.dy * per_tile;
    vec2 extent = 0.5 * (abs(dx) + abs(dy));
    ivec2 lo = ivec2(floor(centre - extent)), hi = ivec2(floor(centre + extent));
    int span = max(hi.x - lo.x, hi.y - lo.y) + 1;
    int stride = max(1, (span + GROUND_TRUTH_FACETS - 1) / GROUND_TRUTH_FACETS);
    float det = dx.x * dy.y - dx.y * dy.x;
    if (abs(det) < 1e-12) return vec2(0.0);
    mat2 to_pixel = inverse(mat2(dx, dy));
    vec2 mirrored = vec2(0.0);
    float inside = 0.0;
    for (int y = lo.y; y <= hi.y; y += stride) {
        for (int x = lo.x; x <= hi.x; x += stride) {
            ivec2 facet = ivec2(x, y);
            vec2 ab = to_pixel * (vec2(facet) + 0.5 - centre);
            if (abs(ab.x) > 0.5 || abs(ab.y) > 0.5) continue;
            inside += 1.0;
            mirrored += facet_mirrors(facet, per_tile, f, draw);
        }
    }
    if (inside < 1.0) {
        // A footprint smaller than a facet: the facet under the pixel's centre.
        mirrored = facet_mirrors(ivec2(floor(centre)), per_tile, f, draw);
        inside = 1.0;
    }
    vec2 per_unit = vec2(mirror_chance(1.0, h0), mirror_chance(1.0, h1));
    return vec2(per_unit.x > 0.0 ? mirrored.x / (inside * per_unit.x) : 0.0,
                per_unit.y > 0.0 ? mirrored.y / (inside * per_unit.y) : 0.0);
}

// The densities of mirroring slopes of two lights over the pixel, by the filter the probe
// selected.
vec2 probe_glint_factors(Footprint f, HalfVector h0, HalfVector h1, bool sparkle) {
    vec2 glint = vec2(0.0);
    if (u_glint_filter == FILTER_OURS) {
        glint = sparkle ? sparkling_factors(f, h0, h1, true)
                        : expected_factors(f, h0, h1, REFERENCE_FOOTPRINT);
    } else if (u_glint_filter == FILTER_OURS_MEAN) {
        glint = sparkling_factors(f, h0, h1, false);
    } else if (u_glint_filter == FILTER_EXPECTED) {
        glint = expected_factors(f, h0, h1, REFERENCE_FOOTPRINT);
    } else if (u_glint_filter == FILTER_REFERENCE) {
        // N×N taps spaced by spread × the pixel's derivatives, Gaussian-weighted; each tap
        // evaluates the facets at the mip-averaged normal and whether the averaged g is clear.
        int n = REFERENCE_SAMPLES;
        float half_n = float(n - 1) * 0.5;
        float sigma = max(half_n, 0.5) * 0.5;
        float total = 0.0;
        for (int j = 0; j < n; ++j) {
            for (int i = 0; i < n; ++i) {
                vec2 o = vec2(float(i) - half_n, float(j) - half_n);
                float weight = exp(-0.5 * dot(o, o) / (sigma * sigma));
                vec2 tc = f.tc + REFERENCE_SPREAD * (o.x * f.dx + o.y * f.dy);
                vec2 b = textureGrad(u_spread_moments, tc, f.dx, f.dy).zw;
                float w = textureGrad(u_glint_moments, tc, f.dx, f.dy).x;
                glint += weight * w * densities(h0, h1, b);
                total += weight;
            }
        }
        glint /= total;
    } else if (u_glint_filter == FILTER_ONE_FACET) {
        float facet_texels = facet_size_m() * u_uv_scale * u_texture_size;
        Patches p = footprint_patches(f.tc, f.dx, f.dy, u_texture_size, facet_texels);
        vec2 per_facet = vec2(mirror_chance(1.0, h0), mirror_chance(1.0, h1)) * p.pixel_facets;
        glint = vec2(per_facet.x > 0.0 ? 1.0 / per_facet.x : 0.0,
                     per_facet.y > 0.0 ? 1.0 / per_facet.y : 0.0);
    } else if (u_glint_filter == FILTER_NONE) {
        float w = textureLod(u_glint_moments, f.tc, 0.0).x;
        glint = w < 1e-6 ? vec2(0.0) : w * densities(h0, h1, textureLod(u_spread_moments, f.tc, 0.0).zw);
    } else {
        glint = ground_truth_factors(f, h0, h1, u_glint_filter == FILTER_GROUND_TRUTH);
    }
    return glint;
}

// The ground truth's and "none"'s albedo, mean slope and normal moments (true); false
// for other filters.
bool probe_footprint_surface(Footprint f, out vec3 albedo, out vec2 slope, out vec4 normals) {
    if (u_glint_filter == FILTER_GROUND_TRUTH) {
        int k = max(u_ground_truth_samples, 1);
        albedo = vec3(0.0);
        slope = vec2(0.0);
        normals = vec4(0.0);
        for (int j = 0; j < k; ++j) {
            for (int i = 0; i < k; ++i) {
                vec2 o = stratum_offset(i, j, k);
                vec2 tc = f.tc + o.x * f.dx + o.y * f.dy;
                albedo += textureLod(u_albedo, tc, 0.0).rgb;
                vec2 b = textureLod(u_spread_moments, tc, 0.0).zw;
                slope += b;
                vec2 n = b / sqrt(1.0 + dot(b, b));
                normals += vec4(n, n * n);
            }
        }
        albedo /= float(k * k);
        slope /= float(k * k);
        normals /= float(k * k);
        return true;
    }
    if (u_glint_filter == FILTER_NONE) {
        albedo = textureLod(u_albedo, f.tc, 0.0).rgb;
        slope = textureLod(u_spread_moments, f.tc, 0.0).zw;
        vec2 n = slope / sqrt(1.0 + dot(slope, slope));
        normals = vec4(n, n * n);
        return true;
    }
    return false;
}
