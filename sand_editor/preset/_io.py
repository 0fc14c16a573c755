"""Reading and writing preset files: size limit, UTF-8, strict JSON, atomic replacement.

A glTF asset that ``sand-editor export`` wrote (``.glb`` or ``.gltf``) reads as the preset in
its material's extras; only its JSON is read, never its images.
"""

from __future__ import annotations

import json
import os
import stat
import struct
from typing import Any

from sand_editor.files import OutputError, write_atomic
from sand_editor.preset._errors import PresetError
from sand_editor.untrusted import bounded_number

MAX_FILE_BYTES = 1 << 20
MAX_NUMBER_CHARS = 100  # every value a preset allows is written in far fewer
_LIMIT_TEXT = f"presets are limited to 1 MiB ({MAX_FILE_BYTES} bytes)"
GLTF_SUFFIXES = (".glb", ".gltf")
GLTF_EXTRAS_KEY = "sand_editor"  # materials[i].extras.sand_editor.preset
_GLB_MAGIC, _GLB_JSON = 0x46546C67, 0x4E4F534A


def _reason(error: OSError) -> str:
    return error.strerror or str(error)


def _refuse_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    # json keeps the last of duplicate keys silently; in a hand-edited preset that hides edits.
    result: dict[str, Any] = {}
    for key, value in pairs:
        if key in result:
            raise PresetError(f"the key {key!r} appears twice in one object; allowed once")
        result[key] = value
    return result


_integer = bounded_number(int, MAX_NUMBER_CHARS, PresetError)
_float = bounded_number(float, MAX_NUMBER_CHARS, PresetError)


def parse_json(text: str) -> Any:
    """Strict JSON of a preset: duplicate keys refused, numbers bounded, NaN and Infinity kept
    for the field checks to refuse by name. Raises PresetError (without a file name)."""
    try:
        return json.loads(
            text,
            parse_constant=_constant,
            parse_int=_integer,
            parse_float=_float,
            object_pairs_hook=_refuse_duplicates,
        )
    except json.JSONDecodeError as error:
        raise PresetError(
            f"not valid JSON: {error.msg} at line {error.lineno}, column {error.colno}"
        ) from None
    except RecursionError:
        raise PresetError("not valid JSON: nested too deeply") from None


def _constant(name: str) -> float:
    # NaN and Infinity parse to floats here; the field checks refuse them with the field's path.
    return float(name)


def read_json(path: str | os.PathLike[str]) -> Any:
    """Read a preset file and return its parsed JSON.

    Raises
    ------
    PresetError
        For a missing, unreadable, oversized, non-UTF-8 or malformed file.
    """
    source = os.fspath(path)
    try:
        info = os.stat(source)
    except FileNotFoundError:
        raise PresetError("no such file", source=source) from None
    except OSError as error:
        raise PresetError(f"cannot read: {_reason(error)}", source=source) from None
    except ValueError:  # a NUL character: no file can have that name
        raise PresetError("no such file: the name has a NUL character", source=source) from None
    if stat.S_ISDIR(info.st_mode):
        raise PresetError("is a folder; allowed a preset file", source=source)
    if not stat.S_ISREG(info.st_mode):
        raise PresetError("is not a regular file; allowed a preset file", source=source)
    glb = source.lower().endswith(".glb")
    # Checked before reading so that a huge (or sparse) file costs nothing; a GLB's images are
    # not read at all.
    if info.st_size > MAX_FILE_BYTES and not glb:
        raise PresetError(f"the file is {info.st_size} bytes; {_LIMIT_TEXT}", source=source)
    try:
        with open(source, "rb") as stream:
            raw = _glb_json_chunk(stream, source) if glb else stream.read(MAX_FILE_BYTES + 1)
    except OSError as error:
        raise PresetError(f"cannot read: {_reason(error)}", source=source) from None
    if len(raw) > MAX_FILE_BYTES:
        raise PresetError(f"the file grew while being read; {_LIMIT_TEXT}", source=source)
    try:
        # utf-8-sig: editors on Windows like to start files with a byte order mark.
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise PresetError(
            f"not UTF-8 text (byte 0x{raw[error.start]:02x} at offset {error.start}); "
            "allowed UTF-8 JSON",
            source=source,
        ) from None
    try:
        document = parse_json(text)
    except PresetError as error:
        raise error.located(source) from None
    if source.lower().endswith(GLTF_SUFFIXES):
        return _preset_in_gltf(document, source)
    return document


def _glb_json_chunk(stream, source: str) -> bytes:
    """The JSON chunk of a binary glTF (its header, then the first chunk), bounded."""
    header = stream.read(20)
    if len(header) < 20:
        raise PresetError("is not a binary glTF: shorter than its header", source=source)
    magic, version, _length, chunk_length, chunk_type = struct.unpack("<5I", header)
    if magic != _GLB_MAGIC or version != 2 or chunk_type != _GLB_JSON:
        raise PresetError("is not a binary glTF 2.0 (no glTF header and JSON chunk)", source=source)
    if chunk_length > MAX_FILE_BYTES:
        raise PresetError(
            f"its JSON chunk is {chunk_length} bytes; allowed up to {MAX_FILE_BYTES}", source=source
        )
    raw = stream.read(chunk_length)
    if len(raw) != chunk_length:
        raise PresetError("is cut short inside its JSON chunk", source=source)
    return raw


def _preset_in_gltf(document: Any, source: str) -> Any:
    materials = document.get("materials") if isinstance(document, dict) else None
    for material in materials if isinstance(materials, list) else []:
        extras = material.get("extras") if isinstance(material, dict) else None
        ours = extras.get(GLTF_EXTRAS_KEY) if isinstance(extras, dict) else None
        if isinstance(ours, dict) and "preset" in ours:
            return ours["preset"]
    raise PresetError(
        f"has no sand preset (materials[].extras.{GLTF_EXTRAS_KEY}.preset); allowed a glTF "
        "file that sand-editor export wrote",
        source=source,
    )


def to_json_text(document: Any) -> str:
    """Format JSON with 2-space indented objects and one-line arrays, ending in a newline.

    Arrays stay on one line because in presets they are short lists of colours or weights,
    which read best side by side.
    """
    return _format(document, "") + "\n"


def _format(value: Any, indent: str) -> str:
    if isinstance(value, dict) and value:
        inner = indent + "  "
        members = ",\n".join(
            f"{inner}{json.dumps(str(key), ensure_ascii=False)}: {_format(item, inner)}"
            for key, item in value.items()
        )
        return f"{{\n{members}\n{indent}}}"
    return json.dumps(value, ensure_ascii=False, allow_nan=False, separators=(", ", ": "))


def write_json_atomic(path: str | os.PathLike[str], document: Any) -> None:
    """Write JSON to ``path`` so that readers see the old file or the new one, never a mix
    (:func:`sand_editor.files.write_atomic`).

    Raises
    ------
    PresetError
        For any failure, naming the file.
    """
    source = os.fspath(path)
    if source.lower().endswith(GLTF_SUFFIXES):
        raise PresetError(
            "is a glTF file; presets are saved as .json (sand-editor export writes glTF)",
            source=source,
        )
    try:
        payload = to_json_text(document).encode("utf-8")
    except (TypeError, ValueError) as error:
        raise PresetError(f"cannot save: {error}", source=source) from None
    try:
        write_atomic(source, payload)
    except OutputError as error:
        reason = error.reason if error.cause is None else f"cannot save: {error.cause}"
        raise PresetError(reason, source=source) from None
