"""The preset document: the JSON object layout, its schema versions and their migrations."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from sand_editor.preset._checks import check_number, describe, type_name
from sand_editor.preset._errors import PresetError
from sand_editor.preset._fields import section_fields, unknown_field
from sand_editor.untrusted import deeper_than

FORMAT = "sand-editor-preset"
SCHEMA_VERSION = 3
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


# Schema 2's glint fields, their defaults and ranges as released; schema 3 replaces them.
_V2_GLINT = {
    "glint_shininess": (10.4, 0.1, 1000.0),
    "glint_sigma": (0.277, 0.001, 10.0),
    "glint_mu": (2.0, -10.0, 10.0),
}
# Schema 2's fields that only the reference's multisampling and Fresnel damping used.
_V2_DROPPED = ("sample_count", "sample_spread", "fresnel_roughness")


def facet_roughness_of(shininess: float) -> float:
    """The Beckmann roughness of a Phong exponent: the lobe exp(−θ²·Gs) about the mirror
    direction is a Gaussian of variance 1/(2·Gs) in the normal's angle, α²/2 per axis."""
    return 1.0 / math.sqrt(2.0 * shininess)


# The reference's glint gain, 5000·e² (its boost at a tenth of the way from the finest mip
# level, where its look was tuned), and the reflectance at normal incidence of quartz.
_REFERENCE_GAIN = 5000.0 * math.e**2
_QUARTZ_F0 = ((1.458 - 1.0) / (1.458 + 1.0)) ** 2


def clear_share_of(mu: float, sigma: float, shininess: float) -> float:
    """The share of clear grains that carries the reference's glint energy, as far as the
    facet model allows (at most every grain).

    The reference's mean glint, at normal incidence, is gain × E[w] × 2π·var times the slope
    density there, with w the Gaussian selection over glint values g uniform in [0, 1) and
    var = 1/(4·Gs) its Phong lobe's variance in slope; the facet model's is F₀·share/4 times
    the same density. Their ratio is the share.
    """
    scale = sigma * math.sqrt(2.0)
    span = math.erf((1.0 - mu) / scale) - math.erf(-mu / scale)
    mean_w = sigma * math.sqrt(math.pi / 2.0) * span
    share = _REFERENCE_GAIN * mean_w * 2.0 * math.pi / (4.0 * shininess) * 4.0 / _QUARTZ_F0
    return min(max(share, 0.0), 1.0)


def _significant(value: float, digits: int = 3) -> float:
    return float(f"{value:.{digits}g}")


def _v2_to_v3(document: dict[str, Any]) -> dict[str, Any]:
    """Schema 3 describes glints by the grains' facets: facet roughness and the share of clear
    grains replace the reference's shininess and selection Gaussian (μ, σ); its sample count,
    sample spread and Fresnel damping are gone. The look of schema 2 files is kept."""
    migrated = dict(document)
    migrated["schema_version"] = 3
    shading = document.get("shading")
    if not isinstance(shading, dict):
        return migrated  # validation reports it
    old = {}
    for name, (default, minimum, maximum) in _V2_GLINT.items():
        value = shading.get(name, default)
        old[name] = check_number(value, f"shading.{name} (schema 2)", minimum, maximum)
    new = {k: v for k, v in shading.items() if k not in _V2_GLINT and k not in _V2_DROPPED}
    new.setdefault(
        "facet_roughness",
        _significant(min(max(facet_roughness_of(old["glint_shininess"]), 0.01), 1.0)),
    )
    new.setdefault(
        "clear_grains",
        _significant(clear_share_of(old["glint_mu"], old["glint_sigma"], old["glint_shininess"])),
    )
    migrated["shading"] = new
    return migrated


# Each function turns a document of the key's version into one of the next version.
MIGRATIONS: dict[int, Callable[[dict[str, Any]], dict[str, Any]]] = {
    1: _v1_to_v2,
    2: _v2_to_v3,
}


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
