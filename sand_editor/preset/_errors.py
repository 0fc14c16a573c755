"""The one exception the preset package raises for bad input."""

from __future__ import annotations


class PresetError(ValueError):
    """A preset file or value is not acceptable.

    The message names the file (when there is one), the field path (when there is one) and
    what is allowed, in the form ``"{file}: {path}: {problem}; allowed ..."``.

    Parameters
    ----------
    message
        What is wrong and what is allowed.
    path
        Dotted field path such as ``"generation.threshold"``, or None.
    source
        File the value came from, or None.
    """

    def __init__(self, message: str, *, path: str | None = None, source: str | None = None):
        self.message = message
        self.path = path
        self.source = source
        super().__init__(": ".join(part for part in (source, path, message) if part))

    def located(self, source: str | None = None, parent: str | None = None) -> PresetError:
        """Return the same error with a file name and/or a parent path prefixed."""
        path = self.path
        if parent:
            path = f"{parent}.{path}" if path else parent
        return PresetError(self.message, path=path, source=source or self.source)
