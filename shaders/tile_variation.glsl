// The grain tile laid without a visible repeat (included by sand_surface.glsl after common.glsl).
//
// The ground is covered by a triangle grid whose every vertex holds its own copy of the tile:
// shifted by a hashed offset and turned or mirrored by one of the square's eight symmetries.
// Those eight map every grain texture onto itself exactly (the moments of slopes and normals
// only swap or change sign), and the copy is shaded in its own axes (in_copy_axes), so a copy
// is shaded exactly as the tile is. A point shows one copy: its nearest vertex's, except in a
// band along the edges of the vertices' hexagons, where the grains of neighbouring copies lie
// over one another, each grain whole or not at all (grain_rank). Up close the border between
// copies runs along grain outlines, never along a line; far away the copies together hold the
// tile's moments symmetrized over the eight (shade_far shades that mixture), so no border shows
// and close and far agree for any tile, even one grain across. One copy per point keeps the
// cost of one: the glints, the relief and the footprint's moments are those of the winning copy.
// The offsets reach past the tile (TILE_COPY_SPREAD tiles), so sparkles, hashed on the ground's
// texel grid, are drawn anew in every copy too.

uniform int u_tile_variation;  // 1: copies varied per vertex; 0: the tile repeats as it is
#if defined LAYER_GRAIN_FLOATS
// For engines whose images hold no integers (Godot): layer + 1 and the identity's low and high
// 16 bits as floats, each exact.
uniform sampler2D u_layer_grain;

uvec2 layer_and_grain(ivec2 texel) {
    uvec3 v = uvec3(texelFetch(u_layer_grain, texel, 0).xyz + 0.5);
    return uvec2(v.x, v.y | (v.z << 16u));
}
#else
uniform usampler2D u_layer_grain;  // the grains' (layer + 1, identity) per finest-level texel

uvec2 layer_and_grain(ivec2 texel) {
    return texelFetch(u_layer_grain, texel, 0).xy;
}
#endif

// TILE_COPY_SPACING (tiles between neighbouring vertices) and TILE_COPY_BIAS (a point's weight
// for its vertex, against a grain's rank) are #defined from sand_editor/render/tile_copies.py.
const float TILE_COPY_SPREAD = 64.0;   // tiles over which the copies' offsets range
const uint TILE_COPY_KEY = 0x5bd1e995u;

// The tile's normal moments (nx, ny, nx², ny²) as its copies show them together, the eight
// symmetries equally often: no mean tilt, and the two axes' squares sharing their sum.
vec4 copies_normal_moments(vec4 n) {
    float square = 0.5 * (n.z + n.w);
    return vec4(0.0, 0.0, square, square);
}

struct TileCopy {
    vec2 tc;    // where the point lies in the copy (tiles)
    mat2 axes;  // the copy's symmetry: copy coordinates = axes · ground's + offset
    uint key;   // the copy's hash, from its vertex
};

// The symmetry (swap, then mirror in x, in y) and offset of vertex `vertex`'s copy.
TileCopy copy_of_vertex(ivec2 vertex, vec2 tc) {
    uint h = hash_cell(vertex, TILE_COPY_KEY);
    TileCopy c;
    c.key = h;
    vec2 sign_xy = vec2((h & 2u) != 0u ? -1.0 : 1.0, (h & 4u) != 0u ? -1.0 : 1.0);
    mat2 swap = (h & 1u) != 0u ? mat2(0.0, 1.0, 1.0, 0.0) : mat2(1.0);
    c.axes = mat2(sign_xy.x, 0.0, 0.0, sign_xy.y) * swap;
    vec2 offset = vec2(hash01(lowbias32(h ^ 0x27d4eb2fu)), hash01(lowbias32(h ^ 0x165667b1u)));
    c.tc = c.axes * tc + offset * TILE_COPY_SPREAD;
    return c;
}

// The three vertices of the triangle holding tc and their barycentric weights.
void copy_vertices(vec2 tc, out ivec2 vertex[3], out vec3 weight) {
    // Skewed coordinates of the grid of spacing TILE_COPY_SPACING (axes at 0° and 60°).
    vec2 p = tc / TILE_COPY_SPACING;
    vec2 q = vec2(p.x - p.y * 0.57735027, p.y * 1.15470054);
    ivec2 base = ivec2(floor(q));
    vec2 f = q - floor(q);
    if (f.x + f.y < 1.0) {
        vertex[0] = base;
        vertex[1] = base + ivec2(1, 0);
        vertex[2] = base + ivec2(0, 1);
        weight = vec3(1.0 - f.x - f.y, f.x, f.y);
    } else {
        vertex[0] = base + ivec2(1, 1);
        vertex[1] = base + ivec2(0, 1);
        vertex[2] = base + ivec2(1, 0);
        weight = vec3(f.x + f.y - 1.0, 1.0 - f.x, 1.0 - f.y);
    }
}

// A copy's grain at its tc, ranked by a hash of the grain (its layer and identity, finest level)
// and of the copy: independent of how the grain looks, so that the copies' borders show the tile's
// own mix of grains (ranking by height would favour the top layer's, and draw the borders as a
// lighter honeycomb).
float grain_rank(TileCopy c) {
    ivec2 texel = min(ivec2(floor(fract(c.tc) * u_texture_size)), ivec2(int(u_texture_size) - 1));
    uvec2 layer_grain = layer_and_grain(texel);
    return hash01(lowbias32(layer_grain.y ^ lowbias32(layer_grain.x ^ c.key)));
}

// The copy that shows at tc, where a pixel spans 2^cells_lod grain cells: its nearest vertex's,
// or in the band along the hexagons' edges the copy whose grain there ranks highest once each
// copy's weight is added. While grains are a pixel or more (cells_lod ≤ 0) the band is as wide
// at every distance, so a pixel shows the copy that the smaller pixels of a nearer or sharper
// view show there; once grains fall below a pixel it narrows (as 2^−cells_lod), since there a
// hash per grain would only flicker.
TileCopy tile_copy(vec2 tc, float cells_lod) {
    ivec2 vertex[3];
    vec3 weight;
    copy_vertices(tc, vertex, weight);
    int nearest = weight.x >= weight.y ? (weight.x >= weight.z ? 0 : 2)
                                       : (weight.y >= weight.z ? 1 : 2);
    TileCopy own = copy_of_vertex(vertex[nearest], tc);
    TileCopy best = own;
    float bias = TILE_COPY_BIAS * exp2(max(cells_lod, 0.0));
    // Away from the hexagons' edges no rank outweighs the nearest vertex: no fetch is made.
    float w_best = weight[nearest];
    float w_least = min(min(weight.x, weight.y), weight.z);
    float w_second = weight.x + weight.y + weight.z - w_best - w_least;
    if (bias * (w_best - w_second) < 1.0) {
        float best_score = -1.0;
        for (int i = 0; i < 3; ++i) {
            if (bias * (w_best - weight[i]) >= 1.0) continue;
            TileCopy c = own;  // (no ?: on a struct: GLSL ES refuses it)
            if (i != nearest) c = copy_of_vertex(vertex[i], tc);
            float score = grain_rank(c) + bias * weight[i];
            if (score > best_score) {
                best_score = score;
                best = c;
            }
        }
    }
    return best;
}
