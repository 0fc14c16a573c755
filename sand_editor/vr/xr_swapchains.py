"""The headset's eye images: one OpenXR swapchain per view of the stereo configuration, a GL
framebuffer on each of its images, and the projection views that hand the drawn images to the
compositor."""

from __future__ import annotations

from contextlib import ExitStack, contextmanager

import xr

from sand_editor.vr.errors import GraphicsError

GL_SRGB8_ALPHA8 = 0x8C43
GL_RGBA8 = 0x8058
# The resolve pass writes sRGB-encoded values: an sRGB swapchain stores them as written.
FORMAT_NAMES = {GL_SRGB8_ALPHA8: "GL_SRGB8_ALPHA8", GL_RGBA8: "GL_RGBA8"}
STEREO = xr.ViewConfigurationType.PRIMARY_STEREO


class EyeSwapchains:
    """The swapchains of a session's views at ``render_scale`` × the recommended size, each
    swapchain and framebuffer released by ``teardown`` (in reverse order of creation)."""

    def __init__(
        self, instance, system_id, session, ctx, render_scale: float, teardown: ExitStack
    ) -> None:
        formats = list(xr.enumerate_swapchain_formats(session))
        chosen = next((f for f in (GL_SRGB8_ALPHA8, GL_RGBA8) if f in formats), None)
        if chosen is None:
            raise GraphicsError(
                f"the runtime offers no 8-bit colour swapchain: {[hex(f) for f in formats]}"
            )
        self.format = FORMAT_NAMES[chosen]
        self.views = []
        self._eyes = []
        configuration = xr.enumerate_view_configuration_views(instance, system_id, STEREO)
        for view in configuration:
            width = max(16, round(view.recommended_image_rect_width * render_scale))
            height = max(16, round(view.recommended_image_rect_height * render_scale))
            width = min(width, view.max_image_rect_width)
            height = min(height, view.max_image_rect_height)
            swapchain = xr.create_swapchain(
                session,
                xr.SwapchainCreateInfo(
                    usage_flags=xr.SwapchainUsageFlags.COLOR_ATTACHMENT_BIT
                    | xr.SwapchainUsageFlags.SAMPLED_BIT,
                    format=chosen,
                    sample_count=1,
                    width=width,
                    height=height,
                    face_count=1,
                    array_size=1,
                    mip_count=1,
                ),
            )
            teardown.callback(xr.destroy_swapchain, swapchain)
            images = xr.enumerate_swapchain_images(swapchain, xr.SwapchainImageOpenGLKHR)
            framebuffers = []
            for image in images:
                # The runtime owns the texture: releasing our wrapper does not delete it.
                texture = ctx.external_texture(image.image, (width, height), 4, 0, "f1")
                framebuffers.append(ctx.framebuffer(color_attachments=[texture]))
                teardown.callback(framebuffers[-1].release)
            self._eyes.append((swapchain, (width, height), framebuffers))
            self.views.append({"width": width, "height": height, "fov": None})

    def __len__(self) -> int:
        return len(self._eyes)

    @contextmanager
    def image(self, index: int):
        """(framebuffer, viewport) of the eye's next swapchain image, released when done."""
        swapchain, size, framebuffers = self._eyes[index]
        image = xr.acquire_swapchain_image(swapchain, xr.SwapchainImageAcquireInfo())
        xr.wait_swapchain_image(swapchain, xr.SwapchainImageWaitInfo(timeout=xr.INFINITE_DURATION))
        try:
            yield framebuffers[image], (0, 0, *size)
        finally:
            xr.release_swapchain_image(swapchain, xr.SwapchainImageReleaseInfo())

    def projection_view(self, index: int, view) -> xr.CompositionLayerProjectionView:
        """The eye's released image as seen from ``view`` (its located pose and field of view)."""
        swapchain, size, _ = self._eyes[index]
        return xr.CompositionLayerProjectionView(
            pose=view.pose,
            fov=view.fov,
            sub_image=xr.SwapchainSubImage(
                swapchain=swapchain, image_rect=xr.Rect2Di(extent=xr.Extent2Di(*size))
            ),
        )
