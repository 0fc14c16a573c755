#version 330 core
// The per-cell hash table of the grain generator: texel (x, y) holds pcg4d of cell
// (x, y mod period) of layer y / period. Hashing once per cell instead of once per pixel and cell
// is what makes the generator cheap; sand_generate.frag reads the table with texelFetch.

uniform int u_period;
uniform uint u_seed;

layout(location = 0) out uvec4 out_hash;

uvec4 pcg4d(uvec4 v) {
    v = v * 1664525u + 1013904223u;
    v.x += v.y * v.w; v.y += v.z * v.x; v.z += v.x * v.y; v.w += v.y * v.z;
    v ^= v >> 16u;
    v.x += v.y * v.w; v.y += v.z * v.x; v.z += v.x * v.y; v.w += v.y * v.z;
    return v;
}

void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    out_hash = pcg4d(uvec4(uint(texel.x), uint(texel.y % u_period), uint(texel.y / u_period), u_seed));
}
