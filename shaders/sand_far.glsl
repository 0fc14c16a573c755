// The sand's large-scale surface and diffuse BRDF: ripples on the macro normal and d'Eon's
// Lambertian-sphere BRDF (included by sand_surface.glsl after its uniforms and helpers).

// d'Eon (2021), the fitted form of the BRDF of a half space of Lambertian spheres, per unit
// albedo at the tile's average albedo kd̄, every channel at once. What depends on kd̄ alone — c,
// the particles' single-scattering albedo mapped from it, and the multiple-scattering floor —
// is computed once per material (SandMaterial.bind) rather than per pixel, normal and light.
// The fit's coefficients (DEON_*) are #defined from sand_editor/render/far_brdf.py, which
// computes the same BRDF in numpy.
uniform vec3 u_sphere_c;
uniform vec3 u_sphere_floor;
uniform vec3 u_sphere_inverse_albedo;  // 1 / kd̄

// The spheres' single-scattering phase for light along l seen along v: it does not depend on
// the normal, so the five normals' light takes it once per light.
float sphere_phase(vec3 l, vec3 v) {
    float u = clamp(-dot(l, v), -1.0, 1.0);
    return 2.0 * (sqrt(max(1.0 - u * u, 0.0)) - u * acos(u)) / (3.0 * PI * PI);
}

// `phase`: sphere_phase(l, v).
vec3 sphere_brdf_per_albedo(vec3 n, vec3 l, vec3 v, float phase) {
    float ui = dot(n, l), uo = dot(n, v);
    if (ui <= 0.0 || uo <= 0.0) return vec3(0.0);
    float cos_io = dot(l, v);
    float single = phase / max(ui + uo, 1e-4);
    float s = sqrt(max((1.0 - ui * ui) * (1.0 - uo * uo), 0.0));
    // Relative azimuth from cos(io) = ui·uo + s·cos φ; at s → 0 the azimuth is moot.
    float cos_phi = s > 1e-5 ? clamp((cos_io - ui * uo) / s, -1.0, 1.0) : 1.0;
    float s_safe = max(s, 1e-5);
    float spread = (acos(cos_phi) + sqrt(ui * uo))
                 / (DEON_SPREAD_SCALE * (acos(min(s_safe, 1.0)) / s_safe + DEON_SPREAD_OFFSET));
    vec3 multiple = spread * (u_sphere_c - DEON_C_OFFSET) + u_sphere_floor;
    vec3 brdf = max(DEON_SINGLE * u_sphere_c * single + DEON_MULTIPLE * multiple, 0.0);
    return brdf * u_sphere_inverse_albedo;
}

// How far the dunes turn the ripples: the phase runs back by this times the dune's height, so
// on a slope the crests turn towards its contours and close up, and on flat ground they run
// as the wind lays them. (Turning the ripples' frame with the slope instead would turn it about
// the world's origin: tens of metres away a slight turn moves the phase by many crests, which
// drew fingerprint rings over the dunes.)
const float RIPPLE_BEND = 0.6;

uniform int u_sharp_ripples;  // 1: ripples filtered along the footprint (below); 0: isotropically
// 1: each sample's ripples as they are at its centre, unfiltered: what a supersampled truth
// averages; 0 (as every frame draws): filtered over the footprint, below.
uniform int u_unfiltered_ripples;
uniform float u_no_ripples;   // 0 on the dunes; 1 on objects (a tray, a sphere): no wind ripples

