"""Render modes: their names on the command line and in the API, and their shader constants."""

from __future__ import annotations

from sand_editor.view import MODES

MODE_HELP = {
    "full": "the material: glints and grains close up, BRDF far away, blended by distance",
    "reference-look": "the full material with the reference's glints (its gain and distance boost"
    " e^(5m), expected values without sparkle), for comparison",
    "lambert": "plain Lambertian shading of the average colour on the macro normal (comparison)",
    "close": "close-range shading only (grain normals, glints, diffuse)",
    "far": "far-range shading only (d'Eon's BRDF on the rippled macro normal)",
    "blend": "the blend weight s(d) as grey: black close, white far",
    "glints": "the glint term alone",
    "normals": "micro (grain) normals in world space, n·0.5 + 0.5",
    "mip": "the grain textures' mip level, blue (0) to red (highest)",
}


# The modes that blend the close and the far range by distance: the only ones whose far-only
# program variant draws anything (``sand_covers`` in shaders/sand_surface.glsl).
BLENDED_MODES = frozenset({"full", "reference-look"})


def check_mode(mode: str) -> str:
    if mode not in MODES:
        raise ValueError(f"unknown render mode {mode!r}; allowed: {', '.join(MODES)}")
    return mode


def mode_index(mode: str) -> int:
    return MODES.index(check_mode(mode))


def mode_defines() -> dict[str, int]:
    """``MODE_FULL`` = 0, ``MODE_LAMBERT`` = 1, … for the shaders."""
    return {f"MODE_{name.upper().replace('-', '_')}": index for index, name in enumerate(MODES)}
