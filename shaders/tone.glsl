// The display's tone curve: the resolve applies it to the exposed scene, and an engine's port
// of the sand (the Godot export) to its surface when it shows the sand as the editor does.

// Stephen Hill's fit of the ACES RRT + ODT (sRGB primaries in and out).
// Columns as vectors: the form every shading language with matrices takes (Godot's no other).
const mat3 ACES_INPUT = mat3(vec3(0.59719, 0.07600, 0.02840), vec3(0.35458, 0.90834, 0.13383),
                             vec3(0.04823, 0.01566, 0.83777));
const mat3 ACES_OUTPUT = mat3(vec3(1.60475, -0.10208, -0.00327),
                              vec3(-0.53108, 1.10813, -0.07276),
                              vec3(-0.07367, -0.00605, 1.07602));

vec3 aces_fitted(vec3 colour) {
    colour = ACES_INPUT * colour;
    vec3 a = colour * (colour + 0.0245786) - 0.000090537;
    vec3 b = colour * (0.983729 * colour + 0.4329510) + 0.238081;
    return clamp(ACES_OUTPUT * (a / b), 0.0, 1.0);
}

// The curve's mean over a pixel whose light varies across it: `colour` its mean, `spread` the
// variance of its luminance over the squared mean (the scene's alpha: sand_surface.glsl's
// Shaded.spread). A frame drawn finer and averaged puts each part of the pixel through the
// curve, whose shoulder bends the bright parts down and whose toe the dark ones: the curve of
// the mean is brighter than the mean of the curve in the shoulder, darker in the toe. The light
// across the pixel is taken as log-normal with that mean and spread, and its mean through the
// curve by 3-point Gauss–Hermite quadrature.
vec3 aces_over_spread(vec3 colour, float spread) {
    if (!(spread > 0.0)) return aces_fitted(colour);
    float log_variance = log(1.0 + spread);
    float reach = sqrt(3.0 * log_variance);
    float centre = exp(-0.5 * log_variance);
    return aces_fitted(colour * centre) * (2.0 / 3.0)
         + (aces_fitted(colour * (centre * exp(reach)))
            + aces_fitted(colour * (centre * exp(-reach)))) / 6.0;
}
