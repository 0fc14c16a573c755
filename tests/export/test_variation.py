"""The glTF export's varied tiles (export/variation.py): the layout repeats with the images and
nowhere else, every texel is the tile's own, the normals turn with their copy, borders follow
the grains, the grid is gone from the images and from a real viewer's frame (three.js), and bad
counts of tiles are refused."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sand_editor.bench.repetition import TILE_SAMPLES, grid_strength
from sand_editor.bench.sweep import SHIPPED
from sand_editor.colour import luminance
from sand_editor.export.maps import MaterialMaps, material_maps
from sand_editor.export.variation import (
    MAX_TILES,
    CopyLayout,
    check_tiles,
    grain_keys,
    varied_maps,
)
from sand_editor.generator import generate
from sand_editor.preset import Preset
from sand_editor.resources import bundled_preset

SIZE = 128


@pytest.fixture(scope="module")
def tiles_of(gl_ctx):
    made = {}

    def make(name: str):
        if name not in made:
            preset = Preset.load(bundled_preset(name))
            textures = generate(preset, SIZE, ctx=gl_ctx)
            made[name] = (textures, material_maps(preset, textures))
        return made[name]

    return make


def _tile_grid(image: np.ndarray) -> float:
    """grid_strength of an image of whole tiles, resampled to TILE_SAMPLES per tile."""
    step = image.shape[0] // (image.shape[0] // SIZE * TILE_SAMPLES)
    return grid_strength(image[::step, ::step])


@pytest.mark.gl
def test_the_layout_repeats_with_the_images_and_each_copy_keeps_the_tiles_texels(tiles_of):
    textures, _ = tiles_of("paper-default")
    layout = CopyLayout(grain_keys(textures), 3, seed=7)
    width = SIZE * 3
    rng = np.random.default_rng(1)
    x = rng.integers(-2 * width, 2 * width, 4000)
    y = rng.integers(-2 * width, 2 * width, 4000)
    here = layout.at(x, y)
    for dx, dy in ((width, 0), (0, width), (-width, 2 * width)):
        for a, b in zip(here, layout.at(x + dx, y + dy), strict=True):
            assert np.array_equal(a, b)
    # Not periodic at one tile: the copies differ a tile apart.
    apart = layout.at(x + SIZE, y)
    assert np.mean((here[0] != apart[0]) | (here[1] != apart[1])) > 0.5
    # Several copies, all eight symmetries among them, every source texel in the tile.
    sx, sy, swap, mx, my = layout.rows(slice(0, width))
    assert 0 <= sx.min() and sx.max() < SIZE and 0 <= sy.min() and sy.max() < SIZE
    symmetries = {tuple(s) for s in np.stack([swap, mx, my], -1).reshape(-1, 3)}
    assert len(symmetries) == 8


@pytest.mark.gl
def test_normals_turn_with_their_copy():
    # A ramp: the height rises along +x (column) and the normal leans to −x, as a slope's does.
    n = 64
    height = np.tile(np.arange(n, dtype=np.float32), (n, 1))
    normal = np.zeros((n, n, 3), np.float32)
    normal[..., 0], normal[..., 2] = -0.6, 0.8
    maps = MaterialMaps(
        base_color=np.zeros((n, n, 3), np.float32), normal=normal,
        roughness=np.full((n, n), 0.5, np.float32), specular=np.zeros((n, n), np.float32),
        occlusion=np.ones((n, n), np.float32), height=height, albedo_scale=np.ones(3),
    )  # fmt: skip
    keys = np.arange(n * n, dtype=np.uint64).reshape(n, n)
    layout = CopyLayout(keys, 4, seed=3)
    varied = varied_maps(maps, layout)
    assert varied.tiles == 4 and varied.size == 4 * n
    h, nx, ny = varied.height, varied.normal[..., 0], varied.normal[..., 1]
    # Where neighbours of one copy step the ramp by one texel, the normal leans against it.
    sx, sy, *symmetry = layout.rows(slice(0, 4 * n))
    same = np.stack(symmetry, -1).astype(np.int8) @ np.array([1, 2, 4], np.int8)

    def one_copy(axis: int) -> np.ndarray:
        # Neighbours of one symmetry whose sources are neighbours too.
        d = [np.abs(np.diff(a, axis=axis)) % (n - 1) for a in (sx, sy)]
        return (np.diff(same, axis=axis) == 0) & (d[0] + d[1] == 1)

    along_x = (np.abs(np.diff(h, axis=1)) == 1) & one_copy(1)
    along_y = (np.abs(np.diff(h, axis=0)) == 1) & one_copy(0)
    assert along_x.sum() > 1000 and along_y.sum() > 1000
    step_x = np.diff(h, axis=1)[along_x]
    step_y = np.diff(h, axis=0)[along_y]
    assert np.all(np.sign(nx[:, :-1][along_x]) == -np.sign(step_x))
    assert np.all(np.sign(ny[:-1, :][along_y]) == -np.sign(step_y))
    assert np.allclose(np.linalg.norm(varied.normal, axis=-1), 1.0, atol=1e-6)


@pytest.mark.gl
@pytest.mark.parametrize("name", SHIPPED)
def test_varied_images_show_no_grid_where_the_repeated_tile_does(tiles_of, name):
    textures, maps = tiles_of(name)
    varied = varied_maps(maps, CopyLayout(grain_keys(textures), 4, seed=11))
    repeated = np.tile(maps.base_color, (4, 4, 1))
    assert _tile_grid(luminance(repeated)) > 0.5
    assert _tile_grid(luminance(varied.base_color)) <= 0.1
    # The same sand: the mean colour and the share of grain texels kept.
    assert np.allclose(varied.base_color.mean((0, 1)), maps.base_color.mean((0, 1)), rtol=0.03)
    # Borders along grain outlines: where a texel's right neighbour is another copy's, seldom
    # do both copies' grains go on across the border (both cut along it), as they would about
    # as often as a texel's grain goes on to its right neighbour, squared, were copies cut
    # along lines.
    keys = grain_keys(textures)
    sx, sy, swap, mx, my = CopyLayout(keys, 4, seed=11).rows(slice(0, 4 * SIZE))
    # Along the image's x, a copy steps along its turned axes.
    step = np.where(swap, 0, np.where(mx, -1, 1)), np.where(swap, np.where(my, -1, 1), 0)
    right = (sx + step[0]) % SIZE, (sy + step[1]) % SIZE  # what the copy shows one to the right
    left = (sx - step[0]) % SIZE, (sy - step[1]) % SIZE
    other_copy = (right[0][:, :-1] != sx[:, 1:]) | (right[1][:, :-1] != sy[:, 1:])
    own = keys[sy, sx]
    goes_on = (own == keys[right[1], right[0]])[:, :-1]
    came_from = (own == keys[left[1], left[0]])[:, 1:]
    cut = other_copy & goes_on & came_from
    in_tile = np.mean(keys == np.roll(keys, -1, axis=1))
    assert other_copy.sum() > 1000
    assert cut.sum() / other_copy.sum() < 0.25 * in_tile**2, (cut.sum() / other_copy.sum(), in_tile)


@pytest.mark.gl
def test_the_gltf_of_varied_tiles_repeats_its_images_as_many_times_less(root, gl_ctx, tmp_path):
    from sand_editor.export.gltf import PatchOptions
    from sand_editor.export.images import decode
    from sand_editor.export.run import ExportSteps
    from tests.export.js_tools import validate_gltf

    preset = Preset.load(bundled_preset("red-desert"))
    out = tmp_path / "varied.gltf"
    for _ in ExportSteps(preset, out, size=64, options=PatchOptions(size_m=2.0, tiles=2)):
        pass
    document = json.loads(out.read_text())
    plane = document["materials"][0]
    scale = plane["pbrMetallicRoughness"]["baseColorTexture"]["extensions"]
    assert scale["KHR_texture_transform"]["scale"] == pytest.approx(
        [2.0 * preset.shading.uv_scale / 2] * 2
    )
    ours = plane["extras"]["sand_editor"]
    assert ours["texture_size"] == 64 and ours["tiles"] == 2
    assert ours["glints"]["tiles_per_image"] == 2
    for image in document["images"]:
        assert decode((tmp_path / image["uri"]).read_bytes()).shape[:2] == (128, 128)
    report = validate_gltf(out)
    assert report["issues"]["numErrors"] == 0 and report["issues"]["numWarnings"] == 0, report
    assert Preset.load(out).to_dict() == preset.to_dict()


def test_tiles_are_refused_outside_their_range_with_the_reason():
    assert check_tiles(4, 1024) == 4
    for bad, size in ((0, 512), (MAX_TILES + 1, 256), (5, 2048), (2.0, 512), (True, 512)):
        with pytest.raises(ValueError, match="tiles"):
            check_tiles(bad, size)
