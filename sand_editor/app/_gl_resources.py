"""The GL objects the 3D view owns in the context Qt gives it, released in that context."""

from __future__ import annotations

import moderngl
import shiboken6
from PySide6.QtGui import QOffscreenSurface, QOpenGLContext, QSurfaceFormat

from sand_editor.gl import REQUIRED_GL_VERSION, release_program, release_standalone_context
from sand_editor.render.material import SandMaterial
from sand_editor.render.renderer import SandRenderer


def surface_format() -> QSurfaceFormat:
    fmt = QSurfaceFormat()
    fmt.setVersion(REQUIRED_GL_VERSION // 100, (REQUIRED_GL_VERSION // 10) % 10)
    fmt.setProfile(QSurfaceFormat.OpenGLContextProfile.CoreProfile)
    fmt.setDepthBufferSize(24)
    return fmt


class GLResources:
    """The view's GL objects, kept apart from the widget: they are released while Qt destroys
    the widget's context, when the widget itself can no longer be reached from Python."""

    def __init__(self) -> None:
        self.ctx: moderngl.Context | None = None
        self.material: SandMaterial | None = None
        self.renderer: SandRenderer | None = None
        self.surface: QOffscreenSurface | None = None
        # The reduced-resolution frame, the full one being refined, and the pass that draws
        # them onto the widget.
        self.targets: dict[str, moderngl.Framebuffer] = {}
        self.upscale: moderngl.Program | None = None
        # The GL error state when the objects went away; None until then.
        self.release_error: str | None = None

    def release(self, context: QOpenGLContext | None = None) -> None:
        """Release everything, with ``context`` made current if given."""
        if self.ctx is None:
            return
        if context is not None and not shiboken6.isValid(self.surface):
            # Nothing left to make current: the objects go with the context itself.
            self.ctx = self.material = self.renderer = self.surface = None
            self.targets, self.upscale = {}, None
            return
        if context is not None:
            release_standalone_context()
            context.makeCurrent(self.surface)
        try:
            for owner in (self.renderer, self.material):
                if owner is not None:
                    owner.release()
            for name in list(self.targets):
                self.release_target(name)
            if self.upscale is not None:
                release_program(self.upscale)
            self.release_error = self.ctx.error
            self.ctx.release()
        finally:
            self.ctx = self.material = self.renderer = self.upscale = None
            if context is not None:
                context.doneCurrent()
            if self.surface is not None and shiboken6.isValid(self.surface):
                self.surface.destroy()
            self.surface = None

    def target(self, name: str, width: int, height: int) -> moderngl.Framebuffer:
        """An offscreen colour target of the view, kept until its size changes."""
        current = self.targets.get(name)
        if current is None or current.size != (width, height):
            self.release_target(name)
            texture = self.ctx.texture((width, height), 4)
            texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self.targets[name] = self.ctx.framebuffer([texture])
        return self.targets[name]

    def release_target(self, name: str) -> None:
        framebuffer = self.targets.pop(name, None)
        if framebuffer is not None:
            for texture in framebuffer.color_attachments:
                texture.release()
            framebuffer.release()
