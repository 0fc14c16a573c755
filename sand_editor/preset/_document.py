"""The preset document: the JSON object layout, its schema versions and their migrations."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from sand_editor.preset._checks import describe, type_name
from sand_editor.preset._errors import PresetError
from sand_editor.preset._fields import section_fields, unknown_field
from sand_editor.untrusted import deeper_than

FORMAT = "sand-editor-preset"
SCHEMA_VERSION = 2
SECTIONS = ("generation", "shading")

# Schema 2 as it was released. A migration must keep describing the schema it produces even
# after later versions rename or move fields, so these names are frozen rather than read from
# the live field table.
_V2_SECTION_FIELDS = {
    "generation": (
        "layers", "threshold", "roundness", "seed", "base_color", "colors", "weights",
        "layer_darkness", "jitter", "period",
    ),
    "shading": (
        "glint_shininess", "glint_sigma", "glint_mu", "sample_count", "sample_spread", "sss",
        "scattering", "absorption", "fresnel_roughness", "transmission",
        "transmission_roughness", "ripple_strength", "detail_strength", "sigmoid_a",
        "sigmoid_b", "uv_scale",
    ),
}  # fmt: skip


MAX_DEPTH = 8  # a preset nests three deep (document, section, list)


def check_depth(document: Any) -> None:
    """Refuse documents nested deeper than ``MAX_DEPTH`` (without recursing into them)."""
    if deeper_than(document, MAX_DEPTH):
        raise PresetError(f"nested more than {MAX_DEPTH} deep; presets nest 3 deep")


def _v1_to_v2(document: dict[str, Any]) -> dict[str, Any]:
    """Schema 1 had every field at the top level; schema 2 groups them into sections."""
    for section in _V2_SECTION_FIELDS:
        if section in document:
            # Moving schema 1's fields into sections would replace this one: refuse, not lose it.
            raise PresetError(
                f"is 1, but the file has a {section!r} section, which schema 1 does not have; "
                "allowed: schema_version 2 for a file with sections",
                path="schema_version",
            )
    migrated: dict[str, Any] = {}
    sections: dict[str, dict[str, Any]] = {name: {} for name in _V2_SECTION_FIELDS}
    for key, value in document.items():
        section = next((s for s, names in _V2_SECTION_FIELDS.items() if key in names), None)
        if section is None:
            # Unknown keys stay where they are so that validation reports them.
            migrated[key] = value
        else:
            sections[section][key] = value
    migrated.update(sections)
    migrated["schema_version"] = 2
    return migrated


# Each function turns a document of the key's version into one of the next version.
MIGRATIONS: dict[int, Callable[[dict[str, Any]], dict[str, Any]]] = {1: _v1_to_v2}


def _schema_version(document: dict[str, Any]) -> int:
    allowed = f"allowed an integer from 1 to {SCHEMA_VERSION}"
    if "schema_version" not in document:
        raise PresetError(f"missing; {allowed}", path="schema_version")
    version = document["schema_version"]
    if isinstance(version, bool) or not isinstance(version, int):
        raise PresetError(
            f"{describe(version)} is {type_name(version)}; {allowed}", path="schema_version"
        )
    if version > SCHEMA_VERSION:
        raise PresetError(
            f"written by a newer Sand Editor: schema version {version}, "
            f"this version reads up to {SCHEMA_VERSION}",
            path="schema_version",
        )
    if version < 1:
        raise PresetError(f"{version} is not a schema version; {allowed}", path="schema_version")
    return version


def migrate(document: dict[str, Any]) -> dict[str, Any]:
    """Bring a document of any supported schema version to the current one.

    The input is not modified.
    """
    version = _schema_version(document)
    while version < SCHEMA_VERSION:
        document = MIGRATIONS[version](document)
        version = document["schema_version"]
    return document


def decode(document: Any) -> dict[str, Any]:
    """Check a parsed document and return the keyword arguments of its preset.

    Top-level fields map to their raw values and each section to a dict of raw values; fields
    the document omits are left out so that they take their defaults. Values are only checked
    by the model classes.

    Raises
    ------
    PresetError
        For a wrong format name, an unsupported schema version or unknown fields.
    """
    if not isinstance(document, dict):
        raise PresetError(
            f'the top level is {type_name(document)}; allowed an object with "format": "{FORMAT}"'
        )
    check_depth(document)
    if document.get("format") != FORMAT:
        found = f"{describe(document['format'])} is not" if "format" in document else "missing;"
        raise PresetError(f"{found} a Sand Editor preset; allowed {FORMAT!r}", path="format")
    document = migrate(document)

    top_level = [spec.name for spec in section_fields("")]
    allowed = ["format", "schema_version", *top_level, *SECTIONS]
    for key in document:
        if key not in allowed:
            raise unknown_field(str(key), allowed)
    arguments: dict[str, Any] = {name: document[name] for name in top_level if name in document}

    for section in SECTIONS:
        body = document.get(section, {})
        if not isinstance(body, dict):
            raise PresetError(
                f"{describe(body)} is {type_name(body)}; allowed an object", path=section
            )
        names = [spec.name for spec in section_fields(section)]
        for key in body:
            if key not in names:
                raise unknown_field(f"{section}.{key}", names)
        arguments[section] = dict(body)
    return arguments


def encode(get: Callable[[str], Any]) -> dict[str, Any]:
    """Build the current-schema document from a getter of field values by dotted path."""
    document: dict[str, Any] = {"format": FORMAT, "schema_version": SCHEMA_VERSION}
    for spec in section_fields(""):
        document[spec.name] = spec.to_json(get(spec.path))
    for section in SECTIONS:
        document[section] = {
            spec.name: spec.to_json(get(spec.path)) for spec in section_fields(section)
        }
    return document
