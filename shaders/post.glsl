#version 330 core
#include "common.glsl"
// Post-processing of the HDR scene, one program per define: BLOOM_DOWNSAMPLE (13 taps),
// BLOOM_UPSAMPLE (3×3 tent, added onto the next larger level), and RESOLVE (bloom mix, exposure,
// ACES tone mapping over the spread of each pixel's light that the scene's alpha holds, and sRGB
// encoding into the caller's framebuffer, or raw values for debug views), METER (the log of the
// scene's luminance, for the exposure's log-average) and DEPTH_COPY (the scene's depth into the
// caller's framebuffer). Drawn with the fullscreen triangle of fullscreen.vert.

uniform sampler2D u_source;
uniform vec2 u_source_texel;   // 1 / size of u_source
uniform vec4 u_viewport;       // x, y, width, height of the output in window pixels

out vec4 out_colour;

vec2 output_uv() {
    return (gl_FragCoord.xy - u_viewport.xy) / u_viewport.zw;
}

#if defined BLOOM_DOWNSAMPLE

// Jimenez (2014): 13 taps as five overlapping 4-texel boxes, which keeps a moving bright pixel
// from flickering as it crosses texel boundaries.
void main() {
    vec2 uv = output_uv();
    vec2 t = u_source_texel;
    vec3 a = texture(u_source, uv + t * vec2(-2.0, 2.0)).rgb;
    vec3 b = texture(u_source, uv + t * vec2(0.0, 2.0)).rgb;
    vec3 c = texture(u_source, uv + t * vec2(2.0, 2.0)).rgb;
    vec3 d = texture(u_source, uv + t * vec2(-2.0, 0.0)).rgb;
    vec3 e = texture(u_source, uv).rgb;
    vec3 f = texture(u_source, uv + t * vec2(2.0, 0.0)).rgb;
    vec3 g = texture(u_source, uv + t * vec2(-2.0, -2.0)).rgb;
    vec3 h = texture(u_source, uv + t * vec2(0.0, -2.0)).rgb;
    vec3 i = texture(u_source, uv + t * vec2(2.0, -2.0)).rgb;
    vec3 j = texture(u_source, uv + t * vec2(-1.0, 1.0)).rgb;
    vec3 k = texture(u_source, uv + t * vec2(1.0, 1.0)).rgb;
    vec3 l = texture(u_source, uv + t * vec2(-1.0, -1.0)).rgb;
    vec3 m = texture(u_source, uv + t * vec2(1.0, -1.0)).rgb;
    vec3 colour = e * 0.125 + (a + c + g + i) * 0.03125 + (b + d + f + h) * 0.0625
                + (j + k + l + m) * 0.125;
    out_colour = vec4(max(colour, 0.0), 1.0);
}

#elif defined BLOOM_UPSAMPLE

uniform float u_radius;  // in source texels

void main() {
    vec2 uv = output_uv();
    vec2 t = u_source_texel * u_radius;
    vec3 colour = texture(u_source, uv).rgb * 4.0;
    colour += (texture(u_source, uv + vec2(-t.x, 0.0)).rgb + texture(u_source, uv + vec2(t.x, 0.0)).rgb
             + texture(u_source, uv + vec2(0.0, -t.y)).rgb + texture(u_source, uv + vec2(0.0, t.y)).rgb) * 2.0;
    colour += texture(u_source, uv + vec2(-t.x, -t.y)).rgb + texture(u_source, uv + vec2(t.x, -t.y)).rgb
            + texture(u_source, uv + vec2(-t.x, t.y)).rgb + texture(u_source, uv + vec2(t.x, t.y)).rgb;
    out_colour = vec4(colour / 16.0, 1.0);
}

#elif defined METER

// Each texel of the small metering target: the log of the mean luminance of the scene under
// it (a bilinear tap of the scene's smallest bloom level that covers it).
void main() {
    float luminance = dot(texture(u_source, output_uv()).rgb, LUMINANCE_WEIGHTS);
    out_colour = vec4(log(max(luminance, 1e-8)), 0.0, 0.0, 1.0);
}

#elif defined DEPTH_COPY

// The scene's depth into the caller's framebuffer (its depth buffer, for what is drawn over the
// finished image and for a compositor that reprojects); the colour is left as it is (blended
// with ZERO, ONE).
void main() {
    gl_FragDepth = texelFetch(u_source, ivec2(gl_FragCoord.xy - u_viewport.xy), 0).r;
    out_colour = vec4(0.0);
}

#elif defined RESOLVE

#include "tone.glsl"

uniform sampler2D u_bloom;
uniform float u_bloom_strength;
uniform float u_bloom_normalisation;  // 1 / number of levels summed into u_bloom
uniform float u_exposure;
uniform bool u_tone_map;              // false: debug values, written clamped and unencoded

void main() {
    vec2 uv = output_uv();
    vec4 texel = texture(u_source, uv);
    vec3 scene = texel.rgb;
    if (!u_tone_map) {
        out_colour = vec4(clamp(scene, 0.0, 1.0), 1.0);
        return;
    }
    vec3 bloom = texture(u_bloom, uv).rgb * u_bloom_normalisation;
    vec3 hdr = mix(scene, bloom, u_bloom_strength) * u_exposure;
    // alpha: the spread of the light across the pixel (tone.glsl), 0 where it is even.
    out_colour = vec4(srgb_encode(aces_over_spread(max(hdr, 0.0), texel.a)), 1.0);
}

#endif
