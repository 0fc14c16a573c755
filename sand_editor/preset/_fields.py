"""The table of preset fields: one row per field drives validation, defaults, docs and sliders."""

from __future__ import annotations

import difflib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

from sand_editor.preset._checks import (
    check_integer,
    check_number,
    describe,
    format_number,
    type_name,
)
from sand_editor.preset._color import Color
from sand_editor.preset._errors import PresetError

Kind = Literal["float", "int", "color", "colors", "weights", "text"]
# What a change of the field costs the renderer: new grain textures, new glint moments (built
# from the grains), or only a uniform of the same name with a ``u_`` prefix.
Cost = Literal["grains", "moments", "uniform", "none"]

# Grains in each cell of a generated layer: the generator draws two feature points per cell.
GRAINS_PER_CELL = 2


@dataclass(frozen=True)
class FieldSpec:
    """Description of one preset field.

    Parameters
    ----------
    path
        Dotted path, ``"generation.threshold"``; top-level fields have no dot.
    kind
        ``"float"``, ``"int"``, ``"color"``, ``"colors"`` (fixed-length list of colours),
        ``"weights"`` (fixed-length list of numbers) or ``"text"``.
    minimum, maximum
        Allowed range of the value (of each element for lists, of the length for text).
    default
        Value a new preset has, and a file that omits the field gets.
    label
        Short name for a control in the editor.
    doc
        One line saying what the field does.
    unit
        Unit for display (``"m"``, ``"1/m"``), empty when the value has none.
    cost
        What a change costs: ``"grains"`` (new textures: every generation field), ``"moments"``
        (new glint moments, and a uniform), ``"uniform"`` (the shader uniform ``u_<name>``
        alone) or ``"none"`` (not shown by the renderer: name, description).
    count
        Number of elements for ``"colors"`` and ``"weights"``.
    multiline
        Text may contain line breaks and tabs.
    """

    path: str
    kind: Kind
    minimum: float
    maximum: float
    default: Any
    label: str
    doc: str
    unit: str = ""
    cost: Cost = "none"
    count: int = 0
    multiline: bool = False

    @property
    def regenerates(self) -> bool:
        """Changing the field needs new grain textures."""
        return self.cost == "grains"

    @property
    def uniform(self) -> str | None:
        """The shader uniform that carries the field (``u_<name>``), or None."""
        return f"u_{self.name}" if self.cost in ("uniform", "moments") else None

    @property
    def section(self) -> str:
        """``"generation"``, ``"shading"`` or ``""`` for top-level fields."""
        return self.path.rpartition(".")[0]

    @property
    def name(self) -> str:
        """Field name within its section."""
        return self.path.rpartition(".")[2]

    def check(self, value: Any) -> Any:
        """Return ``value`` in its canonical Python form, or raise PresetError naming the path.

        Colours may be given as :class:`Color` or ``"#rrggbb"``; lists as lists or tuples.
        """
        return _CHECKS[self.kind](self, value)

    def to_json(self, value: Any) -> Any:
        """Return the JSON form of a checked value."""
        return _TO_JSON[self.kind](value)


def _check_float(spec: FieldSpec, value: Any) -> float:
    return check_number(value, spec.path, spec.minimum, spec.maximum)


def _check_int(spec: FieldSpec, value: Any) -> int:
    return check_integer(value, spec.path, int(spec.minimum), int(spec.maximum))


def _to_color(value: Any, path: str) -> Color:
    if isinstance(value, Color):
        return value
    try:
        return Color.from_hex(value)
    except PresetError as error:
        raise error.located(parent=path) from None


def _check_color(spec: FieldSpec, value: Any) -> Color:
    return _to_color(value, spec.path)


def _elements(spec: FieldSpec, value: Any, what: str) -> tuple[Any, ...]:
    if not isinstance(value, (list, tuple)):
        raise PresetError(
            f"{describe(value)} is {type_name(value)}; allowed an array of {spec.count} {what}",
            path=spec.path,
        )
    if len(value) != spec.count:
        raise PresetError(
            f"has {len(value)} entries; allowed exactly {spec.count} {what}", path=spec.path
        )
    return tuple(value)


def _check_colors(spec: FieldSpec, value: Any) -> tuple[Color, ...]:
    return tuple(
        _to_color(item, f"{spec.path}[{index}]")
        for index, item in enumerate(_elements(spec, value, "'#rrggbb' colours"))
    )


