"""The workbench: where rays meet the panel, which button they press, the sand objects."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sand_editor.view import ViewState
from sand_editor.vr.bench_meshes import (
    DESK_HEIGHT_M,
    box_mesh,
    box_props,
    controller_props,
    yaw_rotation,
)
from sand_editor.vr.workbench import BUTTONS, PANEL_PIXELS, Workbench, button_at
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


def test_the_desk_stands_on_the_ground_at_hand_height_with_its_legs_in_the_dune(bench):
    assert bench.table_top == pytest.approx(0.25 + DESK_HEIGHT_M)
    props = bench.layout.props()
    assert props.shape[1] == 9 and len(props) % 3 == 0
    assert props[:, 1].min() < 0.25  # the legs reach into the dune
    assert props[:, 1].max() == pytest.approx(bench.table_top + 0.05, abs=1e-6)  # tray rim


def test_the_sand_lies_in_the_tray_below_its_rim_and_the_sphere_on_the_desk(bench):
    (sand, sand_origin), (sphere, sphere_origin) = bench.sand_objects()
    top = sand["position"][:, 1].max() + sand_origin[1]
    assert bench.table_top < top < bench.table_top + 0.05
    lowest = sphere["position"][:, 1].min() + sphere_origin[1]
    assert lowest == pytest.approx(bench.table_top, abs=2e-3)
    assert bench.contains(sand_origin) and bench.contains(sphere_origin)
    assert not bench.contains((0.0, 0.0, 0.0))  # where the user stands


def test_the_bench_turned_to_face_the_user_keeps_its_shape():
    ahead = Workbench(lambda x, z: 0.0)
    turned = Workbench(lambda x, z: 0.0, stand_xz=(5.0, -3.0), yaw=math.radians(90))
    # Facing −x now: the desk's middle lies 0.55 m along −x from the standing point.
    np.testing.assert_allclose(turned.layout.origin[[0, 2]], (5.0 - 0.55, -3.0), atol=1e-9)
    np.testing.assert_allclose(
        np.sort(np.linalg.norm(turned.panel.corners() - turned.panel.center, axis=1)),
        np.sort(np.linalg.norm(ahead.panel.corners() - ahead.panel.center, axis=1)),
    )
    # The panel faces the user: its front looks back at the standing point.
    to_user = np.array([5.0, turned.panel.center[1], -3.0]) - turned.panel.center
    assert np.dot(turned.panel.normal, to_user) > 0


def test_a_ray_at_each_button_hits_that_button(bench):
    panel = bench.panel
    for name, button in BUTTONS.items():
        u0, v0, u1, v1 = button.box
        u, v = (u0 + u1) / 2, (v0 + v1) / 2
        point = (
            panel.center
            + (u - 0.5) * panel.size[0] * panel.right
            + (v - 0.5) * panel.size[1] * panel.up
        )
        hit = bench.aim("right", _aim_at(point))
        assert hit is not None and hit[0] == pytest.approx(u) and hit[1] == pytest.approx(v)
        assert bench.hovered["right"] == name
        assert bench.press("right") == button.command


def test_rays_that_miss_or_come_from_behind_press_nothing(bench):
    assert bench.aim("left", _aim_at(bench.panel.center + (0, 2.0, 0))) is None
    behind = bench.panel.center - 0.5 * bench.panel.normal
    assert bench.aim("left", _aim_at(bench.panel.center, origin=behind)) is None
    assert bench.press("left") is None
    assert bench.aim("left", None) is None


def test_buttons_lie_on_the_panel_without_overlapping():
    boxes = sorted(b.box for b in BUTTONS.values())
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
        # Counter-clockwise seen from outside: the face culling keeps it.
        assert np.dot(face_normal, mesh["normal"][triangle[0]]) > 0


def test_each_face_is_mapped_in_metres_along_it_even_when_turned():
    size = (0.4, 0.2, 0.6)
    for yaw in (0.0, 0.7, -2.5):
        mesh = box_mesh((3.0, 1.0, -2.0), size, rotation=yaw_rotation(yaw))
        uv = mesh["uv"].reshape(6, 4, 2)
        spans = sorted(tuple(np.round(np.ptp(face, axis=0), 6)) for face in uv)
        assert spans == sorted(
            [(0.4, 0.6), (0.4, 0.6), (0.6, 0.2), (0.6, 0.2), (0.4, 0.2), (0.4, 0.2)]
        )
        # A texel's step in uv is the same distance on the face: no stretching, no stripes.
        p, u = mesh["position"].reshape(6, 4, 3).astype(float), uv.astype(float)
        for face_p, face_uv in zip(p, u, strict=True):
            d_p = np.linalg.norm(face_p[1] - face_p[0])
            d_uv = np.linalg.norm(face_uv[1] - face_uv[0])
            assert d_p == pytest.approx(d_uv, rel=1e-5)


def test_controller_bodies_follow_the_aim_pose():
    pose = Pose.from_yaw_pitch((1.0, 1.2, -0.5), math.radians(40), math.radians(-20))
    rows = controller_props(pose)
    assert len(rows) == 2 * 36 and np.all(np.isfinite(rows))
    centre = rows[:, :3].mean(axis=0)
    # The grip lies behind the aim point, against the ray.
    assert np.dot(centre - np.asarray(pose.position), pose.forward) < 0
    assert np.linalg.norm(centre - np.asarray(pose.position)) < 0.15
    assert box_props((0, 0, 0), (1, 1, 1), (0.5, 0.5, 0.5)).shape == (36, 9)
