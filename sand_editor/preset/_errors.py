"""The one exception the preset package raises for bad input."""

from __future__ import annotations

from sand_editor.untrusted import printable, shorten

MAX_MESSAGE_CHARS = 300  # a whole message, file name and field path included
_MAX_SOURCE_CHARS = 100  # a file name keeps its end, where the name is
_MAX_PATH_CHARS = 60  # a field path (it may be a key read from the file) keeps its start


class PresetError(ValueError):
    """A preset file or value is not acceptable.

    The message names the file (when there is one), the field path (when there is one) and
    what is allowed, in the form ``"{file}: {path}: {problem}; allowed ..."``: always one line
    of at most ``MAX_MESSAGE_CHARS`` characters, with control characters escaped.

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
        self.message = printable(shorten(str(message), MAX_MESSAGE_CHARS))
        self.path = None if path is None else shorten(printable(str(path)), _MAX_PATH_CHARS)
        self.source = (
            None
            if source is None
            else shorten(printable(str(source)), _MAX_SOURCE_CHARS, keep_end=True)
        )
        text = ": ".join(part for part in (self.source, self.path, self.message) if part)
        super().__init__(shorten(text, MAX_MESSAGE_CHARS))

    def located(self, source: str | None = None, parent: str | None = None) -> PresetError:
        """Return the same error with a file name and/or a parent path prefixed."""
        path = self.path
        if parent:
            path = f"{parent}.{path}" if path else parent
        return PresetError(self.message, path=path, source=source or self.source)
