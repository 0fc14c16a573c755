// Glints as the sun mirrored in grain facets, drawn per footprint cell (included by
// sand_surface.glsl after common.glsl).
//
// A grain's surface is a mosaic of facets, the largest of the preset's facet size a and smaller
// ones down to a/FACET_SIZE_RANGE (below). A facet that mirrors the sun into the eye shows the
// sun's radiance times quartz's Fresnel reflectance, R = F·E/Ω (E the sun's irradiance, Ω its
// solid angle), over its own area: a pixel of area A holding a facet of area a' gets R·a'/A.
// The material's expected glint radiance L (the footprint's slope moments) therefore fixes the
// chance that a facet mirrors, P = L/R, and the count in a patch of N facets is binomial(N, P),
// Poisson for small P: its value L·Σa'/(N·P·ā) has expectation L, so the sparkle keeps the
// expected-value filter's energy, and each sparkle is exactly as bright as a real facet of its
// size mirroring the real sun.
//
// The draw is anchored on the ground: a patch is a cell of the ground's own grid (not the
// tile's) as wide as a texel of a mip level near the pixel's footprint, hashed with its level
// and with the half vector's bin in slope space, one bin as wide as the cone of half vectors
// the sun's disc spans (half its angular radius: a facet mirrors the sun while the half vector
// stays within that cone). Camera motion leaves the patches and their counts where they are;
// another half vector (the other eye) falls into another bin and draws other facets, as in
// life.

uniform float u_facet_size;  // edge of the largest facets of a grain, µm

// Facet edges spread log-uniformly from the preset's size down to FACET_SIZE_RANGE times smaller
// (#defined by material.py), each octave holding an equal share of the surface, as on a
// fractured crystal's faces. Close up the small ones sparkle in many pixels, further away the
// large ones still outshine their pixel. FACETS_PER_LARGEST (#defined by material.py, which the
// exports' glint parameters share) is how many facets the area of one largest facet holds.
const float FACET_AREA_RANGE = FACET_SIZE_RANGE * FACET_SIZE_RANGE;

float facet_size_m() { return u_facet_size * 1.0e-6; }
// LIGHT_ANGULAR_RADIUS (#defined by material.py): the sun's (and the moon's) real angular radius.

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

// The area of a facet, in largest facets', from a hash: by number, 1/r² is uniform in [1, R²].
float facet_area(uint h) {
    return 1.0 / (1.0 + (FACET_AREA_RANGE - 1.0) * open01(h));
}

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

// At most this many mirroring facets of a patch are placed one by one.
const int PLACED_FACETS = 16;

// The patches a pixel's footprint draws its facets from: texels of a mip level at least as wide
// as the footprint, so that it overlaps at most 2×2 of them. Between two levels the coarser is
// taken with the fractional level's chance, decided per coarse patch, so that zooming changes
// patches a few at a time. Levels go past the top of the texture's pyramid far away (patches
// of several tiles). The moments a patch draws from repeat with the tile, its draw does not:
// the sparkles show no tile grid, and patches wider than a tile each draw their own.
struct Patches {
    bool valid;
    float level;          // of the patches (log2 of their edge in finest-level texels)
    float size;           // their edge in finest-level texels
    float facets;         // a patch's area in largest facets'
    float pixel_facets;   // the footprint's area in largest facets'
    ivec2 first;          // the lower-left patch the footprint overlaps
    vec2 texel;           // the footprint's centre, finest-level texels of the ground
    vec2 extent;          // its bounding box
    mat2 to_pixel;        // texels from the centre → footprint coordinates (|a|, |b| ≤ ½ inside)
};

//   tc, dx, dy: texture coordinates (tiles; the texture repeats every tile) and their screen
//       derivatives: the footprint is the parallelogram tc + a·dx + b·dy, |a|, |b| ≤ ½
//   texture_size: finest-level texels per tile;  facet_texels: a facet's edge in those texels
Patches footprint_patches(vec2 tc, vec2 dx, vec2 dy, float texture_size, float facet_texels) {
    Patches p;
    vec2 px = dx * texture_size, py = dy * texture_size;
    float det = px.x * py.y - px.y * py.x;
    float facet_area = facet_texels * facet_texels;
    p.valid = abs(det) > 1e-12;
    p.pixel_facets = abs(det) / facet_area;
    p.to_pixel = p.valid ? inverse(mat2(px, py)) : mat2(0.0);
    p.extent = abs(px) + abs(py);
    float level = max(log2(max(max(p.extent.x, p.extent.y), facet_texels)), 0.0);
    float fine = ceil(level);
    p.texel = tc * texture_size;
    ivec2 coarse_cell = ivec2(floor(p.texel / exp2(fine + 1.0)));
    uint coarse_key = hash_cell(coarse_cell, uint(fine + 1.0) * 4u + 1u);
    bool take_coarse = hash01(coarse_key) < level - floor(level);
    p.level = take_coarse ? fine + 1.0 : fine;
    p.size = exp2(p.level);
    p.facets = p.size * p.size / facet_area;
    p.first = ivec2(floor((p.texel - 0.5 * p.extent) / p.size));
    return p;
}

