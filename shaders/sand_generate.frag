#version 330 core
#include "common.glsl"
// Layered, thresholded, tileable 2D Worley grains: the GLSL twin of
// sand_editor/generator/reference.py (see noise.py for the model). Every constant and every step
// here mirrors that file; change both together. PROFILE_OFFSET, PROFILE_SCALE, ANCHOR_DEPTH and
// CAP_FLOOR (and KEY_STRIDE, ANCHOR0, ANCHOR1) are #defined from noise.py when the program is built.

uniform int u_size;          // texture edge in pixels
uniform int u_period;        // cells per tile edge
uniform int u_layers;
uniform uint u_seed_key;    // lowbias32(seed), mixed into every cell key
uniform float u_threshold;
uniform float u_grain_reach2; // roundness: the radius² of a grain's ball (noise.py)
uniform float u_jitter;

// Colour and glint follow from the owning layer and the grain word (noise.py: grain_colour_index,
// glint_value), so palette edits never need the grains generated again.
layout(location = 0) out vec4 out_normal_height;
layout(location = 1) out uvec2 out_layer_grain; // layer + 1 (0 in gaps), grain word


// One feature point of neighbour cell o of the pixel's cell: its offset to the pixel p − f (in
// cells), its squared 3D distance, and its word. Point k of a cell sits around anchor k.
struct Point { vec2 delta; float f; uint word; };

Point feature_point(ivec2 o, int k, ivec2 cell, vec2 frac, int layer) {
    ivec2 c = cell + o;  // wrap into the tile without the slow integer modulo
    c += (ivec2(lessThan(c, ivec2(0))) - ivec2(greaterThanEqual(c, ivec2(u_period)))) * u_period;
    // One 32-bit word per point: x, y, depth and glint value, 8 bits each (noise.py).
    uint key = (uint(c.y) * uint(u_period) + uint(c.x)) * KEY_STRIDE + uint(layer) * 2u + uint(k);
    uint word = lowbias32(key ^ u_seed_key);
    vec2 anchor = k == 0 ? ANCHOR0 : ANCHOR1;
    // Bytes placed in the top of a float's mantissa: 1 + byte/256 exactly, without an
    // integer-to-float conversion (which AVX2 lacks for unsigned integers).
    vec3 bytes = uintBitsToFloat(0x3f800000u | uvec3((word & 0xffu) << 15u, (word & 0xff00u) << 7u,
                                                     (word & 0xff0000u) >> 1u)) - 1.0;
    vec2 position = bytes.xy;
    float depth = ANCHOR_DEPTH + u_jitter * (bytes.z - ANCHOR_DEPTH);
    vec2 delta = frac - ((anchor + u_jitter * (position - anchor)) + vec2(o));
    return Point(delta, dot(delta, delta) + depth * depth, word);
}

// Keeps the two smallest squared distances and which points gave them. Only indices are
// carried: llvmpipe runs both sides of every branch, so carrying offsets would cost more than
// computing the two winners again once the owning layer is known.
void consider(float f, int index, inout float f1, inout float f2, inout int i1, inout int i2) {
    bool nearest = f < f1;
    bool second = !nearest && f < f2;
    i2 = nearest ? i1 : (second ? index : i2);
    f2 = nearest ? f1 : (second ? f : f2);
    i1 = nearest ? index : i1;
    f1 = nearest ? f : f1;
}

// Point index: (ox + 1) + 3·(oy + 1) + 9·k for point k of neighbour cell (ox, oy).
void visit(ivec2 o, ivec2 cell, vec2 frac, int layer,
           inout float f1, inout float f2, inout int i1, inout int i2) {
    int base = (o.x + 1) + 3 * (o.y + 1);
    consider(feature_point(o, 0, cell, frac, layer).f, base, f1, f2, i1, i2);
    consider(feature_point(o, 1, cell, frac, layer).f, base + 9, f1, f2, i1, i2);
}

Point indexed_point(int index, ivec2 cell, vec2 frac, int layer) {
    int k = index >= 9 ? 1 : 0;
    int rest = index - 9 * k;
    int oy = rest >= 6 ? 1 : (rest >= 3 ? 0 : -1);
    int ox = rest - 3 * (oy + 1) - 1;
    return feature_point(ivec2(ox, oy), k, cell, frac, layer);
}

void main() {
    // The pixel centre (x + ½)/size · period split into cell and fraction. Numerator and
    // denominator are integers below 2^24, exact in float; a quotient that is not an integer is at
    // least 1/denominator from one, far more than its rounding error, so floor() is exact.
    // (Integer division would be exact too, but llvmpipe runs it one lane at a time.)
    vec2 numerator = (2.0 * floor(gl_FragCoord.xy) + 1.0) * float(u_period);
    float denominator = 2.0 * float(u_size);
    ivec2 cell = ivec2(floor(numerator / denominator));
    vec2 frac = (numerator - vec2(cell) * denominator) / denominator;

    int owner = -1;
    float owner_profile = 0.0;
    int owner_i1 = -1;
    for (int layer = 0; layer < u_layers; ++layer) {
        float f1 = 1.0, f2 = 1.0;   // the reference clamps squared distances at 1
        int i1 = -1, i2 = -1;
        // The own cell first, then edges, then corners; the reference backend offers the
        // points in the same order, so ties break alike. (Written out: llvmpipe keeps a
        // looped-over const array in memory.)
        visit(ivec2(0, 0), cell, frac, layer, f1, f2, i1, i2);
        visit(ivec2(-1, 0), cell, frac, layer, f1, f2, i1, i2);
        visit(ivec2(1, 0), cell, frac, layer, f1, f2, i1, i2);
        visit(ivec2(0, -1), cell, frac, layer, f1, f2, i1, i2);
        visit(ivec2(0, 1), cell, frac, layer, f1, f2, i1, i2);
        visit(ivec2(-1, -1), cell, frac, layer, f1, f2, i1, i2);
        visit(ivec2(1, -1), cell, frac, layer, f1, f2, i1, i2);
        visit(ivec2(-1, 1), cell, frac, layer, f1, f2, i1, i2);
        visit(ivec2(1, 1), cell, frac, layer, f1, f2, i1, i2);
        float profile = PROFILE_OFFSET + PROFILE_SCALE * (sqrt(f2) - sqrt(f1));
        if (profile > u_threshold && f1 < u_grain_reach2) {
            owner = layer;
            owner_profile = profile;
            owner_i1 = i1;
            break;
        }
    }

    out_normal_height = vec4(0.0, 0.0, 1.0, 0.0);
    out_layer_grain = uvec2(0u);
    if (owner >= 0) {
        // (no ?: on a struct: GLSL ES, which the same source compiles as, refuses it)
        Point nearest = Point(vec2(0.0), 1.0, 0u);
        if (owner_i1 >= 0) nearest = indexed_point(owner_i1, cell, frac, owner);
        // The grain is the cap of a ball of radius² u_grain_reach2 around its feature point: its
        // normal points from the ball's centre, straight up over the point (noise.py).
        float cap = sqrt(max(u_grain_reach2 - dot(nearest.delta, nearest.delta),
                             CAP_FLOOR * CAP_FLOOR * u_grain_reach2));
        out_normal_height = vec4(normalize(vec3(nearest.delta, cap)), owner_profile);
        uint word = nearest.word;
        out_layer_grain = uvec2(uint(owner + 1), word);
    }
}
