"""``sand-editor export``: glTF 2.0 assets that the Khronos validator passes with no error and no
warning, for every shipped preset, as GLB and as .gltf with files; the preset comes back from
the file; the material says what the preset says; nothing is written when the export stops."""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sand_editor.cli import main
from sand_editor.export.gltf import PatchOptions, plane_mesh, sphere_mesh
from sand_editor.export.images import decode
from sand_editor.export.run import ExportSteps
from sand_editor.preset import Preset, PresetError
from sand_editor.resources import bundled_preset
from tests.export.js_tools import validate_gltf

SHIPPED = ["paper-default", "red-desert", "pale-quartz", "black-volcanic"]
SIZE = 128


def glb_json(path) -> dict:
    data = path.read_bytes()
    length, kind = struct.unpack_from("<II", data, 12)
    assert kind == 0x4E4F534A
    return json.loads(data[20 : 20 + length])


def export(preset: Preset, out, **options) -> dict:
    steps = ExportSteps(preset, out, size=SIZE, options=PatchOptions(**options))
    for _ in steps:
        pass
    return steps.record


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """Every shipped preset exported as GLB (with the sphere) and as .gltf with files."""
    folder = tmp_path_factory.mktemp("exported")
    files = {}
    for name in SHIPPED:
        preset = Preset.load(bundled_preset(name))
        export(preset, folder / f"{name}.glb", sphere=True)
        export(preset, folder / name / f"{name}.gltf")
        files[name] = (preset, folder / f"{name}.glb", folder / name / f"{name}.gltf")
    return files


@pytest.mark.gl
@pytest.mark.parametrize("name", SHIPPED)
@pytest.mark.parametrize("kind", ["glb", "gltf"])
def test_the_khronos_validator_finds_no_error_and_no_warning(root, exported, name, kind):
    _, glb, gltf = exported[name]
    report = validate_gltf(glb if kind == "glb" else gltf)
    issues = report["issues"]
    assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"]
    info = report["info"]
    assert info["version"] == "2.0"
    assert set(info["extensionsUsed"]) == {
        "KHR_materials_ior",
        "KHR_materials_specular",
        "KHR_texture_transform",
    }
    assert info["totalTriangleCount"] > (2 if kind == "glb" else 1)


@pytest.mark.gl
@pytest.mark.parametrize("name", SHIPPED)
def test_the_preset_comes_back_from_either_file(exported, name):
    preset, glb, gltf = exported[name]
    assert Preset.load(glb) == preset
    assert Preset.load(gltf) == preset


@pytest.mark.gl
def test_the_material_carries_the_presets_index_tiling_and_maps(exported):
    preset, glb, gltf = exported["red-desert"]
    document = glb_json(glb)
    plane, sphere = document["materials"]
    assert plane["extensions"]["KHR_materials_ior"]["ior"] == pytest.approx(
        preset.shading.grain_ior
    )
    pbr = plane["pbrMetallicRoughness"]
    assert pbr["metallicFactor"] == 0.0
    # The patch is 2 m across and the preset repeats its tile uv_scale times a metre.
    scale = pbr["baseColorTexture"]["extensions"]["KHR_texture_transform"]["scale"]
    assert scale == pytest.approx([2.0 * preset.shading.uv_scale] * 2)
    assert sphere["normalTexture"]["extensions"]["KHR_texture_transform"]["scale"][0] > scale[0]
    # Occlusion and metallic-roughness share one ORM image.
    assert plane["occlusionTexture"]["index"] == pbr["metallicRoughnessTexture"]["index"]
    # The .gltf's images lie beside it and decode at the tile's size.
    names = [image["uri"] for image in json.loads(gltf.read_text())["images"]]
    assert len(names) == 4
    for name in names:
        pixels = decode((gltf.parent / name).read_bytes())
        assert pixels.shape[:2] == (SIZE, SIZE)
    albedo_scale = plane["extras"]["sand_editor"]["albedo_scale"]
    assert all(0.2 < c < 1.0 for c in albedo_scale)


def test_meshes_face_out_with_unit_normals_and_tangents():
    for mesh in (plane_mesh(2.0), sphere_mesh(0.4, (0.0, 0.4, 0.0), segments=16)):
        p, n, t = mesh["POSITION"], mesh["NORMAL"], mesh["TANGENT"]
        assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)
        assert np.allclose(np.linalg.norm(t[:, :3], axis=1), 1.0, atol=1e-5)
        assert np.allclose(np.sum(n * t[:, :3], axis=1), 0.0, atol=1e-5)
        tri = mesh["indices"].reshape(-1, 3)
        a, b, c = p[tri[:, 0]], p[tri[:, 1]], p[tri[:, 2]]
        face = np.cross(b - a, c - a)
        area = np.linalg.norm(face, axis=1)
        assert np.all(area > 0.0), "no degenerate triangle"
        outward = np.sum(face * n[tri].mean(axis=1), axis=1)
        assert np.all(outward > 0.0), "counter-clockwise seen from outside"
        # The bitangent cross(n, t)·w points up the image: along −v.
        uv = mesh["TEXCOORD_0"]
        bitangent = np.cross(n, t[:, :3]) * t[:, 3:]
        duv_along_bitangent = []
        for i0, i1, i2 in tri[area > 1e-6][:50]:
            edges = np.array([p[i1] - p[i0], p[i2] - p[i0]])
            duv = np.array([uv[i1] - uv[i0], uv[i2] - uv[i0]])
            # Solve edges = duv · [dp/du; dp/dv] for the surface's dp/dv.
            dp = np.linalg.lstsq(duv, edges, rcond=None)[0]
            duv_along_bitangent.append(np.dot(dp[1], bitangent[i0]))
        assert np.all(np.array(duv_along_bitangent) < 0.0)


