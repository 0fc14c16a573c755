"""Text from outside made safe to show in one line: escaped and bounded. Standard library only."""

from __future__ import annotations

import unicodedata


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
