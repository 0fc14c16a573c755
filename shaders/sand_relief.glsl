// Grain relief up close (included by sand_surface.glsl after its uniforms): the grains stand at
// their depth and shade each other along the light, from the height the generator makes.
//
// The material's albedo texture holds each texel's relief height in its alpha, 1 for the top of
// the tallest grain and 0 in the gaps (material_build.frag); its mipmaps average it, so a coarse
// footprint sees a smoothed surface. The grains sink below the shading point's plane by at most
// RELIEF_DEPTH_CELLS grain cells. The eye's ray is marched down through the height field in a
// bounded number of steps (parallax occlusion mapping, the step that passes below refined by
// halving), each eye with its own view vector, so each sees the grains at their own depth; from
// where it lands, a ray towards the light finds how far the grains in front rise above it (a soft
// shadow). Both fade in as a grain cell grows from RELIEF_FADE_PX.x to .y of the footprint's taps
// (a pixel's width across, a share of its length along a grazing view: sand_surface.glsl), and
// nothing of it runs below that, so mid and far range pay nothing. Where it fades out, the
// footprint is read where the eye's ray meets the grains on average (mean_relief_shift), so the
// grains do not slide towards the eye as the view draws back. What the shadows take from a pixel
// of many grains is not lost there: the material measures its mean per light and eye direction
// (relief_visibility.frag) and the far range, and the close range where the relief fades, are lit
// by that.

uniform float u_grain_cell;  // a grain cell's edge, in tiles (1 / the generator's period)
uniform int u_relief;        // 1: grains with relief; 0: flat (the relief's cost measured apart)
// The mean share of a light that reaches what an eye sees of the grains: x the light's cosine,
// y the eye's, z the azimuth between them over π (RELIEF_TABLE texels, ends on the ends).
uniform sampler3D u_relief_visibility;

const float RELIEF_DEPTH_CELLS = 0.5;
const vec2 RELIEF_FADE_PX = vec2(2.0, 5.0);
const int RELIEF_STEPS = 12;
// Halvings of the step in which the ray passes below the grains: a grain's side is a wall in
// the height field, and the crossing taken between two steps alone lands on either side of it
// from pixel to pixel, stair steps along the view.
const int RELIEF_REFINE_STEPS = 4;
const float RELIEF_SHARPEN_LOD = 1.0;  // heights read this many mip levels finer than the footprint
const int SHADOW_STEPS = 12;
const float SHADOW_SOFTNESS = 48.0;  // per unit of depth: how quickly a shadow darkens
const float MIN_RELIEF_COSINE = 0.15;  // grazing rays are cut at this angle's reach

struct Relief {
    vec2 tc;          // where the eye's ray meets the grains, in tiles
    float depth;      // how deep, as a share of relief_depth_tc
    float sun;        // the share of the sun's (and the moon's) light that reaches it
    float moon;
};

float relief_height(vec2 tc, float lod) {
    return textureLod(u_albedo, tc, max(lod - RELIEF_SHARPEN_LOD, 0.0)).a;
}

// A grain cell's edge in texels of the grain textures.
float grain_cell_texels() {
    return u_grain_cell * u_texture_size;
}

// The weight of the relief where the footprint's taps are `texels_per_tap` texels long.
float relief_weight(float texels_per_tap) {
    if (u_relief == 0) return 0.0;
    float cell_px = grain_cell_texels() / max(texels_per_tap, 1e-6);
    return smoothstep(RELIEF_FADE_PX.x, RELIEF_FADE_PX.y, cell_px);
}

// Visibility of a light from the point at `depth` below the top, `tc`, along tangent-space l.
float relief_shadow(vec2 tc, float depth, vec3 l, float depth_tc, float lod) {
    if (l.z <= 0.0) return 1.0;
    vec2 step_tc = l.xy / max(l.z, MIN_RELIEF_COSINE) * depth_tc * depth / float(SHADOW_STEPS);
    float blocked = 0.0;
    for (int i = 1; i <= SHADOW_STEPS; ++i) {
        float ray = depth * (1.0 - float(i) / float(SHADOW_STEPS));
        float ground = 1.0 - relief_height(tc + step_tc * float(i), lod);
        blocked = max(blocked, (ray - ground) * (1.0 - float(i - 1) / float(SHADOW_STEPS)));
    }
    return 1.0 - clamp(SHADOW_SOFTNESS * blocked, 0.0, 1.0);
}

