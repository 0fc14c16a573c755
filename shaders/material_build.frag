#version 330 core
#include "common.glsl"
// Builds level 0 of the sand material's filterable textures from the generated grains. Every
// quantity written here is linear in what the renderer averages, so the GPU's mipmaps (box
// averages) stay exact footprint averages at every level:
//   albedo:  linear RGB of the grain; alpha: its relief height (sand_relief.glsl), 1 at the top
//            of the tallest grain, lower on deeper layers, 0 in gaps
//   glint:   w, w·bx, w·by, w·bx·by   (w: the light a clear grain gets, else 0; b = slope of the grain
//            normal, n ∝ (bx, by, 1))
//   spread:  w·bx², w·by², bx, by
//   hole:    w·exp(−|b|²/2s₀²), the slope density near zero at scale s₀ (sand_surface.glsl)
//   normal:  nx, ny, nx², ny² of every texel's unit normal (the diffuse light's distribution
//            of normals)
// so a footprint's w-weighted slope mean and covariance (LEAN mapping) and its plain mean slope
// (the diffuse normal) come out of one trilinear fetch per texture.
// Where a grain cell spans too few texels for its grains' shape (material.py's
// supersampling), the grains come generated u_supersample times finer each way, and every
// texel is the mean of its u_supersample² points: the moments of the slopes within it, as the
// mipmaps are of the texels within theirs.

uniform sampler2D u_normal_height;   // generator output: normal xyz, height
uniform usampler2D u_layer_grain;    // generator output: layer + 1 (0 in gaps), grain word
uniform int u_supersample;           // generator points per texel, each way
uniform vec3 u_base_color;           // linear
uniform vec3 u_layer_colors[LAYER_COLOURS];  // linear, layers × 4 palette entries (#defined)
uniform uvec3 u_colour_thresholds;   // 16-bit colour pick bounds (noise.colour_thresholds)
uniform float u_clear_grains;        // share of the grains that are clear
uniform float u_layer_light[MAX_LAYERS];  // linear share of the light reaching each layer

// The relief height is the grain's profile over the tallest a profile gets (PROFILE_TOP), times
// this for each layer deeper (a deeper layer's grains lie lower).
const float LAYER_RELIEF = 0.7;

layout(location = 0) out vec4 out_albedo;
layout(location = 1) out vec4 out_glint;
layout(location = 2) out vec4 out_spread;
layout(location = 3) out float out_hole;
layout(location = 4) out vec4 out_normal;

struct Built {
    vec4 albedo;
    vec4 glint;
    vec4 spread;
    float hole;
    vec4 normal;
};

// What one point of the generator's grains adds to its texel.
Built built_at(ivec2 point) {
    vec4 normal_height = texelFetch(u_normal_height, point, 0);
    uvec2 layer_grain = texelFetch(u_layer_grain, point, 0).xy;
    int layer = int(layer_grain.x) - 1;
    uint word = layer_grain.y;

    vec3 albedo = u_base_color;
    float w = 0.0;
    float relief = 0.0;
    if (layer >= 0) {
        relief = normal_height.w / PROFILE_TOP * pow(LAYER_RELIEF, float(layer));
        uint pick = lowbias32(word) >> 16u;
        int colour = int(pick >= u_colour_thresholds.x) + int(pick >= u_colour_thresholds.y)
                   + int(pick >= u_colour_thresholds.z);
        albedo = u_layer_colors[layer * 4 + colour];
        // A grain is clear when its glint value (uniform in [0, 1)) is below the share; a
        // deeper layer's mirrors get less light, as its colours do.
        float g = float(word >> 24u) / 256.0;
        w = g < u_clear_grains ? u_layer_light[layer] : 0.0;
    }
    vec3 n = normal_height.xyz;
    vec2 b = n.xy / n.z;   // n.z ≥ about CAP_FLOOR (noise.py): never 0
    Built out_;
    out_.albedo = vec4(albedo, clamp(relief, 0.0, 1.0));
    out_.glint = vec4(w, w * b, w * b.x * b.y);
    out_.spread = vec4(w * b * b, b);
    out_.hole = w * exp(-0.5 * dot(b, b) / HOLE_SCALE2);
    out_.normal = vec4(n.xy, n.xy * n.xy);
    return out_;
}

void main() {
    ivec2 first = ivec2(gl_FragCoord.xy) * u_supersample;
    Built sum = Built(vec4(0.0), vec4(0.0), vec4(0.0), 0.0, vec4(0.0));
    for (int j = 0; j < u_supersample; ++j) {
        for (int i = 0; i < u_supersample; ++i) {
            Built b = built_at(first + ivec2(i, j));
            sum.albedo += b.albedo;
            sum.glint += b.glint;
            sum.spread += b.spread;
            sum.hole += b.hole;
            sum.normal += b.normal;
        }
    }
    float share = 1.0 / float(u_supersample * u_supersample);
    out_albedo = sum.albedo * share;
    out_glint = sum.glint * share;
    out_spread = sum.spread * share;
    out_hole = sum.hole * share;
    out_normal = sum.normal * share;
}
