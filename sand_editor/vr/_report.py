"""What the frame loop measures for ``--report``: per-frame times and counts."""

from __future__ import annotations

import numpy as np


class FrameStats:
    """Lists of per-frame milliseconds and the counts the report is made of."""

    def __init__(self) -> None:
        self.eye_ms: list[float] = []
        self.overhead_ms: list[float] = []
        self.submit_ms: list[float] = []
        self.wait_ms: list[float] = []
        self.gaps_ms: list[float] = []
        self.regenerating_gaps_ms: list[float] = []
        self.last_submit: float | None = None
        self.frames_submitted = 0
        self.frames_rendered = 0
        self.views_differ = True
        self.states: list[str] = []
        self.errors: list[str] = []  # the first MAX_REPORTED_ERRORS of them
        self.error_count = 0
        self.max_gap_frame = 0
        self.head_lod = None
        self.head_lod_changes = 0
        self.eye_lod_disagreements = 0


def summary(values: list[float]) -> dict:
    """Median and 99th percentile (None when nothing was measured)."""
    if not values:
        return {"median": None, "p99": None, "count": 0}
    array = np.asarray(values)
    return {
        "median": round(float(np.median(array)), 3),
        "p99": round(float(np.percentile(array, 99)), 3),
        "count": len(values),
    }
