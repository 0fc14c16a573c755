"""Tests of the Node-side harness (tests/export/js_tools.py): the glTF validator runner, and the
three.js render's camera conventions, read-back orientation and light units, on a lit plane."""

from __future__ import annotations

import io
import struct

import numpy as np
import pygltflib
import pytest
from PIL import Image

from tests.export.js_tools import render_threejs, validate_gltf

BASE_COLOR = np.array([0.5, 0.25, 0.125])
SUN_IRRADIANCE = np.array([3.0, 2.5, 2.0])
SUN_ELEVATION_DEG = 60.0
SUN_AZIMUTH_DEG = 35.0
SIZE = 96


def plane_gltf(specular_factor: float | None = 0.0) -> tuple[pygltflib.GLTF2, bytes]:
    """A 2 m × 2 m plane in XZ facing +y, with normals and TEXCOORD_0, and one constant
    metallic-roughness material (roughness 1, metallic 0). With ``specular_factor`` 0 the
    material has KHR_materials_specular's specularFactor 0, so it is purely Lambertian."""
    positions = np.array([[-1, 0, 1], [1, 0, 1], [1, 0, -1], [-1, 0, -1]], dtype=np.float32)
    normals = np.tile(np.array([0, 1, 0], dtype=np.float32), (4, 1))
    uvs = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], dtype=np.float32)
    indices = np.array([0, 1, 2, 0, 2, 3], dtype=np.uint16)
    chunks = [positions.tobytes(), normals.tobytes(), uvs.tobytes(), indices.tobytes()]
    offsets = np.cumsum([0, *map(len, chunks)])
    blob = b"".join(chunks) + b"\0" * (-offsets[-1] % 4)

    targets = [pygltflib.ARRAY_BUFFER] * 3 + [pygltflib.ELEMENT_ARRAY_BUFFER]
    views = [
        pygltflib.BufferView(buffer=0, byteOffset=int(offset), byteLength=len(chunk), target=target)
        for offset, chunk, target in zip(offsets[:-1], chunks, targets, strict=True)
    ]
    float_type, vec3, vec2 = pygltflib.FLOAT, pygltflib.VEC3, pygltflib.VEC2
    accessors = [
        pygltflib.Accessor(bufferView=0, componentType=float_type, count=4, type=vec3,
                           min=positions.min(0).tolist(), max=positions.max(0).tolist()),
        pygltflib.Accessor(bufferView=1, componentType=float_type, count=4, type=vec3),
        pygltflib.Accessor(bufferView=2, componentType=float_type, count=4, type=vec2),
        pygltflib.Accessor(bufferView=3, componentType=pygltflib.UNSIGNED_SHORT, count=6,
                           type=pygltflib.SCALAR),
    ]  # fmt: skip
    material = pygltflib.Material(
        name="sand",
        pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
            baseColorFactor=[*BASE_COLOR.tolist(), 1.0], metallicFactor=0.0, roughnessFactor=1.0
        ),
    )
    used = []
    if specular_factor is not None:
        material.extensions = {"KHR_materials_specular": {"specularFactor": specular_factor}}
        used = ["KHR_materials_specular"]
    primitive = pygltflib.Primitive(
        attributes=pygltflib.Attributes(POSITION=0, NORMAL=1, TEXCOORD_0=2), indices=3, material=0
    )
    gltf = pygltflib.GLTF2(
        asset=pygltflib.Asset(version="2.0", generator="sand-editor tests"),
        scene=0,
        scenes=[pygltflib.Scene(nodes=[0])],
        nodes=[pygltflib.Node(mesh=0, name="plane")],
        meshes=[pygltflib.Mesh(primitives=[primitive])],
        materials=[material],
        accessors=accessors,
        bufferViews=views,
        buffers=[pygltflib.Buffer(byteLength=len(blob))],
        extensionsUsed=used,
    )
    return gltf, blob


def write_glb(path, specular_factor: float | None = 0.0):
    gltf, blob = plane_gltf(specular_factor)
    gltf.set_binary_blob(blob)
    gltf.save_binary(str(path))
    return path


