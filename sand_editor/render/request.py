"""What one frame is asked to show: ``SandRenderer.render(target, FrameRequest(...))``."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from sand_editor.render.camera import Camera
from sand_editor.render.modes import check_mode
from sand_editor.render.scene import FrameScene
from sand_editor.render.sky import SkyState

DEBUG_MODES = frozenset({"blend", "normals", "mip"})


@dataclass(frozen=True)
class FrameRequest:
    """One frame: seen by ``camera`` under ``sky``, shaded as ``mode`` (``render.modes``).

    ``viewport`` (x, y, width, height) of the target, its whole area when None. ``exposure``
    fixes the exposure; None meters it (``ExposureControl``). ``scene`` is what
    ``SandRenderer.prepare_frame`` chose for this frame (one for both eyes); None chooses it
    from ``camera``, with the sphere where ``show_sphere`` says (None: the renderer's
    setting). ``extra(camera, sky, shadows)`` draws more (not sand) into the scene,
    depth-tested, before it is exposed, lit as the sand is (``shadows``: the frame's
    ``SceneShadows``); with ``depth_out`` the scene's depth goes into the target's depth buffer
    too. ``moving``: a frame of a view in motion (the editor's reduced frames while it orbits,
    edits or plays the clock), whose shadow maps, where the view alone moved, are drawn
    again one a frame, the oldest first (``SunShadows.update``); a still
    frame draws every map it needs. ``footprint_scale``: the share of a pixel's width the sand
    is filtered over, 1 but in the frames of a still drawn with more samples
    (``SandRenderer.render_still``). A mode not in ``render.modes`` raises ``ValueError``.
    """

    camera: Camera
    sky: SkyState
    mode: str = "full"
    viewport: tuple[int, int, int, int] | None = None
    exposure: float | None = None
    show_sphere: bool | None = None
    scene: FrameScene | None = None
    extra: Callable | None = None
    depth_out: bool = False
    moving: bool = False
    footprint_scale: float = 1.0

    def __post_init__(self) -> None:
        check_mode(self.mode)
        if not 0.0 < self.footprint_scale <= 1.0:
            raise ValueError(f"footprint_scale must lie in (0, 1], got {self.footprint_scale}")
        if self.viewport is not None:
            object.__setattr__(self, "viewport", tuple(int(v) for v in self.viewport))

    @property
    def debug(self) -> bool:
        """Debug modes write the material's values unexposed and unblended, over black."""
        return self.mode in DEBUG_MODES
