"""The web export: a folder the renderer's own programs and material draw from, served on
localhost, drawn by headless Chromium as the renderer draws it, and entered in VR through Meta's
WebXR emulator."""

from __future__ import annotations

import io
import json
import math
import os
import threading
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image

from sand_editor import gl
from sand_editor.bench import web as web_bench
from sand_editor.bench.browser import CHROMIUM, JS_TOOLS, run_page, screenshot
from sand_editor.bench.sweep import random_preset
from sand_editor.cli import main
from sand_editor.export.serve import make_server
from sand_editor.export.web import SCENE_FILE, VIEWER_DIR, VIEWER_FILES, export_web
from sand_editor.preset import Preset
from sand_editor.render.material import SandMaterial
from sand_editor.render.sky import sky_at
from sand_editor.render.terrain import DuneTerrain
from sand_editor.resources import bundled_preset
from sand_editor.vr.locomotion import SNAP_TURN_DEG

pytestmark = pytest.mark.gl
SMALL = 128  # texels per tile edge of the material in the quick tests


@pytest.fixture(scope="module")
def site(tmp_path_factory, gl_ctx):
    folder = tmp_path_factory.mktemp("web") / "site"
    export_web(Preset.load(bundled_preset("red-desert")), folder, SMALL, ctx=gl_ctx)
    return folder


def _scene(folder: Path) -> dict:
    return json.loads((folder / SCENE_FILE).read_text())


def test_the_page_carries_the_renderers_programs_not_copies(site):
    scene = _scene(site)
    surface = scene["programs"]["surface"]
    from sand_editor.render.material import surface_defines

    defines = {**surface_defines(), "FRAGMENT_SHADER": 1}
    assert surface["fragment"] == gl.shader_text("terrain.glsl", defines, dialect="es")
    far = scene["programs"]["surface_far"]["fragment"]
    assert "#define SAND_FAR_ONLY" in far and "#define SAND_FAR_ONLY" not in surface["fragment"]
    assert set(scene["programs"]) == {
        "surface", "surface_far", "sky", "bloom_down", "bloom_up", "resolve",
    }  # fmt: skip
    for program in scene["programs"].values():
        assert program["vertex"].startswith("#version 300 es\n")
        assert program["fragment"].startswith("#version 300 es\n")


def test_the_material_is_the_renderers_own_level_by_level(site, gl_ctx):
    scene = _scene(site)
    preset = Preset.load(bundled_preset("red-desert"))
    material = SandMaterial(gl_ctx, SMALL)
    try:
        material.update(preset)
        expected = json.loads(json.dumps(material.uniform_values()))
        assert scene["material"]["uniforms"] == expected
        textures = {entry["uniform"]: entry for entry in scene["material"]["textures"]}
        assert set(textures) == set(material.textures())
        moments = textures["u_glint_moments"]
        assert moments["internal_format"] == "RGBA32F"  # the glint estimate needs 32 bits
        data = (site / moments["file"]).read_bytes()
        assert len(data) == sum(level["bytes"] for level in moments["levels"])
        assert len(moments["levels"]) == int(np.log2(SMALL)) + 1
        top = moments["levels"][-1]
        assert top["size"] == [1, 1]
        texel = np.frombuffer(data[top["offset"] :], dtype=np.float32)
        read = np.frombuffer(material.glint_moments.read(level=len(moments["levels"]) - 1),
                             dtype=np.float32)  # fmt: skip
        np.testing.assert_array_equal(texel, read)
        assert textures["u_layer_grain"]["internal_format"] == "RG32UI"
        assert textures["u_relief_visibility"]["target"] == "TEXTURE_3D"
    finally:
        material.release()
    for entry in scene["material"]["textures"]:
        size = (site / entry["file"]).stat().st_size
        assert size == sum(level["bytes"] for level in entry["levels"]), entry["file"]


