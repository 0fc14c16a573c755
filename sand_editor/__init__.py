"""Sand Editor: glinty granular sand materials, from grain textures to VR."""

from sand_editor.preset import Color, Preset, PresetError

__all__ = ["Color", "Preset", "PresetError", "SandTextures", "generate"]
__version__ = "0.1.0"


def __getattr__(name: str):
    # The generator pulls in moderngl lazily so that the preset model imports cheaply.
    if name in ("generate", "SandTextures"):
        from sand_editor import generator

        return getattr(generator, name)
    raise AttributeError(f"module 'sand_editor' has no attribute {name!r}")
