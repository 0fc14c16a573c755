"""The frame loop's answers to controller input: time and mode changes reach the editor,
panel buttons work through a ray and the trigger, sands cycle with new grains."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from sand_editor.vr.actions import SCRUB_HOURS_PER_S
from sand_editor.vr.loop import TIME_MESSAGE_INTERVAL_S

REPO = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(not os.environ.get("DISPLAY"), reason="needs an X display")


@pytest.fixture(scope="module")
def scripted():
    result = subprocess.run(
        [sys.executable, str(Path(__file__).with_name("_scripted_viewer.py")), "100"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=300,
        env=dict(os.environ, PYTHONPATH=str(REPO)),
    )
    assert result.returncode == 0, result.stderr[-4000:]
    return json.loads(result.stdout.splitlines()[-1])


def test_the_stick_moves_the_clock_and_the_editor_hears_of_it_a_few_times_a_second(scripted):
    times = [m for m in scripted["sent"] if m["type"] == "time"]
    # One after "ready", then the scrubbing, throttled.
    assert times[0]["hours"] == pytest.approx(12.0)
    assert len(times) >= 2
    final = scripted["report"]["final"]["hours"]
    assert times[-1]["hours"] == pytest.approx(final, abs=1e-3)
    assert 12.0 < final < 12.0 + 20 * 0.25 * SCRUB_HOURS_PER_S
    # At most ~5 messages a second however fast the frames come.
    spacing = [b["at_s"] - a["at_s"] for a, b in zip(times, times[1:], strict=False)]
    assert min(spacing) >= TIME_MESSAGE_INTERVAL_S


def test_pointing_at_the_lambert_button_and_pulling_the_trigger_switches_mode(scripted):
    modes = [m["mode"] for m in scripted["sent"] if m["type"] == "mode"]
    assert modes == ["lambert"]
    assert scripted["report"]["final"]["mode"] == "lambert"


def test_next_sand_shows_the_next_shipped_preset(scripted):
    assert scripted["report"]["final"]["preset"] != "paper-default"
    assert scripted["shown_preset"] != "paper-default"
    assert scripted["report"]["errors"] == []


def test_teleports_by_stick_and_by_trigger_and_one_snap_turn(scripted):
    moves = scripted["report"]["locomotion"]
    assert moves["teleports"] == 2
    assert moves["snap_turns"] == 1
    assert moves["yaw_deg"] == pytest.approx(-30.0)
    x, _, z = moves["head_in_world"]
    # Two throws of ~20 m, the second turned 30° to the right of the first.
    assert 25.0 < math.hypot(x, z) < 60.0
    assert x > 3.0 and z < -20.0


def test_the_workbench_stays_until_brought_and_then_stands_before_the_user(scripted):
    moves = scripted["report"]["locomotion"]
    assert moves["bench_moves"] == 1
    bx, _, bz = scripted["report"]["bench_at"]
    x, _, z = moves["head_in_world"]
    assert math.hypot(bx - x, bz - z) == pytest.approx(0.55, abs=0.05)


def test_walking_far_rebuilds_the_terrain_once_per_level_of_detail_change(scripted):
    report = scripted["report"]
    assert report["terrain_meshes_built"] <= report["head_level_of_detail_changes"]
    assert report["terrain_meshes_built"] >= 2  # the teleports moved the rings


def test_the_vignette_button_on_the_brought_and_turned_bench_switches_the_vignette_off(scripted):
    assert scripted["report"]["locomotion"]["comfort_vignette"] is False
