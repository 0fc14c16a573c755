"""8-bit sRGB colours."""

from __future__ import annotations

import re
from dataclasses import dataclass

from sand_editor.colour import srgb_decode
from sand_editor.preset._checks import check_integer, describe, type_name
from sand_editor.preset._errors import PresetError

_HEX = re.compile(r"#[0-9a-fA-F]{6}")


@dataclass(frozen=True)
class Color:
    """An sRGB colour with 8 bits per channel.

    Parameters
    ----------
    r, g, b
        Channel values from 0 to 255.
    """

    r: int
    g: int
    b: int

    def __post_init__(self) -> None:
        for channel in ("r", "g", "b"):
            check_integer(getattr(self, channel), channel, 0, 255)

    @classmethod
    def from_hex(cls, text: str) -> Color:
        """Parse ``"#rrggbb"`` (either case).

        Raises
        ------
        PresetError
            (a ValueError) for anything else, including ``"#rgb"`` and names.
        """
        if not isinstance(text, str) or not _HEX.fullmatch(text):
            shown = describe(text) if isinstance(text, str) else type_name(text)
            raise PresetError(f"{shown} is not a colour; allowed '#rrggbb' (six hex digits)")
        return cls(int(text[1:3], 16), int(text[3:5], 16), int(text[5:7], 16))

    @property
    def hex(self) -> str:
        """``"#rrggbb"`` in lower case."""
        return f"#{self.r:02x}{self.g:02x}{self.b:02x}"

    @property
    def srgb(self) -> tuple[float, float, float]:
        """Encoded channel values in [0, 1]."""
        return (self.r / 255, self.g / 255, self.b / 255)

    @property
    def linear(self) -> tuple[float, float, float]:
        """Linear-light channel values in [0, 1] (exact sRGB transfer function)."""
        r, g, b = self.srgb
        return (srgb_decode(r), srgb_decode(g), srgb_decode(b))

    def __str__(self) -> str:
        return self.hex