// Wind ripples, made where they are seen rather than read from a tile, so they never repeat.
// Crests run across the wind, RIPPLE_WAVELENGTH apart on average, wandering sideways along
// low-frequency noise (which also stretches and squeezes the spacing); here and there a crest
// forks (ripple_defect): one more crest starts between two forks, as real ripple fields show.
// The profile rises slowly on the windward side and drops on the lee, more so on steep slopes.
// Everything is an analytic function of the phase, so the footprint's filtering is too: the
// phase varies over the pixel by σ, and the ripple's slope is the footprint's mean, attenuated
// by exp(−σ²/2), which fades ripples smaller than a pixel smoothly (no moiré at any distance).
// The slopes the filter takes out still turn the sand to and from the light and the sky, and
// lengthen and shorten the grains' shadows: their deviation along the ripples' axis
// (`unresolved`) and the unfiltered profile's shape (SurfacePoint.ripple_profile) are handed to
// the light, as LEAN and Toksvig mapping hand a filtered normal map's variance to the BRDF, but
// along the one axis ripples tilt on (spread around the normal, as those do, it left the far
// frames 2–5 % too dark at a low sun) and with the profile's skew: a short steep lee, a long
// gentle windward side. The diffuse light is taken at three tilts, each third of the slopes at
// its mean angle (ripple_nodes), the glints' at four quantiles of each third
// (tilted_tile_specular). Under a sun along the ripples the three hold their slopes' light
// within 4–9 % (22 % on steep ground at strength 1) where two tilts either side of the mean
// miss it by up to 22–89 % (test_ripple_field.py). Its variance is handed over as (1 − kept)²
// of it, in full only where the ripples lie well below the pixel: where the footprint spans
// about a ripple its mean slope still follows it, and tilts about that darkened the frames. It
// is not capped: strong ripples' steep slopes keep their light too (against frames
// supersampled with the ripples unfiltered, u_unfiltered_ripples: a truth that does not hold
// this filter).
const float RIPPLE_WAVELENGTH = 0.09;  // metres
const float RIPPLE_WANDER = 0.6;       // crests' sideways wander, in wavelengths
const vec2 RIPPLE_WANDER_SCALE = vec2(1.6, 0.8); // metres: the wander's features (along, across)
const float DEFECT_CELL = 1.6;         // metres: one fork pair at most per cell of the wind's frame
const float DEFECT_CHANCE = 0.8;
const float DEFECT_REACH = 0.3;        // metres from its crest's segment that a pair bends crests
const uint RIPPLE_KEY = 0x2c1b3c6du;
// The footprint's phase variance per squared pixel step: a Gaussian of 0.41 pixels' deviation.
// FLIP against the frame supersampled 8×8 (bench depth's view) at 3 / 10 / 30 m, measured with
// a slope-variance hand-off since taken out: 1/3 gave 0.103 / 0.059 / 0.074, this 0.099 / 0.048
// / 0.082, a box's 1/12 0.101 / 0.040 / 0.085; as shipped, this gives 0.102 / 0.049 / 0.072.
// The wider filters alias less (test_ripple_field.py), the narrower keep nearer ripples sharp.
const float RIPPLE_FOOTPRINT = 1.0 / 6.0;

// Smooth value noise in [−1, 1] with its gradient (per unit of p), on a hashed lattice.
vec3 value_noise(vec2 p, uint key) {
    vec2 cell = floor(p), f = p - cell;
    ivec2 c = ivec2(cell);
    float a = hash01(hash_cell(c, key)), b = hash01(hash_cell(c + ivec2(1, 0), key));
    float d = hash01(hash_cell(c + ivec2(0, 1), key)), e = hash01(hash_cell(c + ivec2(1, 1), key));
    // Quintic fade: the gradient (the crests' spacing) is smooth across cells too.
    vec2 u = f * f * f * (f * (6.0 * f - 15.0) + 10.0), du = 30.0 * f * f * (f * (f - 2.0) + 1.0);
    float value = mix(mix(a, b, u.x), mix(d, e, u.x), u.y);
    vec2 grad = du * vec2(mix(b - a, e - d, u.y), mix(d - a, e - b, u.x));
    return vec3(2.0 * value - 1.0, 2.0 * grad);
}

