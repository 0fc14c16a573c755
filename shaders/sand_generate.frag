#version 330 core
// Layered, thresholded, tileable 2D Worley grains: the GLSL twin of
// sand_editor/generator/reference.py (see noise.py for the model). Every constant and every step
// here mirrors that file; change both together.

uniform int u_size;          // texture edge in pixels
uniform int u_period;        // cells per tile edge
uniform int u_layers;
uniform usampler2D u_hash;  // per-cell hashes, layer l at rows [l·period, (l+1)·period)
uniform float u_threshold;
uniform float u_roundness10; // 10 · roundness
uniform float u_jitter;

// Colour and glint follow from the owning layer and the grain word (noise.py: grain_colour_index,
// glint_value), so palette edits never need the grains generated again.
layout(location = 0) out vec4 out_normal_height;
layout(location = 1) out uvec2 out_layer_grain; // layer + 1 (0 in gaps), grain word

const float UNIT_16 = 1.0 / 65536.0;
const float PROFILE_OFFSET = 0.1;
const float PROFILE_SCALE = 0.8;
const float ROUNDNESS_LIMIT = 0.81;
const vec2 ANCHOR0 = vec2(0.25);
const vec2 ANCHOR1 = vec2(0.75);
const float ANCHOR_DEPTH = 0.5;

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

// Offers the two points of neighbour cell o (of the pixel's cell) to the nearest-two search.
void visit(ivec2 o, ivec2 cell, vec2 frac, int layer,
           inout float f1, inout float f2, inout vec2 d1, inout vec2 d2, inout uint w1) {
    // Nearest the cell can come to the pixel; a cell no nearer than F2 cannot change
    // F1 or F2, so skipping it changes nothing but time.
    vec2 reach = vec2(o.x < 0 ? frac.x : (o.x > 0 ? 1.0 - frac.x : 0.0),
                      o.y < 0 ? frac.y : (o.y > 0 ? 1.0 - frac.y : 0.0));
    if (dot(reach, reach) >= f2) return;
    ivec2 c = cell + o;  // wrap into the tile without the slow integer modulo
    c += ivec2(lessThan(c, ivec2(0))) * u_period - ivec2(greaterThanEqual(c, ivec2(u_period))) * u_period;
    uvec4 h = texelFetch(u_hash, ivec2(c.x, c.y + layer * u_period), 0);
    vec2 offset = vec2(o);
    vec2 p0 = vec2(float(h.x & 0xffffu), float(h.x >> 16u)) * UNIT_16;
    vec2 p1 = vec2(float(h.z & 0xffffu), float(h.z >> 16u)) * UNIT_16;
    float z0 = float(h.y & 0xffffu) * UNIT_16;
    float z1 = float(h.w & 0xffffu) * UNIT_16;
    vec2 delta0 = frac - ((ANCHOR0 + u_jitter * (p0 - ANCHOR0)) + offset);
    vec2 delta1 = frac - ((ANCHOR1 + u_jitter * (p1 - ANCHOR1)) + offset);
    float depth0 = ANCHOR_DEPTH + u_jitter * (z0 - ANCHOR_DEPTH);
    float depth1 = ANCHOR_DEPTH + u_jitter * (z1 - ANCHOR_DEPTH);
    consider(dot(delta0, delta0) + depth0 * depth0, delta0, h.y, f1, f2, d1, d2, w1);
    consider(dot(delta1, delta1) + depth1 * depth1, delta1, h.w, f1, f2, d1, d2, w1);
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
        // The own cell first, then edges, then corners: the nearest points are found early, so
        // more of the far cells are skipped. The reference backend visits them in the same order.
        // (Written out rather than looped over a const array, which llvmpipe keeps in memory.)
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
        if (profile > u_threshold && u_roundness10 * f1 < ROUNDNESS_LIMIT) {
            vec2 gradient = PROFILE_SCALE * (distance_gradient(d2, f2) - distance_gradient(d1, f1));
            out_normal_height = vec4(normalize(vec3(-gradient, profile)), profile);
            out_layer_grain = uvec2(uint(layer + 1), w1);
            break;
        }
    }
}
