"""What every benchmark does with its results: a table on stdout, JSON and a plot on request."""

from __future__ import annotations

import json
from collections.abc import Callable

from sand_editor.files import write_atomic


def write_json(path: str, document: dict) -> None:
    """``document`` as indented JSON, written whole or not at all (folders made as needed)."""
    write_atomic(path, (json.dumps(document, indent=2) + "\n").encode(), make_folder=True)


def report(
    results: dict,
    format_table: Callable[[dict], str],
    plot: Callable[[dict, str], None],
    json_path: str | None = None,
    plot_path: str | None = None,
) -> int:
    print(format_table(results))
    if json_path:
        write_json(json_path, results)
    if plot_path:
        plot(results, plot_path)
    return 0