def write_gltf_with_bin(path):
    gltf, blob = plane_gltf()
    gltf.buffers[0].uri = path.with_suffix(".bin").name
    path.with_suffix(".bin").write_bytes(blob)
    gltf.save_json(str(path))
    return path


def look_at(eye, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    eye, target, up = (np.asarray(v, dtype=np.float64) for v in (eye, target, up))
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, forward)
    view = np.eye(4)
    view[0, :3], view[1, :3], view[2, :3] = right, true_up, -forward
    view[:3, 3] = -view[:3, :3] @ eye
    return view


def perspective(fov_y_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    f = 1.0 / np.tan(np.radians(fov_y_deg) / 2)
    return np.array([
        [f / aspect, 0, 0, 0],
        [0, f, 0, 0],
        [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)],
        [0, 0, -1, 0],
    ])  # fmt: skip


def plane_hits(view, projection, width, height) -> np.ndarray:
    """(height, width, 2): the x, z where each pixel centre's ray meets y = 0, rows top-down."""
    cols = (np.arange(width) + 0.5) / width * 2 - 1
    rows = 1 - (np.arange(height) + 0.5) / height * 2
    x, y = np.meshgrid(cols, rows)
    inverse = np.linalg.inv(projection @ view)
    ndc = np.stack([x, y, np.full_like(x, -1.0), np.ones_like(x)], axis=-1)
    far_ndc = ndc.copy()
    far_ndc[..., 2] = 1.0
    near_pts, far_pts = ndc @ inverse.T, far_ndc @ inverse.T
    near_pts = near_pts[..., :3] / near_pts[..., 3:]
    far_pts = far_pts[..., :3] / far_pts[..., 3:]
    t = near_pts[..., 1] / (near_pts[..., 1] - far_pts[..., 1])
    hit = near_pts + t[..., None] * (far_pts - near_pts)
    return hit[..., [0, 2]]


SCENE_VIEW = look_at(eye=(0.3, 2.5, 2.5), target=(0.3, 0.0, 0.0))
SCENE_PROJECTION = perspective(45.0, 1.0, 0.1, 50.0)
_elev, _azim = np.radians(SUN_ELEVATION_DEG), np.radians(SUN_AZIMUTH_DEG)
SUN_DIRECTION = np.array(
    [np.cos(_elev) * np.sin(_azim), np.sin(_elev), np.cos(_elev) * np.cos(_azim)]
)


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    linear = np.clip(linear, 0.0, 1.0)
    return np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * linear ** (1 / 2.4) - 0.055)


@pytest.fixture(scope="module")
def lambert_render(root, tmp_path_factory):
    """The Lambertian plane (specularFactor 0) seen 45° from above, lit by the sun."""
    path = write_glb(tmp_path_factory.mktemp("plane") / "plane.glb")
    return render_threejs(
        path, SCENE_VIEW, SCENE_PROJECTION, SUN_DIRECTION, SUN_IRRADIANCE, SIZE, SIZE
    )


