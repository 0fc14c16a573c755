"""Reading and writing preset files: size limit, UTF-8, strict JSON, atomic replacement."""

from __future__ import annotations

import contextlib
import json
import os
import stat
import tempfile
from typing import Any

from sand_editor.preset._errors import PresetError

MAX_FILE_BYTES = 1 << 20
_LIMIT_TEXT = f"presets are limited to 1 MiB ({MAX_FILE_BYTES} bytes)"


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
    if stat.S_ISDIR(info.st_mode):
        raise PresetError("is a folder; allowed a preset file", source=source)
    if not stat.S_ISREG(info.st_mode):
        raise PresetError("is not a regular file; allowed a preset file", source=source)
    # Checked before reading so that a huge (or sparse) file costs nothing.
    if info.st_size > MAX_FILE_BYTES:
        raise PresetError(f"the file is {info.st_size} bytes; {_LIMIT_TEXT}", source=source)
    try:
        with open(source, "rb") as stream:
            raw = stream.read(MAX_FILE_BYTES + 1)
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
        return json.loads(text, parse_constant=_constant, object_pairs_hook=_refuse_duplicates)
    except json.JSONDecodeError as error:
        raise PresetError(
            f"not valid JSON: {error.msg} at line {error.lineno}, column {error.colno}",
            source=source,
        ) from None
    except RecursionError:
        raise PresetError("not valid JSON: nested too deeply", source=source) from None
    except PresetError as error:
        raise error.located(source) from None


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
    """Write JSON to ``path`` so that readers see the old file or the new one, never a mix.

    The text goes to a temporary file in the same folder, is flushed to disk, and then
    replaces the target in one rename. On failure the temporary file is removed and the
    target is untouched.

    Raises
    ------
    PresetError
        For any failure, naming the file.
    """
    source = os.fspath(path)
    # Through a symlink, replace the file it points to rather than the link.
    target = os.path.realpath(source)
    folder = os.path.dirname(target)
    temp_name: str | None = None
    try:
        payload = to_json_text(document)
        with tempfile.NamedTemporaryFile(
            "wb", dir=folder, prefix=f".{os.path.basename(target)}.", suffix=".tmp", delete=False
        ) as stream:
            temp_name = stream.name
            stream.write(payload.encode("utf-8"))
            stream.flush()
            os.fsync(stream.fileno())
        os.chmod(temp_name, _mode_for(target))
        os.replace(temp_name, target)
        temp_name = None
    except OSError as error:
        reason = _reason(error) if os.path.isdir(folder) else f"the folder {folder} does not exist"
        raise PresetError(f"cannot save: {reason}", source=source) from error
    except Exception as error:
        raise PresetError(f"cannot save: {error}", source=source) from error
    finally:
        if temp_name is not None:
            with contextlib.suppress(OSError):
                os.unlink(temp_name)
    _sync_folder(folder)


def _mode_for(target: str) -> int:
    # Keep the permissions of the file being replaced; temporary files start out private.
    try:
        return stat.S_IMODE(os.stat(target).st_mode)
    except OSError:
        return 0o644


def _sync_folder(folder: str) -> None:
    # Makes the rename itself durable on POSIX; folders cannot be opened this way on Windows.
    with contextlib.suppress(OSError, AttributeError):
        descriptor = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(descriptor)
        finally:
            os.close(descriptor)
