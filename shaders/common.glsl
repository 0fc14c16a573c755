// Shared by every program: constants, the integer hash and sRGB encoding; sand_editor/gl.py
// includes it once per program.

const float PI = 3.14159265358979;
const float MAX_HALF = 60000.0;  // largest radiance written to half-float targets
const float MAX_SPREAD = 100.0;  // largest spread of a pixel's light written (tone.glsl)

// Integer hash (lowbias32, Chris Wellons): the same numbers on every GPU, and in numpy
// (sand_editor/generator/noise.py mirrors it for the grains).
uint lowbias32(uint x) {
    x ^= x >> 16u; x *= 0x7feb352du;
    x ^= x >> 15u; x *= 0x846ca68bu;
    return x ^ (x >> 16u);
}

// A uniform number in [0, 1) from 24 bits of a hash.
float hash01(uint x) { return float(lowbias32(x) >> 8u) / 16777216.0; }

// Hash of a 2D integer cell with a key: anchored in texture space when the cell is a texel.
uint hash_cell(ivec2 cell, uint key) {
    return lowbias32(uint(cell.x) ^ lowbias32(uint(cell.y) ^ lowbias32(key)));
}

// The sRGB curve, its constants #defined from sand_editor/colour.py for every program.
vec3 srgb_encode(vec3 linear) {
    vec3 low = linear * SRGB_SLOPE;
    vec3 high = (1.0 + SRGB_OFFSET) * pow(linear, vec3(1.0 / SRGB_POWER)) - SRGB_OFFSET;
    return mix(high, low, lessThanEqual(linear, vec3(SRGB_LINEAR_KNEE)));
}
