#version 330 core
#include "common.glsl"
// The grains' mean shadowing of a light as an eye sees it (sand_relief.glsl's statistical
// twin), one texel per (light cosine, eye cosine, azimuth between them): RELIEF_SAMPLES points
// of the tile, each turned by its own azimuth (sand is the same in every direction), have the
// eye's ray marched down into the grains and the light's ray up from where it lands, exactly
// as the close range does with the relief at full weight, at the mip level where the relief
// reaches full weight (a grain cell RELIEF_FADE_PX.y pixels wide). The mean is what a pixel of
// many grains shows: the far range and the close range, where the relief fades out, are lit
// by it, so no band of unshadowed light lies where the relief ends. The second channel is the
// mean depth at which the eye's ray meets the grains: where the relief fades out, the close
// range reads the grains there (sand_relief.glsl's mean_relief_shift).
// Texel (x, y) of a RELIEF_TABLE.x·RELIEF_TABLE.z × RELIEF_TABLE.y target: light cosine
// x mod RELIEF_TABLE.x, azimuth x / RELIEF_TABLE.x, eye cosine y; each axis's end texels at
// its ends (cosines 0 and 1, azimuths 0 and π).

uniform sampler2D u_albedo;     // alpha: the relief height (material_build.frag)
uniform float u_texture_size;

#include "sand_relief.glsl"

out vec2 out_visibility;  // the mean visibility, and the mean depth the eye's ray reaches

float axis_value(int index, int count, float top) {
    return top * float(index) / float(count - 1);
}

void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    float cos_light = max(axis_value(texel.x % RELIEF_TABLE.x, RELIEF_TABLE.x, 1.0), 0.02);
    float azimuth = axis_value(texel.x / RELIEF_TABLE.x, RELIEF_TABLE.z, PI);
    float cos_eye = max(axis_value(texel.y, RELIEF_TABLE.y, 1.0), 0.02);
    vec3 l = vec3(sqrt(1.0 - cos_light * cos_light), 0.0, cos_light);
    float sin_eye = sqrt(1.0 - cos_eye * cos_eye);
    vec3 e = vec3(sin_eye * cos(azimuth), sin_eye * sin(azimuth), cos_eye);
    float lod = max(log2(grain_cell_texels() / RELIEF_FADE_PX.y), 0.0);
    vec2 sum = vec2(0.0);
    for (int i = 0; i < RELIEF_SAMPLES; ++i) {
        uint h = lowbias32(uint(i) * 3u + 0x51ed27u);
        vec2 tc = vec2(hash01(h), hash01(lowbias32(h + 1u)));
        float turn = 2.0 * PI * hash01(lowbias32(h + 2u));
        mat2 r = mat2(cos(turn), sin(turn), -sin(turn), cos(turn));
        vec3 lr = vec3(r * l.xy, l.z), er = vec3(r * e.xy, e.z);
        Relief hit = relief_at(tc, er, lr, lr, bvec2(true, false), lod);
        sum += vec2(hit.sun, hit.depth);
    }
    out_visibility = sum / float(RELIEF_SAMPLES);
}
