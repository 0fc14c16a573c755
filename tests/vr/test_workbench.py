"""The workbench: where rays meet the panel, which button they press, the sand objects."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sand_editor.view import ViewState
from sand_editor.vr.workbench import BUTTONS, PANEL_PIXELS, Workbench, box_mesh, button_at
from sand_editor.vr.xrmath import Pose


@pytest.fixture
def bench():
    return Workbench(lambda x, z: 0.25)


def _aim_at(point, origin=(0.1, 1.3, 0.2)) -> Pose:
    origin = np.asarray(origin, float)
    d = np.asarray(point, float) - origin
    yaw = math.atan2(-d[0], -d[2])
    pitch = math.atan2(d[1], math.hypot(d[0], d[2]))
    return Pose.from_yaw_pitch(origin, yaw, pitch)


def test_the_block_stands_on_the_ground_at_hand_height(bench):
    assert bench.table_top == pytest.approx(0.25 + 0.85)
    bottom = bench.table_center[1] - bench.table_size[1] / 2
    assert bottom < 0.25  # reaches into the dune


def test_a_ray_at_each_button_hits_that_button(bench):
    panel = bench.panel
    for name, (u0, v0, u1, v1, *_rest) in BUTTONS.items():
        u, v = (u0 + u1) / 2, (v0 + v1) / 2
        point = (
            panel.center
            + (u - 0.5) * panel.size[0] * panel.right
            + (v - 0.5) * panel.size[1] * panel.up
        )
        hit = bench.aim("right", _aim_at(point))
        assert hit is not None and hit[0] == pytest.approx(u) and hit[1] == pytest.approx(v)
        assert bench.hovered["right"] == name
        assert bench.press("right") == BUTTONS[name][5]


def test_rays_that_miss_or_come_from_behind_press_nothing(bench):
    assert bench.aim("left", _aim_at(bench.panel.center + (0, 2.0, 0))) is None
    behind = bench.panel.center - 0.5 * bench.panel.normal
    assert bench.aim("left", _aim_at(bench.panel.center, origin=behind)) is None
    assert bench.press("left") is None
    assert bench.aim("left", None) is None


def test_buttons_lie_on_the_panel_without_overlapping():
    boxes = sorted(b[:4] for b in BUTTONS.values())
    for u0, v0, u1, v1 in boxes:
        assert 0 <= u0 < u1 <= 1 and 0 <= v0 < v1 <= 1
    for left, right in zip(boxes, boxes[1:], strict=False):
        assert left[2] < right[0]


def test_button_at_between_buttons_is_none():
    assert button_at(0.5, 0.9) is None


def test_panel_shows_time_and_hovered_button(bench):
    state = ViewState(hours=16.5, day_speed=0.5, playing=True, mode="lambert")
    plain = np.asarray(bench.panel_image(state, "red-desert"))
    assert plain.shape == (PANEL_PIXELS[1], PANEL_PIXELS[0], 3)
    bench.hovered["right"] = "sand"
    hovered = np.asarray(bench.panel_image(state, "red-desert"))
    assert np.any(plain != hovered)
    other_time = np.asarray(bench.panel_image(ViewState(hours=4.0), "red-desert"))
    assert np.any(other_time[:100] != np.asarray(bench.panel_image(ViewState(), "x"))[:100])


@pytest.mark.parametrize(
    "hours,clock", [(0.0, "00:00"), (16.999, "16:59"), (23.9999, "23:59"), (24.0, "00:00")]
)
def test_the_clock_reads_the_current_minute(bench, hours, clock):
    assert bench.panel_text(ViewState(hours=hours), "x")[0] == clock


def test_the_panel_is_drawn_again_only_when_what_it_shows_changes(bench):
    same_minute = [ViewState(hours=10.0 + i * 0.001) for i in range(5)]
    assert len({bench.panel_text(c, "x") for c in same_minute}) == 1
    assert bench.panel_text(ViewState(hours=10.02), "x") != bench.panel_text(
        ViewState(hours=10.0), "x"
    )


def test_box_faces_point_outwards_with_tangents_in_the_face():
    mesh = box_mesh((1.0, 2.0, 3.0), (0.4, 0.2, 0.6))
    assert len(mesh["index"]) == 36
    positions = mesh["position"].astype(float)
    centre = positions.mean(axis=0)
    np.testing.assert_allclose(centre, (1.0, 2.0, 3.0), atol=1e-6)
    outward = np.einsum("ij,ij->i", positions - centre, mesh["normal"])
    assert np.all(outward > 0)
    assert np.allclose(np.einsum("ij,ij->i", mesh["tangent"], mesh["normal"]), 0)
    for triangle in mesh["index"].reshape(-1, 3):
        a, b, c = positions[triangle]
        face_normal = np.cross(b - a, c - a)
        assert np.dot(face_normal, mesh["normal"][triangle[0]]) != 0