@pytest.mark.gl
def test_a_stopped_export_writes_nothing(gl_ctx, tmp_path):
    out = tmp_path / "stopped.glb"
    steps = ExportSteps(Preset(), out, size=SIZE)
    for fraction, _ in steps:
        if fraction >= 0.5:
            break
    steps.close()
    assert list(tmp_path.iterdir()) == []


def test_a_glb_without_our_preset_names_the_file(tmp_path):
    path = tmp_path / "other.glb"
    document = json.dumps({"asset": {"version": "2.0"}}).encode()
    document += b" " * (-len(document) % 4)
    path.write_bytes(
        struct.pack("<III", 0x46546C67, 2, 20 + len(document))
        + struct.pack("<II", len(document), 0x4E4F534A)
        + document
    )
    with pytest.raises(PresetError, match=r"other\.glb: has no sand preset"):
        Preset.load(path)


def test_saving_a_preset_over_a_gltf_file_is_refused(tmp_path):
    path = tmp_path / "sand.glb"
    path.write_bytes(b"keep")
    with pytest.raises(PresetError, match="presets are saved as .json"):
        Preset().save(path)
    assert path.read_bytes() == b"keep"


@pytest.mark.gl
def test_the_success_line_shows_the_out_path_escaped_on_one_line(gl_ctx, tmp_path, capsys):
    out = tmp_path / "a\nb\x1b[2Jc.glb"
    assert main(["export", "pale-quartz", "--out", str(out), "--size", "64"]) == 0
    said = capsys.readouterr().out
    assert said.count("\n") == 1 and "\x1b" not in said
    assert said.rstrip("\n").endswith("a\\nb\\x1b[2Jc.glb")
    assert out.is_file()


@pytest.mark.gl
def test_the_export_command_writes_a_glb_and_says_so(gl_ctx, tmp_path, capsys):
    out = tmp_path / "patch.glb"
    status = main(["export", "pale-quartz", "--out", str(out), "--size", "64", "--patch", "5"])
    assert status == 0
    said = capsys.readouterr()
    assert said.out.startswith("exported pale-quartz as glb (1 file,")
    assert said.err == "", "no progress bar when stderr is not a terminal"
    document = glb_json(out)
    assert document["accessors"][0]["max"] == pytest.approx([2.5, 0.0, 2.5])


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--out", "x.obj"], "cannot tell the format from the suffix"),
        (["--out", "x.glb", "--format", "gltf"], "--format gltf does not fit --out"),
        (["--out", "x.gltf", "--format", "glb"], "--format glb does not fit --out"),
        (["--out", "x.bin", "--format", "glb"], "allowed with --format glb: a .glb file"),
        (["--out", "x.glb", "--patch", "0"], "--patch 0.0: allowed 0.01 to 1000"),
        (["--out", "x.glb", "--patch", "nan"], "--patch nan: allowed"),
        (["--out", "x.glb", "--size", "10"], "10"),
        (["--out", "x.glb", "--tiles", "0"], "tiles 0 is out of range for texture size 1024"),
        (["--out", "x.glb", "--size", "2048", "--tiles", "5"], "allowed 1 to 4"),
        (["--out", "x", "--format", "web", "--tiles", "2"], "--tiles applies to glb and gltf"),
    ],
)
def test_bad_export_arguments_give_one_line(tmp_path, capsys, argv, message):
    argv = [a if not a.startswith("x.") else str(tmp_path / a) for a in argv]
    assert main(["export", "paper-default", *argv]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("sand-editor export: error: ")
    assert message in err
    assert list(tmp_path.iterdir()) == []


@settings(max_examples=200, deadline=None, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])  # fmt: skip
@given(
    suffix=st.sampled_from([".glb", ".gltf", ".GLB"]),
    head=st.sampled_from([b"", b"glTF\x02\x00\x00\x00", b"glTF\x02\x00\x00\x00\xff\xff\xff\x7f"]),
    body=st.binary(max_size=200),
)
def test_any_bytes_named_gltf_give_one_preset_error(tmp_path, suffix, head, body):
    path = tmp_path / f"fuzz{suffix}"
    path.write_bytes(head + body)
    try:
        Preset.load(path)
    except PresetError as error:
        text = str(error)
        assert "\n" not in text and text.startswith(str(path))


@pytest.mark.gl
@settings(max_examples=60, deadline=None, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])  # fmt: skip
@given(data=st.data())
def test_a_real_glb_with_bytes_changed_gives_the_preset_or_one_error(exported, tmp_path, data):
    _, glb, _ = exported["paper-default"]
    raw = bytearray(glb.read_bytes()[:4096])
    for _ in range(data.draw(st.integers(1, 4))):
        raw[data.draw(st.integers(0, 200))] = data.draw(st.integers(0, 255))
    path = tmp_path / "changed.glb"
    path.write_bytes(bytes(raw))
    try:
        Preset.load(path)
    except PresetError as error:
        assert "\n" not in str(error)
