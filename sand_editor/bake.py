"""Bake a preset's grain textures to image files: our own set (the renderer's textures), or
an engine's texture set (``sand_editor.export.sets``)."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
from PIL import Image

from sand_editor.colour import linear_to_srgb
from sand_editor.export.maps import material_maps
from sand_editor.export.sets import TARGETS as SET_TARGETS
from sand_editor.export.sets import MapFormats, texture_set
from sand_editor.export.steps import Steps, generation_steps
from sand_editor.files import write_folder
from sand_editor.generator import SandTextures
from sand_editor.preset import Preset

LOW_RES_SIZE = 64
FILES = {
    "albedo.png": "sRGB 8-bit RGB, the grain colours",
    "albedo_low.png": f"sRGB 8-bit RGB, {LOW_RES_SIZE}² area average of the albedo (far field)",
    "normal.png": "8-bit RGB, tangent-space normal encoded n·0.5 + 0.5 (+z out of the surface)",
    "height.png": "16-bit grey, grain profile height · 65535 (heights lie in [0, 0.9])",
    "glint.png": "8-bit grey, glint value of top-layer grains, 0 elsewhere",
    "layer.png": "8-bit grey, owning layer + 1 (0 in gaps)",
}


def _to_8bit(values: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(values * 255.0), 0, 255).astype(np.uint8)


def _image_rows(array: np.ndarray) -> np.ndarray:
    # Arrays keep row 0 at v = 0 (OpenGL's convention); image files start at the top, v = 1.
    return np.ascontiguousarray(np.flipud(array))


def _area_average(image: np.ndarray, size: int) -> np.ndarray:
    """Mean over equal blocks (exact when size divides the edge, else nearest block bounds)."""
    edge = image.shape[0]
    bounds = np.linspace(0, edge, size + 1).round().astype(int)
    rows = np.add.reduceat(image, bounds[:-1], axis=0) / np.diff(bounds)[:, None, None]
    return np.add.reduceat(rows, bounds[:-1], axis=1) / np.diff(bounds)[None, :, None]


def encode_images(textures: SandTextures) -> dict[str, Image.Image]:
    """The baked images of a texture set, by file name."""
    low = _area_average(textures.albedo.astype(np.float64), min(LOW_RES_SIZE, textures.size))
    height16 = np.clip(np.rint(textures.height * 65535.0), 0, 65535).astype(np.uint16)
    return {
        "albedo.png": Image.fromarray(_image_rows(_to_8bit(linear_to_srgb(textures.albedo)))),
        "albedo_low.png": Image.fromarray(_image_rows(_to_8bit(linear_to_srgb(low)))),
        "normal.png": Image.fromarray(_image_rows(_to_8bit(textures.normal * 0.5 + 0.5))),
        "height.png": Image.fromarray(_image_rows(height16)),
        "glint.png": Image.fromarray(_image_rows(_to_8bit(textures.glint))),
        "layer.png": Image.fromarray(_image_rows((textures.layer + 1).astype(np.uint8))),
    }


def material_record(preset: Preset, textures: SandTextures) -> dict:
    average = textures.average_albedo.astype(np.float64)
    srgb = _to_8bit(linear_to_srgb(average))
    return {
        "format": "sand-editor-material",
        "version": 1,
        "size": textures.size,
        "orientation": "image row 0 is the top of the texture (v = 1)",
        "files": FILES,
        "average_albedo_linear": [round(float(c), 6) for c in average],
        "average_albedo_srgb": "#{:02x}{:02x}{:02x}".format(*srgb),
        "statistics": textures.statistics(preset.generation.layers),
        "preset": preset.to_dict(),
    }


DEFAULT_TARGET = "sand-editor"
TARGETS = (DEFAULT_TARGET, *SET_TARGETS)


def bake(
    preset: Preset,
    size: int,
    out_dir: Path,
    backend: str = "gl",
    target: str = DEFAULT_TARGET,
    formats: MapFormats | None = None,
) -> dict:
    """Generate and write the baked files; returns the bake's record.

    Everything is encoded in memory and written as one unit (``sand_editor.files.write_folder``):
    temporary names first, then renamed into place under a lock on the folder, ``material.json``
    (or the set's README) last, so two bakes into one folder never mix and a failed one leaves
    the old files.
    """
    steps = BakeSteps(preset, size, out_dir, target=target, formats=formats, backend=backend)
    for _ in steps:
        pass
    return steps.record


def _encode_files(preset: Preset, textures: SandTextures):
    files = {}
    for name, image in encode_images(textures).items():
        buffer = io.BytesIO()
        image.save(buffer, format="PNG")
        files[name] = buffer.getvalue()
    record = material_record(preset, textures)
    files["material.json"] = (json.dumps(record, indent=2, ensure_ascii=False) + "\n").encode()
    return files


def _set_record(preset: Preset, textures: SandTextures, target: str, files) -> dict:
    return {
        "target": target,
        "size": textures.size,
        "files": list(files),
        "statistics": textures.statistics(preset.generation.layers),
    }


class BakeSteps(Steps):
    """``bake`` in short steps (see :class:`Steps`). Uses the calling thread's headless
    context (or ``ctx``)."""

    def __init__(
        self,
        preset: Preset,
        size: int,
        out_dir: Path,
        ctx=None,
        target: str = DEFAULT_TARGET,
        formats: MapFormats | None = None,
        backend: str = "gl",
    ) -> None:
        if target not in TARGETS:
            raise ValueError(f"unknown target {target!r}; allowed {', '.join(TARGETS)}")
        if target == DEFAULT_TARGET and formats not in (None, MapFormats()):
            raise ValueError(
                "--normal-format and --height-format apply to the engine targets "
                f"({', '.join(SET_TARGETS)}); the {DEFAULT_TARGET} set keeps its own"
            )
        super().__init__(
            self._run(preset, size, Path(out_dir), ctx, target, formats or MapFormats(), backend)
        )

    def _run(self, preset, size, out_dir, ctx, target, formats, backend):
        textures = yield from generation_steps(preset, size, ctx, backend=backend)
        if target == DEFAULT_TARGET:
            yield 0.6, "Encoding the images"
            files = _encode_files(preset, textures)
            record = json.loads(files["material.json"])
        else:
            yield 0.6, "Making the material maps"
            maps = material_maps(preset, textures)
            yield 0.7, "Encoding the images"
            files = texture_set(preset, maps, target, formats, preset.name)
            record = _set_record(preset, textures, target, files)
        yield 0.95, f"Writing {len(files)} files"
        write_folder(out_dir, files)
        self.record = record
        yield 1.0, "Done"
