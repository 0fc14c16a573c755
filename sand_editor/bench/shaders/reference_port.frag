#version 330 core
// The reference's texture generator, ported at its original cost: nine 27-cell Worley searches
// per layer per pixel, an extra edge-distance pass whose result is never used, every layer
// evaluated for every pixel, float32 sine hashes and finite-difference normals. It is the
// "before" side of a benchmark, so its weaknesses are kept on purpose.

uniform float u_size;
uniform int u_layers;
uniform float u_threshold;
uniform float u_roundness;
uniform float u_seed;
uniform float u_jitter;
uniform float u_period;
uniform float u_fd_step;
uniform float u_layer_darkness;
uniform vec3 u_base_color;
uniform vec3 u_colors[4];
uniform vec4 u_weights;
// Always 0 at run time. The compiler cannot know that, so work multiplied by it or offset by it
// is neither removed nor merged with an identical evaluation.
uniform float u_keep;

layout(location = 0) out vec4 out_normal_height;
layout(location = 1) out vec4 out_albedo_glint;
layout(location = 2) out float out_layer;

vec3 hash3(vec3 c) {
    vec3 q = vec3(dot(c, vec3(127.1, 311.7, 74.7)),
                  dot(c, vec3(269.5, 183.3, 246.1)),
                  dot(c, vec3(113.5, 271.9, 124.6)));
    return fract(sin(q) * 143758.5453);
}

float hash1(vec3 c) {
    return fract(sin(dot(c, vec3(12.9898, 78.233, 37.719))) * 143758.5453);
}

struct Cell {
    float f1;  // squared distances, clamped to [0, 1]
    float f2;
    float r;   // the closest cell's scalar
    vec3 closest;  // the closest feature point, for the edge pass
};

Cell worley(vec3 p) {
    vec3 cell = floor(p);
    Cell w = Cell(1e30, 1e30, 0.0, vec3(0.0));
    for (int ox = -1; ox <= 1; ++ox)
    for (int oy = -1; oy <= 1; ++oy)
    for (int oz = -1; oz <= 1; ++oz) {
        vec3 c = cell + vec3(ox, oy, oz);
        vec3 cm = mod(c, u_period);
        vec3 feature = c + u_jitter * hash3(cm);
        vec3 d = p - feature;
        float f = dot(d, d);
        if (f < w.f1) {
            w.f2 = w.f1;
            w.f1 = f;
            w.r = hash1(cm);
            w.closest = feature;
        } else if (f < w.f2) {
            w.f2 = f;
        }
    }
    w.f1 = clamp(w.f1, 0.0, 1.0);
    w.f2 = clamp(w.f2, 0.0, 1.0);
    return w;
}

// Distance to the nearest Voronoi border. The reference computes it and never reads it; it is
// here for its cost only. The reference's second pass does not share the first pass's jitter.
float edge_distance(vec3 p, vec3 closest) {
    vec3 cell = floor(p);
    vec3 to_closest = closest - p;
    float md = 8.0;
    for (int ox = -1; ox <= 1; ++ox)
    for (int oy = -1; oy <= 1; ++oy)
    for (int oz = -1; oz <= 1; ++oz) {
        vec3 c = cell + vec3(ox, oy, oz);
        vec3 to_other = c + hash3(mod(c, u_period)) - p;
        vec3 between = to_other - to_closest;
        if (dot(between, between) > 1e-5) {
            md = min(md, dot(0.5 * (to_closest + to_other), normalize(between)));
        }
    }
    return md;
}

float profile(Cell w) {
    return 0.1 + sqrt(0.64 * w.f2) - sqrt(0.64 * w.f1);
}

float thresholded(vec3 p) {
    float n = profile(worley(p));
    return n > u_threshold ? n : 0.0;
}

void main() {
    // gl_FragCoord sits at pixel centres: (x + 0.5, y + 0.5).
    vec2 uv = gl_FragCoord.xy / u_size;
    int owner = -1;
    vec3 normal = vec3(0.0, 0.0, 1.0);
    float height = 0.0;
    vec3 albedo = u_base_color;
    float glint = 0.0;
    float kept = 0.0;

    // No early exit: the reference evaluates every layer for every pixel.
    for (int i = 0; i < u_layers; ++i) {
        vec3 p = vec3(uv.x * u_period, u_seed * u_period, uv.y * u_period) + 100.0 * float(i);

        Cell centre = worley(p);
        float n = profile(centre);
        float t = n > u_threshold ? n : 0.0;
        float edge = edge_distance(p, centre.closest);

        float h = u_fd_step;
        float gx = (thresholded(p + vec3(h, 0.0, 0.0)) - thresholded(p - vec3(h, 0.0, 0.0))) / (2.0 * h);
        float gy = (thresholded(p + vec3(0.0, h, 0.0)) - thresholded(p - vec3(0.0, h, 0.0))) / (2.0 * h);
        float gz = (thresholded(p + vec3(0.0, 0.0, h)) - thresholded(p - vec3(0.0, 0.0, h))) / (2.0 * h);

        // Roundness and colour are separate searches at the same point in the reference.
        Cell for_roundness = worley(p + vec3(u_keep));
        Cell for_colour = worley(p + vec3(2.0 * u_keep));
        bool round_enough = 1.0 - (0.1 + sqrt(u_roundness * 10.0 * for_roundness.f1)) > 0.0;

        // Folding every result into an output stops the compiler from sinking the searches
        // into the ownership branch below, which would skip them once a pixel is owned.
        kept += u_keep * (gx + gy + gz + edge + for_roundness.f1 + for_colour.r + t);

        if (owner < 0 && t != 0.0 && round_enough) {
            owner = i;
            normal = normalize(vec3(-gx, -gz, t));
            height = t;
            float r = for_colour.r;
            vec4 cumulative = vec4(u_weights.x,
                                   u_weights.x + u_weights.y,
                                   u_weights.x + u_weights.y + u_weights.z,
                                   u_weights.x + u_weights.y + u_weights.z + u_weights.w) / 100.0;
            int k = r < cumulative.x ? 0 : r < cumulative.y ? 1 : r < cumulative.z ? 2 : 3;
            albedo = u_colors[k] * max(0.4, 1.0 - float(i) * u_layer_darkness * 0.624);
            glint = i == 0 ? r : 0.0;
        }
    }

    out_normal_height = vec4(normal, height + kept);
    out_albedo_glint = vec4(albedo, glint);
    out_layer = float(owner);
}
