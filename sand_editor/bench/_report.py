"""What every benchmark does with its results: a table on stdout, JSON and a plot on request."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path


def report(
    results: dict,
    format_table: Callable[[dict], str],
    plot: Callable[[dict, str], None],
    json_path: str | None = None,
    plot_path: str | None = None,
) -> int:
    print(format_table(results))
    if json_path:
        Path(json_path).write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
    if plot_path:
        plot(results, plot_path)
    return 0