def test_the_day_and_the_dunes_are_whole(site):
    scene = _scene(site)
    table = scene["sky"]["table"]
    assert [row["hours"] for row in (table[0], table[-1])] == [0.0, 24.0]
    assert len(table) == 24 * 60 // 10 + 1
    noon = next(row for row in table if row["hours"] == 12.0)
    np.testing.assert_allclose(noon["uniforms"]["u_sun_direction"], sky_at(12.0).sun_direction,
                               rtol=1e-6)  # fmt: skip
    assert all(np.isfinite(row["exposure"]) and row["exposure"] > 0 for row in table)
    terrain = scene["terrain"]
    vertices = (site / terrain["vertices"]).stat().st_size // 4
    assert vertices == terrain["vertex_count"] * terrain["stride_floats"]
    indices = np.fromfile(site / terrain["indices"], dtype=np.uint32)
    assert indices.size == terrain["index_count"] and indices.max() < terrain["vertex_count"]
    positions = np.fromfile(site / terrain["vertices"], dtype=np.float32)
    assert np.isfinite(positions).all()
    for name in VIEWER_FILES:
        assert (site / name).read_bytes() == (VIEWER_DIR / name).read_bytes()
    # Where VR walks: the terrain's own heights, and the VR viewer's stick thresholds.
    walk = scene["locomotion"]
    n, radius = walk["samples"], walk["walk_radius_m"]
    heights = np.fromfile(site / walk["heights"], dtype=np.float32).reshape(n, n)
    axis = np.linspace(-radius, radius, n)
    terrain = DuneTerrain()
    for row, column in ((0, 0), (n // 2, n // 3), (n - 1, n - 1)):
        expected = terrain.height(axis[column], axis[row])
        assert heights[row, column] == pytest.approx(float(expected), abs=1e-5)
    assert walk["snap_turn_deg"] == SNAP_TURN_DEG


@pytest.mark.parametrize(
    "fmt, preset, said",
    [("web", "black-volcanic", ("as a web page", "sand-editor serve")),
     ("godot", "pale-quartz", ("as a Godot 4 project", "project.godot"))],
)  # fmt: skip
def test_folder_exports_on_the_command_line_and_their_refusals(fmt, preset, said, tmp_path,
                                                                capsys):  # fmt: skip
    out = tmp_path / "folder"
    assert main(["export", preset, "--format", fmt, "--out", str(out), "--size", "64"]) == 0
    printed = capsys.readouterr().out
    assert f"exported {preset} {said[0]}" in printed and said[1] in printed
    assert _scene(out)["preset"] == preset
    a_file = tmp_path / "a-file"
    a_file.write_text("kept")
    assert main(["export", preset, "--format", fmt, "--out", str(a_file)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is not a folder" in err and f"--format {fmt}" in err
    assert a_file.read_text() == "kept"
    assert main(["export", preset, "--format", fmt, "--out", str(out), "--size", "10"]) == 1
    assert "allowed 64 to 4096" in capsys.readouterr().err


def _get(url: str) -> tuple[int, str, bytes]:
    try:
        with urllib.request.urlopen(url, timeout=10) as response:
            return response.status, response.headers["Content-Type"], response.read()
    except urllib.error.HTTPError as error:
        return error.code, error.headers["Content-Type"], b""


def test_serve_serves_the_page_and_nothing_else(site, tmp_path):
    server = make_server(site, "127.0.0.1", 0)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        base = f"http://127.0.0.1:{server.server_address[1]}"
        status, kind, body = _get(base + "/")
        assert status == 200 and kind.startswith("text/html") and b"sand-viewer.js" in body
        status, kind, _ = _get(base + "/sand-viewer.js")
        assert status == 200 and kind.startswith("text/javascript")  # a module needs it
        status, kind, body = _get(base + "/scene.json")
        assert status == 200 and json.loads(body)["version"] == 1
        assert _get(base + "/%2e%2e/%2e%2e/etc/passwd")[0] == 404
        assert _get(base + "/no-such.bin")[0] == 404
    finally:
        server.shutdown()
        server.server_close()
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="has no scene.json, so it is not a complete web export"):
        make_server(tmp_path / "empty")
    with pytest.raises(ValueError, match="no such folder"):
        make_server(tmp_path / "missing")


def _require_chromium(root) -> None:
    if not os.path.exists(CHROMIUM):
        (pytest.fail if os.environ.get("CI") else pytest.skip)(f"Chromium ({CHROMIUM}) is missing")


@pytest.mark.slow
@pytest.mark.parametrize("name", ["paper-default", "black-volcanic", "random"])
def test_the_page_draws_what_the_renderer_draws(name, root, gl_ctx, tmp_path):
    _require_chromium(root)
    if name == "random":
        preset = random_preset(np.random.default_rng(28), "random-28")
    else:
        preset = Preset.load(bundled_preset(name))
    result = web_bench.compare(preset, gl_ctx, folder=tmp_path)
    assert result["info"]["console"] == []
    for row in result["rows"]:
        assert row["flip"] <= web_bench.FLIP_TARGET, row
        assert web_bench.sparkles_agree(row), row
    # Glinty sand glints in the page too, and black sand stays black.
    shares = [row["sparkle_web"] for row in result["rows"]]
    if name == "paper-default":
        assert max(shares) >= web_bench.MIN_SPARKLE_SHARE
    ours, web = result["frames"]["ours"], result["frames"]["web"]
    ground = slice(ours.shape[1] // 2, None)
    assert abs(float(web[:, ground].mean()) - float(ours[:, ground].mean())) < 4.0


@pytest.mark.slow
def test_the_page_enters_vr_draws_both_eyes_and_moves_with_the_sticks(root, site):
    _require_chromium(root)
    posts = run_page(
        "/webxr.html",
        {"/webxr.html": JS_TOOLS / "webxr.html"},
        {"/site/": site, "/node_modules/iwer/": root / "node_modules" / "iwer"},
        # The emulator sizes the canvas to the window (at least 500 wide in headless Chromium):
        # a low window keeps 100 frames of SwiftShader's short.
        {"width": 320, "height": 220, "hours": 16.5, "frames": 100, "pitch_deg": 40.0},
        frozenset({"info"}),
        "WebXR session",
        (320, 220),
        timeout_s=300,
    )
    info = json.loads(posts["info"])
    assert info["supported"] and info["mode"] == "immersive-vr"
    assert info["frames"] >= 100
    assert [eye["eye"] for eye in info["eyes"]] == ["left", "right"]
    left, right = (eye["viewport"] for eye in info["eyes"])
    assert left[0] == 0 and right[0] == left[2] and left[2] == right[2] > 0
    assert info["eye_difference"] > 0.1  # two eyes, two views
    for eye in info["eyes"]:
        assert 20 < np.mean(eye["mean"]) < 250  # drawn: neither black nor blown out
    assert info["gl_error"] == 0 and info["console"] == []
    # The sticks: the right one walked where the head looks (north, −z), then turned once by
    # the VR viewer's snap angle; the left one took the day back.
    start, walked, turned, scrubbed = info["states"]
    assert walked["z"] < start["z"] - 1.0 and abs(walked["x"]) < 1e-6
    assert turned["yaw"] == pytest.approx(-math.radians(SNAP_TURN_DEG))
    assert 1.0 < turned["hours"] - scrubbed["hours"] < 16.0
    # Standing on the sand wherever it walked to.
    eye_height = info["eyes"][0]["position"][1] - info["ground_below_eye"]
    assert 1.0 < eye_height < 2.0


@pytest.mark.slow
def test_the_page_a_user_opens_shows_the_sand(root, site):
    _require_chromium(root)
    server = make_server(site, "127.0.0.1", 0)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        url = f"http://127.0.0.1:{server.server_address[1]}/"
        png, console = screenshot(url, (640, 360))
    finally:
        server.shutdown()
        server.server_close()
    assert not [line for line in console if "rror" in line], console
    image = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.float64)
    sky, ground = image[5:30, 400:600], image[200:300, 420:620]  # beside the panel
    assert sky[..., 2].mean() > sky[..., 0].mean()  # a blue sky
    assert ground[..., 0].mean() > ground[..., 2].mean() + 20  # red-desert's sand, lit
    assert ground.std() > 2.0  # grains and ripples, not a flat fill


@pytest.fixture(scope="module")
def served(site):
    """The exported page on a server of its own for the module's requests: (host, port)."""
    server = make_server(site, "127.0.0.1", 0)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield server.server_address
    server.shutdown()
    server.server_close()


@settings(
    max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(path=st.one_of(
    st.text(max_size=40),
    st.lists(st.sampled_from(["..", ".", "%2e%2e", "%2f", "scene.json", "etc", "passwd", "",
                              "index.html", "%00", "\\", "~"]), max_size=6).map("/".join),
))  # fmt: skip
def test_fuzzed_request_paths_get_a_file_of_the_page_or_an_error(site, served, path):
    import http.client
    from urllib.parse import quote

    files = {p.read_bytes() for p in site.iterdir()}
    host, port = served
    connection = http.client.HTTPConnection(host, port, timeout=10)
    try:
        target = "/" + quote(path, safe="/%.~")
        connection.request("GET", target)
        response = connection.getresponse()
        body = response.read()
        assert response.status in (200, 301, 400, 404), (target, response.status)
        if response.status == 200:
            assert body in files, target  # only the page's own files
    finally:
        connection.close()
    assert _get(f"http://{host}:{port}/scene.json")[0] == 200  # and it serves on
