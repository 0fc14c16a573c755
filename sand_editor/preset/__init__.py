"""The preset model: validated sand parameters and their JSON file format.

Standard library only, so that the model loads without Qt, OpenGL or numpy.
"""

from sand_editor.preset._color import Color
from sand_editor.preset._document import FORMAT, MIGRATIONS, SCHEMA_VERSION
from sand_editor.preset._errors import PresetError
from sand_editor.preset._fields import FIELDS, GRAINS_PER_CELL, FieldSpec, field_spec
from sand_editor.preset._io import GLTF_EXTRAS_KEY, GLTF_SUFFIXES, MAX_FILE_BYTES
from sand_editor.preset._model import Generation, Preset, Shading

__all__ = [
    "FIELDS",
    "GRAINS_PER_CELL",
    "FORMAT",
    "GLTF_EXTRAS_KEY",
    "GLTF_SUFFIXES",
    "MAX_FILE_BYTES",
    "MIGRATIONS",
    "SCHEMA_VERSION",
    "Color",
    "FieldSpec",
    "Generation",
    "Preset",
    "PresetError",
    "Shading",
    "field_spec",
]