// The phase (radians) a fork pair adds at q (metres, wind's frame): two phase singularities of
// opposite winding a few wavelengths apart along the crests, whose 2π jumps both run along the
// segment between them (where sin() does not see them), faded out before the cell's edge so
// that cells need not see each other's.
float ripple_defect(vec2 q) {
    vec2 cell = floor(q / DEFECT_CELL);
    uint h = hash_cell(ivec2(cell), RIPPLE_KEY ^ 0x9e3779b9u);
    if (hash01(h) >= DEFECT_CHANCE) return 0.0;
    float half_length = RIPPLE_WAVELENGTH * mix(2.0, 5.0, hash01(lowbias32(h + 1u)));
    float reach = DEFECT_REACH;
    vec2 jitter = vec2(hash01(lowbias32(h + 2u)), hash01(lowbias32(h + 3u))) - 0.5;
    vec2 room = vec2(0.5 * DEFECT_CELL - reach) - vec2(0.0, half_length);
    vec2 centre = (cell + 0.5) * DEFECT_CELL + 2.0 * jitter * max(room, 0.0);
    vec2 d1 = q - centre + vec2(0.0, half_length), d2 = q - centre - vec2(0.0, half_length);
    // Angles whose cut runs from each singularity along +y (across the wind): the difference
    // jumps only between them.
    float winding = atan(d1.x, -d1.y) - atan(d2.x, -d2.y);
    vec2 off = q - centre;
    float to_segment = length(vec2(off.x, max(abs(off.y) - half_length, 0.0)));
    float sign_ = (h & 0x10u) != 0u ? 1.0 : -1.0;
    return sign_ * winding * (1.0 - smoothstep(0.35 * reach, reach, to_segment));
}

// The mean square over a period of the ripple profile's slope (below) of asymmetry `sharp`, in
// units of its steepest: 1/2 for a sine (RIPPLE_MEAN_SQUARE_*: far_brdf.py's fit).
float ripple_mean_square(float sharp) {
    float s2 = sharp * sharp;
    return 0.5 * (1.0 + s2 * (RIPPLE_MEAN_SQUARE_A + RIPPLE_MEAN_SQUARE_B * sharp))
         / ((1.0 + sharp) * (1.0 + sharp));
}

// The ripples' slope at q (metres in the wind's frame: x along the wind), filtered over the
// footprint of derivatives dx, dy, on gentle (steep = 0) to steep (1) ground; the phase is set
// back by `bend` metres (RIPPLE_BEND times the dune's height), whose gradient is bend_grad.
// `unresolved`: the deviation of the slopes the filter takes out, along the axis they lie on
// (the unfiltered profile's mean square less the filtered one's), as much as is handed on;
// `sharpest`: the unfiltered profile's asymmetry (RIPPLE_SHARPNESS on gentle ground, 0 a sine).
vec2 ripples_at(vec2 q, vec2 dx, vec2 dy, float steep, float bend, vec2 bend_grad,
                out vec2 unresolved, out float sharpest) {
    vec3 wander = value_noise(q / RIPPLE_WANDER_SCALE, RIPPLE_KEY);
    float k = 2.0 * PI / RIPPLE_WAVELENGTH;
    float shift = RIPPLE_WANDER * RIPPLE_WAVELENGTH;  // metres of wander per unit of noise
    float phase = k * (q.x - bend + shift * wander.x) + ripple_defect(q);
    vec2 along = vec2(1.0, 0.0) - bend_grad + shift * wander.yz / RIPPLE_WANDER_SCALE;  // ∇phase/k
    // The phase's variance over the pixel's footprint, RIPPLE_FOOTPRINT per squared step of a
    // pixel: along each of its axes, or (isotropic, as mip mapping filters) the longer one in
    // both.
    float gx = k * dot(along, dx), gy = k * dot(along, dy);
    float spread2 = u_unfiltered_ripples != 0 ? 0.0 : RIPPLE_FOOTPRINT * (u_sharp_ripples != 0
        ? gx * gx + gy * gy
        : 2.0 * k * k * dot(along, along) * max(dot(dx, dx), dot(dy, dy)));
    float keep = exp(-0.5 * spread2);
    // h = sin(t + s·sin t)/k: its slope is dh/dt·∇t/k, largest 1 at the lee (over 1 + s).
    // The asymmetry is the profile's harmonics, which the footprint filters as its second:
    // exp(−4σ²/2) against the fundamental's exp(−σ²/2).
    sharpest = mix(RIPPLE_SHARPNESS, RIPPLE_STEEP_SHARPNESS, steep);
    float sharp = sharpest * exp(-1.5 * spread2);
    float profile = cos(phase + sharp * sin(phase)) * (1.0 + sharp * cos(phase)) / (1.0 + sharp);
    float lost = ripple_mean_square(sharpest) - keep * keep * ripple_mean_square(sharp);
    unresolved = (1.0 - keep) * sqrt(max(lost, 0.0)) * along;
    return keep * profile * along;
}

