// The sand's large-scale surface and diffuse BRDF: ripples on the macro normal and d'Eon's
// Lambertian-sphere BRDF (included by sand_surface.glsl after its uniforms and helpers).

const float RIPPLE_SLOPE_GAIN = 8.0; // ripple strength 1 means slopes 8× the map's
const float MIN_FACING = 0.05;       // least n·v of a shading normal

// d'Eon (2021), the fitted form of the BRDF of a half space of Lambertian spheres, per unit
// albedo at the tile's average albedo kd̄, every channel at once. What depends on kd̄ alone — c,
// the particles' single-scattering albedo mapped from it, and the multiple-scattering floor
// (1.94208·kd̄)^1.85432 — is computed once per material (SandMaterial.bind) rather than per
// pixel, normal and light.
uniform vec3 u_sphere_c;
uniform vec3 u_sphere_floor;
uniform vec3 u_sphere_inverse_albedo;  // 1 / kd̄

vec3 sphere_brdf_per_albedo(vec3 n, vec3 l, vec3 v) {
    float ui = dot(n, l), uo = dot(n, v);
    if (ui <= 0.0 || uo <= 0.0) return vec3(0.0);
    float cos_io = dot(l, v);
    float u = clamp(-cos_io, -1.0, 1.0);
    float phase = 2.0 * (sqrt(max(1.0 - u * u, 0.0)) - u * acos(u)) / (3.0 * PI * PI);
    float single = phase / max(ui + uo, 1e-4);
    float s = sqrt(max((1.0 - ui * ui) * (1.0 - uo * uo), 0.0));
    // Relative azimuth from cos(io) = ui·uo + s·cos φ; at s → 0 the azimuth is moot.
    float cos_phi = s > 1e-5 ? clamp((cos_io - ui * uo) / s, -1.0, 1.0) : 1.0;
    float s_safe = max(s, 1e-5);
    float spread = (acos(cos_phi) + sqrt(ui * uo))
                 / (4.50996 * (acos(min(s_safe, 1.0)) / s_safe + 0.113706));
    vec3 multiple = spread * (u_sphere_c - 0.249978) + u_sphere_floor;
    vec3 brdf = max(0.995917 * u_sphere_c * single + 0.0684744 * multiple, 0.0);
    return brdf * u_sphere_inverse_albedo;
}

// How far the dune slope turns the ripples: the wind's direction on the surface plus this times
// the (unnormalised) downhill direction, which is 0 on flat ground and grows with the slope, so
// the ripples bend over the dunes without a seam where the slope's direction turns.
const float RIPPLE_BEND = 0.6;

uniform int u_sharp_ripples;  // 1: ripples filtered along the footprint (below); 0: isotropically
uniform float u_no_ripples;   // 0 on the dunes; 1 on objects (a tray, a sphere): no wind ripples
const int RIPPLE_TAPS = 4;

// A ripple map's mean slope over the pixel's footprint (uv derivatives dx, dy). A distant
// footprint is a long streak across the ripples: filtered isotropically, as mipmaps are, it
// would be blurred to its longest axis and the ripples would fade where they are still seen
// across the view. Here up to RIPPLE_TAPS taps along the longer axis, each filtered to the
// footprint's width, average it as its own shape: the filtering the GPU's anisotropic sampler
// does, whose CPU rasterizer's version costs far more.
vec2 ripple_slopes(sampler2D map, vec2 uv, vec2 dx, vec2 dy) {
    if (u_sharp_ripples == 0) return textureGrad(map, uv, dx, dy).xy;
    bool x_longer = dot(dx, dx) >= dot(dy, dy);
    vec2 major = x_longer ? dx : dy, minor = x_longer ? dy : dx;
    float ratio = length(major) / max(length(minor), 1e-12);
    float taps = clamp(ceil(ratio), 1.0, float(RIPPLE_TAPS));
    vec2 step_uv = major / taps;
    vec2 sum = vec2(0.0);
    for (int i = 0; i < RIPPLE_TAPS; ++i) {
        if (float(i) >= taps) break;
        vec2 at = uv + step_uv * (float(i) + 0.5 - 0.5 * taps);
        sum += textureGrad(map, at, step_uv, minor).xy;
    }
    return sum / taps;
}

// The macro normal with ripples across the wind and fine detail.
vec3 rippled_normal(SurfacePoint s) {
    // The ripple maps' crests run along v and the wind blows along +u: the frame's first axis
    // is the way the wind blows (from the compass bearing u_wind_direction), on the surface.
    float from = radians(u_wind_direction);
    vec3 wind = vec3(-sin(from), 0.0, cos(from));  // world: x east, −z north
    vec3 up = vec3(0.0, 1.0, 0.0);
    vec3 downhill = s.normal - dot(s.normal, up) * up;
    float slope = length(downhill);
    vec3 along = wind + RIPPLE_BEND * downhill;
    vec2 a = vec2(dot(along, s.tangent), dot(along, s.bitangent));
    float len = length(a);
    vec2 axis_t = len > 1e-6 ? a / len : vec2(1.0, 0.0);
    mat2 frame = mat2(axis_t, vec2(-axis_t.y, axis_t.x));  // columns: along, across
    vec2 ripple_uv = transpose(frame) * s.uv;
    float steep = smoothstep(0.2, 0.45, slope);
    vec2 dx = transpose(frame) * dFdx(s.uv), dy = transpose(frame) * dFdy(s.uv);
    vec2 grad_r = mix(ripple_slopes(u_ripple_shallow, ripple_uv, dx, dy),
                      ripple_slopes(u_ripple_steep, ripple_uv, dx, dy), steep);
    vec2 grad = frame * grad_r * (1.0 - u_no_ripples);
    grad += texture(u_detail, s.uv * 4.0).xy * (u_detail_strength / max(u_ripple_strength, 1e-3));
    vec3 n_t = normalize(vec3(-RIPPLE_SLOPE_GAIN * u_ripple_strength * grad, 1.0));
    return to_world(n_t, s);
}

// The surface point on its ripples: the rippled normal, bent towards the eye where a ripple's
// back would face away from it (a hard dark patch that no real ripple shows: its back would be
// hidden by its crest), with the tangent frame turned to it.
SurfacePoint rippled_point(SurfacePoint s, vec3 v) {
    vec3 n = rippled_normal(s);
    float facing = dot(n, v);
    if (facing < MIN_FACING) n = normalize(n + (MIN_FACING - facing) * v);
    SurfacePoint r = s;
    r.normal = n;
    r.tangent = normalize(s.tangent - dot(s.tangent, n) * n);
    r.bitangent = cross(n, r.tangent) * sign(dot(cross(s.normal, s.tangent), s.bitangent));
    return r;
}
