"""Input from outside (files, the VR link, command lines) kept within bounds: text escaped and
cut to one line, nesting measured without recursion, numbers bounded before conversion and
written in ASCII digits.

Standard library only: the preset model and the link use it."""

from __future__ import annotations

import re
import unicodedata
from collections.abc import Callable
from typing import Any


def printable(text: str) -> str:
    """``text`` with control, format and line-separator characters escaped (``\\n``,
    ``\\x1b``, ``\\u2028``), so that a message from a hostile file stays one line and shows
    exactly what is there."""
    if text.isprintable():
        return text
    out = []
    for char in text:
        if char.isprintable() or char == " ":
            out.append(char)
        elif unicodedata.category(char) == "Zs":
            out.append(" ")
        else:
            out.append(char.encode("unicode_escape").decode("ascii"))
    return "".join(out)


def shorten(text: str, limit: int, keep_end: bool = False) -> str:
    """``text`` cut to ``limit`` characters with an ellipsis where it was cut."""
    if len(text) <= limit:
        return text
    return "…" + text[-(limit - 1) :] if keep_end else text[: limit - 1] + "…"


def deeper_than(value: Any, limit: int) -> bool:
    """True when lists and dicts in ``value`` nest more than ``limit`` levels (the value itself
    is level 1); iterative, so any depth is measured without recursing."""
    stack = [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if depth > limit:
            return True
        if isinstance(item, dict):
            stack.extend((child, depth + 1) for child in item.values())
        elif isinstance(item, (list, tuple)):
            stack.extend((child, depth + 1) for child in item)
    return False


def bounded_number(
    convert: Callable[[str], Any], limit: int, error: type[Exception]
) -> Callable[[str], Any]:
    """A JSON number parser (``parse_int=``, ``parse_float=``) that raises ``error`` for a number
    written in more than ``limit`` characters: Python refuses integers of over 4300 digits with a
    ValueError of its own, and no value we accept needs a hundred."""

    def parse(text: str) -> Any:
        if len(text) > limit:
            raise error(f"a number of {len(text)} characters; allowed at most {limit}")
        return convert(text)

    return parse


MAX_NUMBER_CHARS = 40  # no number a person types for us needs more
# Python's int() and float() also read other scripts' digits ("١٢" is 12), underscores ("1_0")
# and surrounding Unicode spaces; a number from outside is spelled in ASCII only.
_INTEGER = re.compile(r"[+-]?[0-9]+")
_NUMBER = re.compile(
    r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|[+-]?(?:inf|infinity|nan)",
    re.IGNORECASE,
)


def integer(text: str) -> int:
    """``text`` as an int: an optional sign and the digits 0-9, at most 40 characters.

    Raises ValueError otherwise (argparse, given it as a ``type``, reports "invalid integer
    value")."""
    if len(text) > MAX_NUMBER_CHARS or not _INTEGER.fullmatch(text):
        raise ValueError(f"{text!r}: expected a whole number in the digits 0-9")
    return int(text)


def number(text: str) -> float:
    """``text`` as a float, spelled as Python writes one in ASCII (``-1.5``, ``2e-3``, ``.5``,
    ``inf``, ``nan``), at most 40 characters; raises ValueError otherwise."""
    if len(text) > MAX_NUMBER_CHARS or not _NUMBER.fullmatch(text):
        raise ValueError(f"{text!r}: expected a number in the digits 0-9")
    return float(text)