// How deep the grains reach below the shading point for an eye along e, in tiles: a grazing eye
// would see each grain's steep side as its top's texel smeared down the wall (fins along the
// view), so the relief flattens as the eye's cosine falls below 0.3.
float relief_depth_tc(vec3 e) {
    return RELIEF_DEPTH_CELLS * u_grain_cell * smoothstep(0.05, 0.3, e.z);
}

// Where tangent-space l and e fall in a table of RELIEF_TABLE entries over the light's
// cosine, the eye's and the azimuth between them (this one, and sand_surface.glsl's five
// normals' correction), each axis's end entries at its ends: the texture coordinate.
vec3 direction_table_at(vec3 l, vec3 e) {
    float across = length(l.xy) * length(e.xy);
    float azimuth = across > 1e-8 ? acos(clamp(dot(l.xy, e.xy) / across, -1.0, 1.0)) : 0.0;
    vec3 at = vec3(clamp(l.z, 0.0, 1.0), clamp(e.z, 0.0, 1.0), azimuth / PI);
    vec3 size = vec3(RELIEF_TABLE);
    return (at * (size - 1.0) + 0.5) / size;
}

// The table's entry for tangent-space l and e: x the mean share of light along l that reaches
// the grains an eye along e sees, y the mean depth at which that eye's ray meets them.
vec2 mean_relief(vec3 l, vec3 e) {
    return texture(u_relief_visibility, direction_table_at(l, e)).rg;
}

float mean_relief_visibility(vec3 l, vec3 e) {
    if (u_relief == 0 || l.z <= 0.0) return 1.0;
    return mean_relief(l, e).x;
}

// Where the eye's ray along e meets the grains on average, from the shading point, in tiles:
// a footprint of many grains shows them there, not at their tops, so that they do not slide
// under the eye as the relief fades out of its footprint. The depth is the same for every
// light: the table's zenith entry is read.
vec2 mean_relief_shift(vec3 e) {
    if (u_relief == 0) return vec2(0.0);
    float depth = mean_relief(vec3(0.0, 0.0, 1.0), e).y;
    return -e.xy / max(e.z, MIN_RELIEF_COSINE) * (relief_depth_tc(e) * depth);
}

// The eye's ray through the grains (tangent-space `e` towards the eye, `l0`, `l1` towards the
// lights, `lit` whether each shines here at all). A light that does not shine (below the
// horizon, or in the scene's shadow) is not marched.
Relief relief_at(vec2 tc, vec3 e, vec3 l0, vec3 l1, bvec2 lit, float lod) {
    float depth_tc = relief_depth_tc(e);
    vec2 step_tc = -e.xy / max(e.z, MIN_RELIEF_COSINE) * depth_tc / float(RELIEF_STEPS);
    float step_depth = 1.0 / float(RELIEF_STEPS);
    float depth = 0.0, ground = 1.0 - relief_height(tc, lod);
    float previous_depth = 0.0, previous_gap = ground;
    vec2 at = tc;
    for (int i = 0; i < RELIEF_STEPS && depth < ground; ++i) {
        previous_depth = depth;
        previous_gap = ground - depth;
        at += step_tc;
        depth += step_depth;
        ground = 1.0 - relief_height(at, lod);
    }
    // Between the last step above the grains and the first below: halve the interval a few
    // times, then where the two lines cross.
    float hit_depth = depth;
    if (depth - ground > 0.0) {
        float lo = previous_depth, hi = depth, gap_lo = previous_gap, below_hi = depth - ground;
        for (int k = 0; k < RELIEF_REFINE_STEPS; ++k) {
            float mid = 0.5 * (lo + hi);
            float g = 1.0 - relief_height(tc + step_tc * (mid / step_depth), lod);
            if (mid < g) {
                lo = mid;
                gap_lo = g - mid;
            } else {
                hi = mid;
                below_hi = mid - g;
            }
        }
        hit_depth = mix(lo, hi, gap_lo / max(gap_lo + below_hi, 1e-6));
    }
    Relief r;
    r.tc = tc + step_tc * (hit_depth / step_depth);
    r.depth = hit_depth;
    r.sun = lit.x ? relief_shadow(r.tc, hit_depth, l0, depth_tc, lod) : 1.0;
    r.moon = lit.y ? relief_shadow(r.tc, hit_depth, l1, depth_tc, lod) : 1.0;
    return r;
}