@pytest.mark.slow
def test_render_shows_the_plane_where_the_camera_matrices_put_it(lambert_render):
    pixels = lambert_render["pixels"]
    assert pixels.shape == (SIZE, SIZE, 4) and pixels.dtype == np.float32
    assert np.isfinite(pixels).all()
    hits = plane_hits(SCENE_VIEW, SCENE_PROJECTION, SIZE, SIZE)
    expected = np.abs(hits).max(axis=-1) <= 1.0
    covered = pixels[..., 3] > 0.5
    assert expected.sum() > SIZE * SIZE / 4, "the test's camera misses most of the plane"
    # The camera is 0.3 m to the right of the plane's centre and looks down at 45°: the plane is
    # left of the centre and narrows towards the top. Only pixels on the edges may differ.
    assert np.count_nonzero(covered != expected) <= 2 * SIZE
    assert not covered[:, -5:].any() and covered[:, : SIZE // 4].any()
    rows = covered.sum(axis=1)
    top, bottom = np.flatnonzero(rows)[[0, -1]]
    assert rows[top] < rows[bottom]
    assert np.all(pixels[~covered][:, :3] == 0.0), "no environment or ambient light"


@pytest.mark.slow
def test_render_radiance_is_base_color_over_pi_times_sun_irradiance(lambert_render):
    """Pins the light units: a light of intensity I and colour c gives irradiance I·c, and the
    diffuse lobe is baseColor/π. The material has no specular lobe (specularFactor 0); with the
    default F0 of 0.04 three.js's Fresnel-weighted diffuse plus GGX specular would differ from
    the Lambertian value by several percent in the darker channels."""
    hits = plane_hits(SCENE_VIEW, SCENE_PROJECTION, SIZE, SIZE)
    central = np.abs(hits).max(axis=-1) <= 0.8
    assert central.sum() > 500
    mean = lambert_render["pixels"][central][:, :3].astype(np.float64).mean(axis=0)
    expected = BASE_COLOR / np.pi * SUN_IRRADIANCE * np.sin(np.radians(SUN_ELEVATION_DEG))
    np.testing.assert_allclose(mean, expected, rtol=0.02)
    assert lambert_render["pixels"][central][:, :3].std(axis=0).max() < 0.01 * expected.max()
    assert lambert_render["info"]["revision"] == "187"


@pytest.mark.slow
def test_render_png_is_the_same_frame_in_srgb(lambert_render):
    image = Image.open(io.BytesIO(lambert_render["png"]))
    assert image.format == "PNG" and image.size == (SIZE, SIZE)
    picture = np.asarray(image.convert("RGB"), dtype=np.float64) / 255
    pixels = lambert_render["pixels"]
    inside = pixels[..., 3] > 0.5
    difference = np.abs(picture[inside] - srgb_encode(pixels[inside][:, :3]))
    assert difference.max() <= 2.5 / 255
    assert picture[~inside].max() == 0.0


@pytest.mark.slow
def test_render_raises_the_page_error_for_a_broken_file(root, tmp_path):
    broken = tmp_path / "broken.glb"
    broken.write_bytes(write_glb(tmp_path / "plane.glb").read_bytes()[:100])
    with pytest.raises(RuntimeError, match="three.js render of broken.glb failed"):
        render_threejs(broken, SCENE_VIEW, SCENE_PROJECTION, SUN_DIRECTION, SUN_IRRADIANCE, 8, 8)


def test_validator_accepts_the_plane(root, tmp_path):
    report = validate_gltf(write_glb(tmp_path / "plane.glb"))
    assert report["issues"]["numErrors"] == 0, report["issues"]["messages"]
    assert report["issues"]["numWarnings"] == 0, report["issues"]["messages"]
    assert report["info"]["version"] == "2.0"


def test_validator_reads_external_buffers_of_a_gltf(root, tmp_path):
    path = write_gltf_with_bin(tmp_path / "plane.gltf")
    report = validate_gltf(path)
    assert report["issues"]["numErrors"] == 0, report["issues"]["messages"]
    assert [r["uri"] for r in report["info"]["resources"]] == ["plane.bin"]

    path.with_suffix(".bin").unlink()
    codes = {m["code"] for m in validate_gltf(path)["issues"]["messages"]}
    assert "IO_ERROR" in codes


def test_validator_reports_errors_in_a_truncated_glb(root, tmp_path):
    data = write_glb(tmp_path / "plane.glb").read_bytes()
    truncated = tmp_path / "truncated.glb"
    truncated.write_bytes(data[: len(data) - 40])
    report = validate_gltf(truncated)
    assert report["issues"]["numErrors"] > 0


def test_validator_reports_a_wrong_glb_length(root, tmp_path):
    data = bytearray(write_glb(tmp_path / "plane.glb").read_bytes())
    struct.pack_into("<I", data, 8, len(data) + 4)
    wrong = tmp_path / "wrong.glb"
    wrong.write_bytes(bytes(data))
    report = validate_gltf(wrong)
    assert report["issues"]["numErrors"] > 0
