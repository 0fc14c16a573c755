"""Type and range checks shared by colours and preset fields, with user-facing messages."""

from __future__ import annotations

import math
from typing import Any

from sand_editor.preset._errors import PresetError

_JSON_TYPE_NAMES = (
    (bool, "a boolean"),
    (str, "a string"),
    (int, "an integer"),
    (float, "a number"),
    (dict, "an object"),
    (list, "an array"),
    (tuple, "an array"),
)


def format_number(number: float) -> str:
    """Write a number the way a person would type it (``1`` rather than ``1.0``)."""
    if isinstance(number, float) and number.is_integer():
        return str(int(number))
    return repr(number)


def describe(value: Any) -> str:
    """Short rendering of a value for a message, in JSON-like spelling."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, int) and value.bit_length() > 190:
        # repr() of an integer past 4300 digits raises; no person types one this long anyway.
        return f"an integer of about {int(value.bit_length() * math.log10(2)) + 1} digits"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def type_name(value: Any) -> str:
    """JSON name of the value's type, with an article (``"a string"``)."""
    if value is None:
        return "null"
    for kind, name in _JSON_TYPE_NAMES:
        if isinstance(value, kind):
            return name
    return f"a {type(value).__name__}"


def _range_text(minimum: float, maximum: float) -> str:
    return f"{format_number(minimum)} to {format_number(maximum)}"


def _check_range(value: float, path: str | None, minimum: float, maximum: float) -> None:
    if not minimum <= value <= maximum:
        raise PresetError(
            f"{describe(value)} is out of range; allowed {_range_text(minimum, maximum)}",
            path=path,
        )


def check_number(value: Any, path: str | None, minimum: float, maximum: float) -> float:
    """Return ``value`` as a finite float within ``[minimum, maximum]``."""
    allowed = f"allowed numbers from {_range_text(minimum, maximum)}"
    # bool is an int subclass, but true/false in a preset is always a mistake.
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise PresetError(f"{describe(value)} is {type_name(value)}; {allowed}", path=path)
    if isinstance(value, float) and not math.isfinite(value):
        raise PresetError(f"{describe(value)} is not allowed; finite numbers only", path=path)
    _check_range(value, path, minimum, maximum)
    return float(value)


def check_integer(value: Any, path: str | None, minimum: int, maximum: int) -> int:
    """Return ``value`` as an int within ``[minimum, maximum]``; floats such as 3.0 are refused."""
    allowed = f"allowed an integer from {_range_text(minimum, maximum)}"
    if isinstance(value, bool) or not isinstance(value, int):
        raise PresetError(f"{describe(value)} is not an integer; {allowed}", path=path)
    _check_range(value, path, minimum, maximum)
    return int(value)
