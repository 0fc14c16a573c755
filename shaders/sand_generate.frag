#version 330 core
// Layered, thresholded, tileable 2D Worley grains: the GLSL twin of
// sand_editor/generator/reference.py (see noise.py for the model). Every constant and every step
// here mirrors that file; change both together. PROFILE_OFFSET, PROFILE_SCALE and ANCHOR_DEPTH
// are #defined from noise.py when the program is built.

uniform int u_size;          // texture edge in pixels
uniform int u_period;        // cells per tile edge
uniform int u_layers;
uniform uint u_seed_key;    // lowbias32(seed), mixed into every cell key
uniform float u_threshold;
uniform float u_grain_reach2; // roundness: a grain needs F1 below this (noise.py)
uniform float u_jitter;

// Colour and glint follow from the owning layer and the grain word (noise.py: grain_colour_index,
// glint_value), so palette edits never need the grains generated again.
layout(location = 0) out vec4 out_normal_height;
layout(location = 1) out uvec2 out_layer_grain; // layer + 1 (0 in gaps), grain word

const float UNIT_8 = 1.0 / 256.0;
const vec2 ANCHOR0 = vec2(0.25);
const vec2 ANCHOR1 = vec2(0.75);

uint lowbias32(uint x) {
    x ^= x >> 16u; x *= 0x7feb352du;
    x ^= x >> 15u; x *= 0x846ca68bu;
    return x ^ (x >> 16u);
}

// Keeps the two smallest squared distances and the offsets p − f that give their gradients.
void consider(float f, vec2 delta, uint word,
              inout float f1, inout float f2, inout vec2 d1, inout vec2 d2, inout uint w1) {
    if (f < f1) {
        f2 = f1; d2 = d1;
        f1 = f; d1 = delta; w1 = word;
    } else if (f < f2) {
        f2 = f; d2 = delta;
    }
}

// Squared in-plane distance from the pixel to the nearest point of neighbour cell o.
float cell_reach2(ivec2 o, vec2 frac) {
    vec2 reach = vec2(o.x < 0 ? frac.x : (o.x > 0 ? 1.0 - frac.x : 0.0),
                      o.y < 0 ? frac.y : (o.y > 0 ? 1.0 - frac.y : 0.0));
    return dot(reach, reach);
}

// Offers the two points of neighbour cell o (of the pixel's cell) to the nearest-two search.
// A cell no nearer than F2 cannot change F1 or F2, so skipping it changes nothing but time.
void visit(ivec2 o, ivec2 cell, vec2 frac, int layer,
           inout float f1, inout float f2, inout vec2 d1, inout vec2 d2, inout uint w1) {
    if (cell_reach2(o, frac) >= f2) return;
    ivec2 c = cell + o;  // wrap into the tile without the slow integer modulo
    c += (ivec2(lessThan(c, ivec2(0))) - ivec2(greaterThanEqual(c, ivec2(u_period)))) * u_period;
    // One 32-bit word per point: x, y, depth and glint value, 8 bits each (noise.py).
    uint key = (uint(c.y) * uint(u_period) + uint(c.x)) * 32u + uint(layer) * 2u;
    uint h0 = lowbias32(key ^ u_seed_key);
    uint h1 = lowbias32((key + 1u) ^ u_seed_key);
    vec2 offset = vec2(o);
    vec2 p0 = vec2(float(h0 & 0xffu), float((h0 >> 8u) & 0xffu)) * UNIT_8;
    vec2 p1 = vec2(float(h1 & 0xffu), float((h1 >> 8u) & 0xffu)) * UNIT_8;
    float z0 = float((h0 >> 16u) & 0xffu) * UNIT_8;
    float z1 = float((h1 >> 16u) & 0xffu) * UNIT_8;
    vec2 delta0 = frac - ((ANCHOR0 + u_jitter * (p0 - ANCHOR0)) + offset);
    vec2 delta1 = frac - ((ANCHOR1 + u_jitter * (p1 - ANCHOR1)) + offset);
    float depth0 = ANCHOR_DEPTH + u_jitter * (z0 - ANCHOR_DEPTH);
    float depth1 = ANCHOR_DEPTH + u_jitter * (z1 - ANCHOR_DEPTH);
    consider(dot(delta0, delta0) + depth0 * depth0, delta0, h0, f1, f2, d1, d2, w1);
    consider(dot(delta1, delta1) + depth1 * depth1, delta1, h1, f1, f2, d1, d2, w1);
}

vec2 distance_gradient(vec2 delta, float f) {
    float d = sqrt(f);
    return d > 0.0 ? delta / d : vec2(0.0);
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

    out_normal_height = vec4(0.0, 0.0, 1.0, 0.0);
    out_layer_grain = uvec2(0u);

    for (int layer = 0; layer < u_layers; ++layer) {
        float f1 = 1.0, f2 = 1.0;   // the reference clamps squared distances at 1
        vec2 d1 = vec2(0.0), d2 = vec2(0.0);
        uint w1 = 0u;
        // The own cell first, then edges, then corners: the nearest points come early and more
        // far cells are skipped. The reference backend offers them in the same order, so ties
        // break alike. (Written out: llvmpipe keeps a looped-over const array in memory.)
        visit(ivec2(0, 0), cell, frac, layer, f1, f2, d1, d2, w1);
        visit(ivec2(-1, 0), cell, frac, layer, f1, f2, d1, d2, w1);
        visit(ivec2(1, 0), cell, frac, layer, f1, f2, d1, d2, w1);
        visit(ivec2(0, -1), cell, frac, layer, f1, f2, d1, d2, w1);
        visit(ivec2(0, 1), cell, frac, layer, f1, f2, d1, d2, w1);
        visit(ivec2(-1, -1), cell, frac, layer, f1, f2, d1, d2, w1);
        visit(ivec2(1, -1), cell, frac, layer, f1, f2, d1, d2, w1);
        visit(ivec2(-1, 1), cell, frac, layer, f1, f2, d1, d2, w1);
        visit(ivec2(1, 1), cell, frac, layer, f1, f2, d1, d2, w1);
        float profile = PROFILE_OFFSET + PROFILE_SCALE * (sqrt(f2) - sqrt(f1));
        if (profile > u_threshold && f1 < u_grain_reach2) {
            vec2 gradient = PROFILE_SCALE * (distance_gradient(d2, f2) - distance_gradient(d1, f1));
            out_normal_height = vec4(normalize(vec3(-gradient, profile)), profile);
            out_layer_grain = uvec2(uint(layer + 1), w1);
            break;
        }
    }
}
