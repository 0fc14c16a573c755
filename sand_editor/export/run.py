"""``sand-editor export``: generate the tile, make the maps, write the glTF asset."""

from __future__ import annotations

from pathlib import Path

from sand_editor.export.gltf import FORMATS, PatchOptions, export_files
from sand_editor.export.maps import material_maps
from sand_editor.export.steps import Steps, generation_steps
from sand_editor.export.variation import CopyLayout, check_tiles, grain_keys, varied_maps
from sand_editor.files import check_regular_target, write_atomic, write_folder
from sand_editor.generator.sizes import DEFAULT_EXPORT_SIZE
from sand_editor.preset import Preset


def format_for(out: Path, fmt: str | None) -> str:
    """The format asked for, or the one the file name's suffix names.

    A format the name contradicts is refused: a file is read back (``Preset.load``, and most
    viewers) as GLB when it ends in ``.glb`` and as JSON otherwise, so a GLB must end in
    ``.glb`` and a .gltf must not."""
    suffix = out.suffix.lower()
    if fmt is None:
        fmt = suffix.lstrip(".")
        if fmt not in FORMATS:
            raise ValueError(
                f"{out}: cannot tell the format from the suffix; name a .glb or .gltf file, or "
                f"give --format ({', '.join(FORMATS)})"
            )
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}; allowed {', '.join(FORMATS)}")
    if (fmt == "glb") != (suffix == ".glb"):
        wanted = "a .glb file" if fmt == "glb" else "a .gltf file (any name but .glb)"
        raise ValueError(
            f"--format {fmt} does not fit --out {out}: a file ending in .glb is read back as "
            f"GLB, any other as JSON; allowed with --format {fmt}: {wanted}, or no --format"
        )
    return fmt


class ExportSteps(Steps):
    """The export in short steps (see :class:`~sand_editor.export.steps.Steps`): nothing is
    written unless it runs to the end. A GLB is one atomic file; a .gltf and its .bin and images
    are written as one unit into its folder, the .gltf last."""

    def __init__(
        self,
        preset: Preset,
        out: Path,
        fmt: str | None = None,
        size: int = DEFAULT_EXPORT_SIZE,
        options: PatchOptions | None = None,
        ctx=None,
    ) -> None:
        out = Path(out)
        fmt = format_for(out, fmt)
        check_regular_target(out)
        options = options or PatchOptions()
        check_tiles(options.tiles, size)
        super().__init__(self._run(preset, out, fmt, size, options, ctx))

    def _run(self, preset, out, fmt, size, options, ctx):
        textures = yield from generation_steps(preset, size, ctx, share=0.5)
        yield 0.5, "Making the material maps"
        maps = material_maps(preset, textures)
        if options.tiles > 1:
            yield 0.6, f"Laying out {options.tiles}×{options.tiles} varied tiles"
            layout = CopyLayout(grain_keys(textures), options.tiles, preset.generation.seed)
            maps = varied_maps(maps, layout)
        del textures  # the maps keep what they need of it: a 4096² tile's grains are 0.6 GB
        yield 0.7, "Encoding the images"
        files = export_files(preset, maps, out, fmt, options)
        yield 0.95, f"Writing {len(files)} file{'s' if len(files) > 1 else ''}"
        if fmt == "glb":
            write_atomic(out, files[out.name], make_folder=True)
        else:
            write_folder(out.parent, files)
        self.record = {
            "format": fmt,
            "files": list(files),
            "bytes": sum(len(data) for data in files.values()),
            "albedo_scale": [float(c) for c in maps.albedo_scale],
        }
        yield 1.0, "Done"
