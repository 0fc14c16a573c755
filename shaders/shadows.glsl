// Shadows of the sun or the moon (sand_editor/render/shadows.py draws the maps and sets these
// uniforms), included by terrain.glsl in both stages: the vertex stage finds each cascade's map
// coordinates, the fragment stage scales the casting light by what of it reaches the point.
// SHADOW_CASCADES is #defined from Python.

uniform int u_shadow_cascades;  // 0: no shadows (no light shines, or they are off)
uniform mat4 u_shadow_matrix[SHADOW_CASCADES];  // mesh-relative position → map xy, depth
uniform float u_shadow_offset[SHADOW_CASCADES];  // metres out along the normal to look up

const float HORIZON_BAND = 0.03;

#if defined VERTEX_SHADER

out vec3 v_shadow[SHADOW_CASCADES];

void shadow_coordinates(vec3 position, vec3 normal) {
    for (int i = 0; i < SHADOW_CASCADES; ++i) {
        v_shadow[i] = (u_shadow_matrix[i] * vec4(position + normal * u_shadow_offset[i], 1.0)).xyz;
    }
}

#elif defined FRAGMENT_SHADER

uniform sampler2D u_shadow_map;  // 2 × 2 atlas of the cascades' depths
uniform int u_shadow_light;      // 0: the sun casts the shadows; 1: the moon
uniform vec2 u_shadow_fade;      // distances (m) over which the shadows fade out, far away
uniform int u_shadow_size;       // texels per edge of one cascade's map

in vec3 v_shadow[SHADOW_CASCADES];

// The share of the light that reaches map point p of cascade `index`: the depth test at the
// four texels around it, weighted bilinearly (percentage-closer filtering), so shadow edges are
// a texel soft and do not step between texels.
float cascade_light(vec3 p, int index) {
    ivec2 tile = ivec2(index % 2, index / 2) * u_shadow_size;
    vec2 q = p.xy * float(u_shadow_size) - 0.5;
    vec2 corner = floor(q);
    vec2 f = q - corner;
    ivec2 base = ivec2(corner);
    ivec2 last = ivec2(u_shadow_size - 1);
    vec4 lit;
    lit.x = float(p.z <= texelFetch(u_shadow_map, clamp(base, ivec2(0), last) + tile, 0).r);
    lit.y = float(p.z <= texelFetch(u_shadow_map, clamp(base + ivec2(1, 0), ivec2(0), last) + tile, 0).r);
    lit.z = float(p.z <= texelFetch(u_shadow_map, clamp(base + ivec2(0, 1), ivec2(0), last) + tile, 0).r);
    lit.w = float(p.z <= texelFetch(u_shadow_map, clamp(base + ivec2(1, 1), ivec2(0), last) + tile, 0).r);
    return mix(mix(lit.x, lit.y, f.x), mix(lit.z, lit.w, f.x), f.y);
}

// What of the casting light reaches a point `distance_m` from the eye: from the finest cascade
// whose map holds it (two texels in from its edges); 1 beyond them all.
float shadow_visibility(float distance_m) {
    if (u_shadow_cascades == 0) return 1.0;
    float margin = 2.0 / float(u_shadow_size);
    int chosen = -1;
    vec3 p = vec3(0.0);
    // Only the choice runs per cascade: the filter once, for the chosen one (a CPU rasterizer
    // would run every branch's filter).
    for (int i = SHADOW_CASCADES - 1; i >= 0; --i) {
        vec3 c = v_shadow[i];
        bool inside = all(greaterThan(c.xy, vec2(margin))) && all(lessThan(c.xy, vec2(1.0 - margin)))
                   && c.z < 1.0 && i < u_shadow_cascades;
        if (inside) {
            chosen = i;
            p = c;
        }
    }
    if (chosen < 0) return 1.0;
    float lit = cascade_light(vec3(p.xy, max(p.z, 0.0)), chosen);
    // Far away the shadows fade out, by distance and towards the last map's edges, rather than
    // stop along a line.
    float fade = smoothstep(u_shadow_fade.x, u_shadow_fade.y, distance_m);
    if (chosen == u_shadow_cascades - 1) {
        vec2 edge = abs(2.0 * p.xy - 1.0);
        fade = max(fade, smoothstep(0.8, 1.0 - 2.0 * margin, max(edge.x, edge.y)));
    }
    return mix(lit, 1.0, fade);
}

// How much of a light in direction l a surface of geometric normal n faces: none once the light
// is below its horizon (the dune's lee side in the evening), whatever its grains and ripples
// would catch; a narrow band, so that a terminator is not a line of pixels.
float above_horizon(vec3 n, vec3 l) {
    return smoothstep(-HORIZON_BAND, HORIZON_BAND, dot(n, l));
}

// The lights of L that reach a point of geometric normal n: below the surface's horizon none,
// and of the casting one what the shadow maps let through. Unchanged without shadows.
Lighting shadowed(Lighting L, vec3 position, vec3 n) {
    if (u_shadow_cascades == 0) return L;
    float visible = shadow_visibility(distance(position, L.eye));
    L.sun_radiance *= above_horizon(n, L.sun_direction) * (u_shadow_light == 0 ? visible : 1.0);
    L.moon_radiance *= above_horizon(n, L.moon_direction) * (u_shadow_light == 1 ? visible : 1.0);
    return L;
}

#endif
