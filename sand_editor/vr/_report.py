"""What the frame loop measures for ``--report``: per-frame times and counts."""

from __future__ import annotations

from collections import Counter

import numpy as np


class FrameStats:
    """Lists of per-frame milliseconds and the counts the report is made of."""

    def __init__(self) -> None:
        self.eye_ms: list[float] = []
        self.overhead_ms: list[float] = []
        self.submit_ms: list[float] = []
        self.wait_ms: list[float] = []
        self.gaps_ms: list[float] = []
        self.display_periods: list[float] = []  # display periods from one frame to the next
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
        # Where the grains of each material shown came from: "editor", "viewer" or "kept".
        self.grain_sources: Counter[str] = Counter()


def count_levels_of_detail(stats: FrameStats, renderer, head, cameras) -> None:
    """How often the head's terrain level of detail changed, and how often the eyes would
    have disagreed on it had each chosen its own (the cost the shared scene avoids)."""
    # One look-up of the ground serves all three: the eyes are centimetres from the head, and
    # the dunes' height changes by far less than a level's factor of two over that.
    ground = float(renderer.terrain.height(head.eye[0], head.eye[2]))
    key = renderer.terrain_level_of_detail(head.eye, ground)
    if key != stats.head_lod:
        stats.head_lod_changes += 1
        stats.head_lod = key
    eye_keys = {renderer.terrain_level_of_detail(c.eye, ground) for c in cameras}
    stats.eye_lod_disagreements += len(eye_keys) > 1


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


def loop_report(loop) -> dict:
    """The report of a frame loop (``--report``): what ran, how fast, what it held."""
    backend = loop.backend
    stats = loop.stats
    suggested = getattr(backend, "suggested_profiles", {})
    rejected = [
        f"bindings for {profile} rejected: {outcome}"
        for profile, outcome in suggested.items()
        if outcome != "accepted"
    ]
    if "after_warm_up" in loop.resources and "end" not in loop.resources:
        loop.resources["end"] = loop._resources()
    return {
        "backend": backend.name,
        "runtime": backend.runtime,
        "system": backend.system,
        "views": backend.views,
        "swapchain_format": backend.swapchain_format,
        "depth_submitted": bool(getattr(backend, "depth_submitted", False)),
        "depth_format": getattr(backend, "depth_format", None),
        "reference_space": backend.reference_space,
        "interaction_profiles": backend.interaction_profiles(),
        "suggested_bindings": suggested,
        "frames_submitted": stats.frames_submitted,
        "frames_rendered": stats.frames_rendered,
        "eye_ms": summary(stats.eye_ms),
        "frame_overhead_ms": summary(stats.overhead_ms),
        "wait_ms": summary(stats.wait_ms),
        "submit_ms": summary(stats.submit_ms),
        "frame_gap_ms": summary(stats.gaps_ms),
        "display_refresh_hz": getattr(backend, "display_refresh_hz", None),
        "display_periods_per_frame": summary(stats.display_periods),
        "max_frame_gap_ms": round(max(stats.gaps_ms, default=0.0), 2),
        "max_frame_gap_at_frame": stats.max_gap_frame,
        "max_frame_gap_while_regenerating_ms": round(
            max(stats.regenerating_gaps_ms, default=0.0), 2
        ),
        "view_matrices_differ": stats.views_differ and stats.frames_rendered > 0,
        "terrain_meshes_built": loop.renderer.terrain_meshes_built - loop._builds_before_loop,
        "head_level_of_detail_changes": stats.head_lod_changes,
        "frames_where_eyes_disagree_on_level_of_detail": stats.eye_lod_disagreements,
        "final": {
            "hours": round(loop.view.state.hours, 4),
            "day_speed": loop.view.state.day_speed,
            "playing": loop.view.state.playing,
            "mode": loop.view.state.mode,
            "preset": loop.presets[loop._index()][0],
        },
        "locomotion": {**loop.stage.report(), "comfort_vignette": loop.controls.comfort},
        "resources": loop.resources,
        "states": stats.states,
        "errors": [*stats.errors, *rejected],
        "link_errors_answered": stats.error_count,
        "grain_requests_superseded": loop.worker.superseded,
        "materials_shown_by_grain_source": dict(stats.grain_sources),
    }
