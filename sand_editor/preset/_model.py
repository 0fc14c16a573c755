"""The preset model: immutable, validated generation and shading parameters."""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass, field
from typing import Any, ClassVar

from sand_editor.preset._checks import describe, type_name
from sand_editor.preset._document import SECTIONS, decode, encode
from sand_editor.preset._errors import PresetError
from sand_editor.preset._fields import (
    FIELDS,
    GRAINS_PER_CELL,
    field_spec,
    section_fields,
    unknown_field,
)
from sand_editor.preset._io import read_json, write_json_atomic


def _default(path: str) -> Any:
    return field_spec(path).default


class _Section:
    """Validation shared by the sections: every field is checked against its FieldSpec."""

    SECTION: ClassVar[str]

    def __post_init__(self) -> None:
        for spec in section_fields(self.SECTION):
            # Frozen dataclass: the canonical value (float for int input, tuple for list,
            # Color for "#rrggbb") is stored once at construction.
            object.__setattr__(self, spec.name, spec.check(getattr(self, spec.name)))


def _section_class(name: str, section: str, doc: str) -> type:
    """A frozen dataclass with one attribute per field of ``section`` in the field table, so
    that a new field is declared in the table alone."""
    return dataclasses.make_dataclass(
        name,
        [(spec.name, Any, field(default=spec.default)) for spec in section_fields(section)],
        bases=(_Section,),
        frozen=True,
        namespace={"SECTION": section, "__doc__": doc, "__module__": __name__},
    )


Generation = _section_class(
    "Generation",
    "generation",
    """Parameters of the grain textures; changing any of them means generating new textures.

    Defaults are the reference's saved material; see :data:`FIELDS` for ranges and meaning.
    Hashable, so generated textures can be cached on it.
    """,
)
Shading = _section_class(
    "Shading",
    "shading",
    """Shader parameters; each field's ``cost`` says what a change redoes (a uniform, or the
    glint moments).

    Defaults are the reference's saved preview material; see :data:`FIELDS`.
    """,
)


_SECTION_TYPES: dict[str, type] = {"generation": Generation, "shading": Shading}
_REPLACEABLE = [*SECTIONS, *(spec.path for spec in FIELDS)]


@dataclass(frozen=True)
class Preset:
    """A complete sand material: name, description, generation and shading parameters.

    Immutable and validated on construction; use :meth:`replace` to derive changed copies.
    """

    name: str = _default("name")
    description: str = _default("description")
    generation: Generation = field(default_factory=Generation)
    shading: Shading = field(default_factory=Shading)

    def __post_init__(self) -> None:
        for spec in section_fields(""):
            object.__setattr__(self, spec.name, spec.check(getattr(self, spec.name)))
        for section, section_type in _SECTION_TYPES.items():
            value = getattr(self, section)
            if not isinstance(value, section_type):
                raise PresetError(
                    f"{describe(value)} is {type_name(value)}; allowed a {section_type.__name__}",
                    path=section,
                )

    def get(self, path: str) -> Any:
        """Return the value at a dotted path such as ``"generation.threshold"``, or a section."""
        if path in SECTIONS:
            return getattr(self, path)
        spec = field_spec(path)
        owner = getattr(self, spec.section) if spec.section else self
        return getattr(owner, spec.name)

    @property
    def grain_spacing_m(self) -> float:
        """Mean distance between neighbouring grains of a layer, in metres on the ground: a tile
        is 1/uv_scale metres of ``period`` cells, each holding two grains."""
        cell_m = 1.0 / (self.shading.uv_scale * self.generation.period)
        return cell_m / math.sqrt(GRAINS_PER_CELL)

    @property
    def largest_facet_m(self) -> float:
        """Edge of a grain's largest mirroring facets, in metres: the facet size, but never wider
        than a grain, whose surface the facets tile (tiny grains with the largest facet size
        would otherwise mirror the sun in rare facets far larger than themselves)."""
        return min(self.shading.facet_size * 1.0e-6, self.grain_spacing_m)

    def replace(self, **changes: Any) -> Preset:
        """Return a copy with some values changed.

        Keys are top-level fields (``name``), sections (``generation=Generation(...)``) or
        dotted paths (``**{"generation.threshold": 0.4}``); section objects apply before dotted
        paths into the same section.

        Raises
        ------
        PresetError
            For an unknown key or an invalid value.
        """
        top_level: dict[str, Any] = {}
        nested: dict[str, dict[str, Any]] = {section: {} for section in SECTIONS}
        for key, value in changes.items():
            if key not in _REPLACEABLE:
                raise unknown_field(key, _REPLACEABLE)
            section, _, name = key.rpartition(".")
            if section:
                nested[section][name] = value
            else:
                top_level[key] = value
        for section, values in nested.items():
            if values:
                base = top_level.get(section, getattr(self, section))
                if isinstance(base, _SECTION_TYPES[section]):
                    top_level[section] = dataclasses.replace(base, **values)
                # otherwise the Preset constructor below reports the bad section object
        return dataclasses.replace(self, **top_level)

    def to_dict(self) -> dict[str, Any]:
        """Return the document written to preset files (current schema, JSON types only)."""
        return encode(self.get)

    @classmethod
    def from_dict(cls, data: Any, source: str | None = None) -> Preset:
        """Build a preset from a parsed document of any supported schema version.

        Fields the document omits take their defaults.

        Parameters
        ----------
        data
            The parsed JSON object, as :meth:`to_dict` returns it.
        source
            File name used in error messages.

        Raises
        ------
        PresetError
            Naming ``source`` and the field path, for anything not acceptable.
        """
        try:
            arguments = decode(data)
            for section, section_type in _SECTION_TYPES.items():
                arguments[section] = section_type(**arguments[section])
            return cls(**arguments)
        except PresetError as error:
            raise error.located(source) from None

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Preset:
        """Read a preset file.

        Raises
        ------
        PresetError
            For any problem with the file or its contents, naming the file.
        """
        return cls.from_dict(read_json(path), source=os.fspath(path))

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the preset to ``path`` atomically (the old file survives any failure).

        Raises
        ------
        PresetError
            When the file cannot be written, naming it.
        """
        write_json_atomic(path, self.to_dict())