// The macro normal with ripples across the wind and fine detail; `unresolved`: the deviation
// of the ripples' slopes that the footprint averages away and hands to the light, in the
// tangent plane, and `profile` their profile's (SurfacePoint.ripple_profile).
vec3 rippled_normal(SurfacePoint s, out vec2 unresolved, out vec2 profile) {
    // The ripples' frame: +x the way the wind blows (from the compass bearing
    // u_wind_direction), in uv, which is the world's (x, z) on the dunes.
    float from = radians(u_wind_direction);
    vec2 axis_t = vec2(-sin(from), cos(from));
    mat2 frame = mat2(axis_t, vec2(-axis_t.y, axis_t.x));  // columns: along, across
    // The dune's height and its gradient over (x, z), from the macro normal.
    float up = max(s.normal.y, 0.2);
    vec2 height_grad = -vec2(s.normal.x, s.normal.z) / up;
    float steep = smoothstep(0.2, 0.45, length(s.normal.xz));
    vec2 dx = transpose(frame) * footprint_dx(s.uv), dy = transpose(frame) * footprint_dy(s.uv);
    vec2 lost;
    float sharp;
    vec2 slope = ripples_at(transpose(frame) * s.uv, dx, dy, steep, RIPPLE_BEND * s.position.y,
                            RIPPLE_BEND * (transpose(frame) * height_grad), lost, sharp);
    vec2 grad = frame * slope * (1.0 - u_no_ripples);
    unresolved = RIPPLE_SLOPE_GAIN * u_ripple_strength * (1.0 - u_no_ripples) * (frame * lost);
    // The slopes handed on are the unfiltered profile's, scaled to their deviation.
    profile = vec2(inversesqrt(ripple_mean_square(sharp)), sharp);
    vec2 at = s.uv * 4.0;
    vec2 detail = textureGrad(u_detail, at, footprint_dx(at), footprint_dy(at)).xy;
    grad += detail * (u_detail_strength / max(u_ripple_strength, 1e-3));
    vec3 n_t = normalize(vec3(-RIPPLE_SLOPE_GAIN * u_ripple_strength * grad, 1.0));
    return to_world(n_t, s);
}

// The point turned to the unit normal n, bent towards the eye (along v) where n would face
// away from it, with its tangent frame turned to it.
SurfacePoint turned_to(SurfacePoint s, vec3 n, vec3 v) {
    float facing = dot(n, v);
    if (facing < MIN_FACING) n = normalize(n + (MIN_FACING - facing) * v);
    SurfacePoint r = s;
    r.normal = n;
    r.tangent = normalize(s.tangent - dot(s.tangent, n) * n);
    r.bitangent = cross(n, r.tangent) * sign(dot(cross(s.normal, s.tangent), s.bitangent));
    return r;
}

// The surface point on its ripples: the rippled normal, bent towards the eye where a ripple's
// back would face away from it (a hard dark patch that no real ripple shows: its back would be
// hidden by its crest), with the tangent frame turned to it and the ripples' slopes too fine
// for the pixel in `unresolved`.
SurfacePoint rippled_point(SurfacePoint s, vec3 v) {
    vec2 unresolved, profile;
    SurfacePoint r = turned_to(s, rippled_normal(s, unresolved, profile), v);
    r.unresolved = unresolved;
    r.ripple_profile = profile;
    return r;
}