// Whether a patch meets the footprint's bounding box (of the 2×2, often only one or two do).
bool patch_overlaps(Patches p, ivec2 cell) {
    vec2 lo = max(vec2(cell) * p.size, p.texel - 0.5 * p.extent);
    vec2 hi = min(vec2(cell + 1) * p.size, p.texel + 0.5 * p.extent);
    return all(greaterThan(hi, lo));
}

// The share of a patch's area that lies in the pixel's footprint, taken from the footprint's
// bounding box (which the 2×2 patches tile, so the shares of a footprint's patches add up to its
// own area exactly).
float patch_share(Patches p, ivec2 cell) {
    vec2 lo = max(vec2(cell) * p.size, p.texel - 0.5 * p.extent);
    vec2 hi = min(vec2(cell + 1) * p.size, p.texel + 0.5 * p.extent);
    vec2 side = max(hi - lo, vec2(0.0));
    float box = max(p.extent.x * p.extent.y, 1e-30);
    return side.x * side.y / box * (p.pixel_facets / p.facets);
}

// Texture coordinates (tiles) of a patch's centre: where its mip texel is.
vec2 patch_centre(Patches p, ivec2 cell, float texture_size) {
    return (vec2(cell) + 0.5) * p.size / texture_size;
}

// The mirroring facets of a patch that lie in the pixel's footprint, as their area in largest
// facets'. lambda is the patch's area in largest facets times their chance to mirror, a property
// of the patch alone; the count is Poisson with FACETS_PER_LARGEST times that mean, each facet of
// a hashed size, so the area's expectation is lambda. They are placed at hashed points of the
// patch, so a sparkle crosses from pixel to pixel as the surface moves under the camera, and the
// pixel's count is Poisson with its own mean, as real facets give.
//   light: 0 sun, 1 moon (their facets are drawn independently)
float facets_in_pixel(Patches p, ivec2 cell, float lambda, vec2 b_half, uint light) {
    if (!(lambda > 0.0)) return 0.0;
    uint patch_key = hash_cell(cell, uint(p.level) * 4u + light * 2u);
    // Half-vector bins one cone across, their grid offset per patch so that bin edges are not
    // lines across the image.
    vec2 offset = vec2(open01(patch_key), open01(lowbias32(patch_key)));
    uint key = hash_cell(half_vector_bin(b_half, offset), patch_key);
    // Past PLACED_FACETS, that many stand for all of them, each weighing facets/placed: the
    // expectation is kept and every pixel still counts points of its own, anchored in texture
    // space. (Drawing a pixel's share with a hash of the patch alone would give every pixel in
    // it the same quantile: the patch would show as a flat block.)
    float facets = poisson_count(lambda * FACETS_PER_LARGEST, key);
    float placed = min(facets, float(PLACED_FACETS));
    float weight = facets / max(placed, 1.0);
    float count = 0.0;
    for (int k = 0; k < PLACED_FACETS; ++k) {
        if (float(k) >= placed) break;
        key = lowbias32(key + 0x9e3779b9u);
        vec2 at = (vec2(cell) + vec2(open01(key), open01(lowbias32(key)))) * p.size;
        vec2 ab = p.to_pixel * (at - p.texel);
        bool inside = abs(ab.x) <= 0.5 && abs(ab.y) <= 0.5;
        count += inside ? facet_area(lowbias32(key ^ 0x68e31da4u)) : 0.0;
    }
    count *= weight;
    if (facets <= float(PLACED_FACETS)) return count;
    // The stand-ins spread a pixel's count as PLACED_FACETS points would, √(facets/placed) times
    // wider than the facets they stand for: a pixel of millions of mirroring facets would show
    // the noise of sixteen. Their deviation from the pixel's mean area (the patch's facets over
    // its share in the footprint, each facet 1/FACETS_PER_LARGEST on average) is narrowed to
    // that of the facets themselves, which keeps the mean.
    float mean = facets / FACETS_PER_LARGEST * patch_share(p, cell);
    return max(mean + (count - mean) * sqrt(placed / facets), 0.0);
}
