"""``sand-editor bench editor --quick`` runs the real window through its scenarios and reports
them (the numbers are the benchmark's business, not the test's)."""

from __future__ import annotations

import json

import pytest

from sand_editor.bench.editor import SCENARIOS
from tests.app.conftest import run_python


@pytest.mark.slow
def test_bench_editor_reports_every_scenario(tmp_path):
    out = tmp_path / "editor.json"
    result = run_python(
        "-m", "sand_editor", "bench", "editor", "--quick", "--json", str(out), timeout=300
    )
    assert result.returncode == 0, result.stderr[-3000:]
    results = json.loads(out.read_text())
    assert [row["scenario"] for row in results["latency"]] == list(SCENARIOS)
    for row in results["latency"]:
        assert row["samples"] > 20
        assert 0.0 <= row["p50_ms"] <= row["p95_ms"] <= row["max_ms"]
        # The 3D view kept drawing while the event loop answered (drawing on its own thread).
        if row["scenario"].startswith("3D"):
            assert row["frames_per_s"] > 1.0, row
        else:
            assert row["frames_per_s"] is None
    edit = results["edit_to_screen"]
    assert edit["low_res_ms"] > 0.0 and edit["full_ms"] > 0.0
    assert edit["3d_ms"] > 0.0 and edit["size_2d"] == 1024
    assert "| 3D clock |" in result.stdout and "llvmpipe" in result.stdout


def test_bench_editor_refuses_options_it_does_not_take():
    result = run_python("-m", "sand_editor", "bench", "editor", "--plot", "x.png")
    assert result.returncode == 1
    assert "--plot" in result.stderr


@pytest.mark.slow
def test_bench_vr_link_times_both_kinds_of_edit(tmp_path):
    out = tmp_path / "vr-link.json"
    result = run_python(
        "-m", "sand_editor", "bench", "vr-link", "--quick", "--json", str(out), timeout=400
    )
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads(out.read_text())["summary"]
    assert [(row["edit"], row["tiles_shared"]) for row in summary] == [
        *(("shading", True), ("generation", True)),
        *(("shading", False), ("generation", False)),
    ]
    for row in summary:
        assert row["edits"] == 3
        times = row["edit_to_screen_ms"]
        assert 0.0 < times["median"] <= times["p90"] <= times["max"]
    # New grains come from the editor's tile when it is shared, from the viewer when not.
    grains = [row["grains"] for row in summary]
    assert grains == ["kept", "editor", "kept", "viewer"]
    assert "| 48×36 | generation | editor | 3 |" in result.stdout