def _check_weights(spec: FieldSpec, value: Any) -> tuple[float, ...]:
    weights = tuple(
        check_number(item, f"{spec.path}[{index}]", spec.minimum, spec.maximum)
        for index, item in enumerate(_elements(spec, value, "numbers"))
    )
    # The weights are relative chances, so only an all-zero set has no meaning.
    if sum(weights) <= 0:
        raise PresetError(
            "all weights are 0; allowed weights from 0 to 100 with at least one above 0",
            path=spec.path,
        )
    return weights


def _check_text(spec: FieldSpec, value: Any) -> str:
    if not isinstance(value, str):
        raise PresetError(
            f"{describe(value)} is {type_name(value)}; allowed a string", path=spec.path
        )
    if not spec.minimum <= len(value) <= spec.maximum:
        raise PresetError(
            f"is {len(value)} characters long; allowed {format_number(spec.minimum)} to "
            f"{format_number(spec.maximum)}",
            path=spec.path,
        )
    allowed_controls = "\n\t" if spec.multiline else ""
    bad = next((c for c in value if not c.isprintable() and c not in allowed_controls), None)
    if bad is not None:
        kind = "printable characters and line breaks" if spec.multiline else "printable characters"
        raise PresetError(f"contains {bad!r}; allowed {kind} only", path=spec.path)
    return value


def _weight_to_json(weight: float) -> float | int:
    # Whole-number weights are written as 22 rather than 22.0, as people type them.
    return int(weight) if weight.is_integer() else weight


_CHECKS: dict[str, Callable[[FieldSpec, Any], Any]] = {
    "float": _check_float,
    "int": _check_int,
    "color": _check_color,
    "colors": _check_colors,
    "weights": _check_weights,
    "text": _check_text,
}

_TO_JSON: dict[str, Callable[[Any], Any]] = {
    "float": float,
    "int": int,
    "color": lambda color: color.hex,
    "colors": lambda colors: [color.hex for color in colors],
    "weights": lambda weights: [_weight_to_json(weight) for weight in weights],
    "text": str,
}


def _generation(name: str, *spec: Any, **extra: Any) -> FieldSpec:
    # Generation fields feed the texture generator, so any change means new textures.
    return FieldSpec(f"generation.{name}", *spec, cost="grains", **extra)


def _shading(name: str, *spec: Any, cost: Cost = "uniform", **extra: Any) -> FieldSpec:
    # Shading fields are uniforms of the material's shaders, named u_<name>.
    return FieldSpec(f"shading.{name}", *spec, cost=cost, **extra)


_hex = Color.from_hex

# Defaults are the reference's saved material "SandTexturesGeneration" and its preview material.
FIELDS: tuple[FieldSpec, ...] = (
    FieldSpec("name", "text", 1, 80, "paper-default", "Name",
              "Short name of the preset, one line."),
    FieldSpec("description", "text", 0, 2000, "", "Description",
              "What sand the preset is.", multiline=True),
    _generation("layers", "int", 0, 15, 10, "Layers",
                "Number of grain layers; lower layers only fill gaps left by higher ones."),
    _generation("threshold", "float", 0.0, 1.0, 0.296, "Threshold",
                "Spacing between grains; higher values need more layers to fill the gaps."),
    _generation("roundness", "float", 0.0, 1.0, 0.28, "Roundness",
                "Each grain is the cap of a ball around its centre: higher makes the balls "
                "smaller, so grains are smaller and rounder and face every way; lower gives "
                "broad, flat-topped grains."),
    _generation("seed", "int", 0, 2**32 - 1, 270, "Seed",
                "Picks a different arrangement of grains and colours."),
    _generation("base_color", "color", 0, 255, _hex("#ffd7c4"), "Base colour",
                "Colour shown in gaps that no layer fills."),
    _generation("colors", "colors", 0, 255,
                (_hex("#ffd7c4"), _hex("#652a0e"), _hex("#ffc4a7"), _hex("#ffd7c4")),
                "Grain colours", "The colours a grain may take.", count=4),
    _generation("weights", "weights", 0.0, 100.0, (22.0, 18.0, 56.0, 4.0), "Colour weights",
                "Relative chance of each grain colour.", count=4),
    _generation("layer_darkness", "float", 0.0, 1.0, 0.085, "Layer darkness",
                "How much darker each deeper layer is (less light reaches it)."),
    _generation("jitter", "float", 0.0, 1.0, 1.0, "Jitter",
                "Fraction of a cell a grain centre may move; 0 gives a regular lattice."),
    _generation("period", "int", 1, 256, 36, "Period",
                "Grain cells along each side of one texture tile.", unit="cells"),
    _shading("facet_roughness", "float", 0.01, 1.0, 0.219, "Facet roughness",
             "How far the tiny facets of a grain's surface tilt from its shape (Beckmann α): "
             "low is glassy, with small, sharp, bright glints; high is frosted, with broad, "
             "dim ones."),
    _shading("facet_size", "float", 20.0, 1000.0, 200.0, "Facet size",
             "Edge of the largest of the tiny mirror-like facets of a grain's surface (smaller "
             "ones reach a quarter of it): small facets give many faint sparkles, large ones few "
             "bright ones, with the same light on average. Never wider than a grain: on sand whose "
             "grains are smaller, the largest facets are a grain wide.",
             unit="µm"),
    _shading("clear_grains", "float", 0.0, 1.0, 1.0, "Clear grains",
             "Share of the top layer's grains that are clear enough to mirror the sun: how "
             "many glints there are (0: none, 1: every grain).", cost="moments"),
    _shading("grain_ior", "float", 1.3, 2.5, 1.458, "Grain refractive index",
             "Index of refraction of the grains: quartz 1.46, volcanic glass about 1.55, "
             "iron-oxide coatings up to 2.4; higher reflects more of the sun."),
    _shading("sss", "float", 0.0, 10.0, 0.733, "Subsurface",
             "Length of the light's path through the grains: scales the scattering and the "
             "absorption."),
    _shading("scattering", "float", 0.0, 1.0, 0.075, "Scattering",
             "Light scattered through grains to the side facing away from the light."),
    _shading("absorption", "float", 0.0, 10.0, 0.1, "Absorption",
             "Light absorbed on its way through the grains (the share scattering wraps "
             "around them, and the transmission); the grains' colours stay as given."),
    _shading("transmission", "float", 0.0, 1.0, 0.045, "Transmission",
             "Light transmitted through the grains toward the viewer."),
    _shading("transmission_roughness", "float", 0.0, 1.0, 0.0, "Transmission roughness",
             "Spread of light transmitted towards a viewer facing the light (1: broad)."),
    _shading("ripple_strength", "float", 0.0, 1.0, 0.053, "Ripple strength",
             "Strength of the sand-ripple normal maps at a distance."),
    _shading("wind_direction", "float", 0.0, 360.0, 30.0, "Wind from",
             "Compass direction the wind comes from (0 north, 90 east; 30 is a trade wind from "
             "the north-north-east): ripple crests lie across it, bending a little over the "
             "dunes.", unit="°"),
    _shading("detail_strength", "float", 0.0, 1.0, 0.046, "Detail strength",
             "Strength of the fine detail normal map at a distance."),
    _shading("sigmoid_a", "float", 0.01, 100.0, 3.0, "Blend sharpness",
             "How quickly close shading gives way to far shading with distance.", unit="1/m"),
    _shading("sigmoid_b", "float", -100.0, 1000.0, 2.0, "Blend distance",
             "Distance at which close and far shading are mixed half and half.", unit="m"),
    _shading("uv_scale", "float", 0.01, 10000.0, 8.0, "Texture scale",
             "Texture tiles per metre of ground.", unit="1/m"),
)  # fmt: skip

_BY_PATH = {spec.path: spec for spec in FIELDS}


def field_spec(path: str) -> FieldSpec:
    """Return the spec of the field at a dotted path.

    Raises
    ------
    PresetError
        For an unknown path, suggesting the closest known one.
    """
    try:
        return _BY_PATH[path]
    except KeyError:
        raise unknown_field(path, list(_BY_PATH)) from None


def section_fields(section: str) -> tuple[FieldSpec, ...]:
    """Specs of one section (``""`` for the top-level fields), in file order."""
    return tuple(spec for spec in FIELDS if spec.section == section)


def unknown_field(path: str, allowed: list[str]) -> PresetError:
    """Error for an unknown field name, suggesting the closest allowed name."""
    # Sections list bare names, replace() lists dotted paths: try the key both ways.
    close = difflib.get_close_matches(path, allowed, n=1) or difflib.get_close_matches(
        path.rpartition(".")[2], allowed, n=1
    )
    hint = f"did you mean {close[0]!r}? " if close else ""
    return PresetError(f"unknown field; {hint}allowed: {', '.join(allowed)}", path=path)
