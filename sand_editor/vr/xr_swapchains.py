"""The headset's eye images: one OpenXR swapchain per view of the stereo configuration, a GL
framebuffer on each of its images, and the projection views that hand the drawn images to the
compositor.

Each eye has a depth buffer too: where the runtime offers ``XR_KHR_composition_layer_depth`` it
is a depth swapchain's image, handed to the compositor with each projection view (an
``XrCompositionLayerDepthInfoKHR`` with the near and far planes drawn with), which reprojects
late frames far better with it; elsewhere a renderbuffer of our own.
"""

from __future__ import annotations

import ctypes
from contextlib import ExitStack, contextmanager

import xr

from sand_editor.gl import attach_depth_texture
from sand_editor.vr.errors import GraphicsError

GL_SRGB8_ALPHA8 = 0x8C43
GL_RGBA8 = 0x8058
# The resolve pass writes sRGB-encoded values: an sRGB swapchain stores them as written.
FORMAT_NAMES = {GL_SRGB8_ALPHA8: "GL_SRGB8_ALPHA8", GL_RGBA8: "GL_RGBA8"}
STEREO = xr.ViewConfigurationType.PRIMARY_STEREO
# Depth formats by preference: float depth keeps the most precision far away.
DEPTH_FORMATS = {
    0x8CAC: ("GL_DEPTH_COMPONENT32F", False),
    0x88F0: ("GL_DEPTH24_STENCIL8", True),
    0x81A6: ("GL_DEPTH_COMPONENT24", False),
    0x8CAD: ("GL_DEPTH32F_STENCIL8", True),
    0x81A5: ("GL_DEPTH_COMPONENT16", False),
}


class EyeSwapchains:
    """The swapchains of a session's views at ``render_scale`` × the recommended size, each
    swapchain and framebuffer released by ``teardown`` (in reverse order of creation)."""

    def __init__(
        self, instance, system_id, session, ctx, render_scale: float, teardown: ExitStack,
        depth: bool = False, near_far: tuple[float, float] = (0.01, 1000.0),
    ) -> None:  # fmt: skip
        formats = list(xr.enumerate_swapchain_formats(session))
        depth_format = next((f for f in DEPTH_FORMATS if f in formats), None) if depth else None
        self.depth_format = DEPTH_FORMATS[depth_format][0] if depth_format else None
        self.near_far = near_far
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
            colour_usage = (
                xr.SwapchainUsageFlags.COLOR_ATTACHMENT_BIT | xr.SwapchainUsageFlags.SAMPLED_BIT
            )
            swapchain = _swapchain(session, colour_usage, chosen, width, height)
            teardown.callback(xr.destroy_swapchain, swapchain)
            images = xr.enumerate_swapchain_images(swapchain, xr.SwapchainImageOpenGLKHR)
            own_depth = None
            if depth_format is None:
                own_depth = ctx.depth_renderbuffer((width, height))
                teardown.callback(own_depth.release)
            framebuffers = []
            for image in images:
                # The runtime owns the texture: releasing our wrapper does not delete it.
                texture = ctx.external_texture(image.image, (width, height), 4, 0, "f1")
                framebuffers.append(ctx.framebuffer([texture], own_depth))
                teardown.callback(framebuffers[-1].release)
            depth_chain = None
            if depth_format is not None:
                depth_chain = self._depth_swapchain(session, depth_format, width, height)
                teardown.callback(xr.destroy_swapchain, depth_chain[0])
            self._eyes.append((swapchain, (width, height), framebuffers, depth_chain))
            self.views.append({"width": width, "height": height, "fov": None})

    @staticmethod
    def _depth_swapchain(session, depth_format: int, width: int, height: int):
        """(swapchain, GL texture names, has stencil) of one eye's depth."""
        usage = xr.SwapchainUsageFlags.DEPTH_STENCIL_ATTACHMENT_BIT
        swapchain = _swapchain(session, usage, depth_format, width, height)
        images = xr.enumerate_swapchain_images(swapchain, xr.SwapchainImageOpenGLKHR)
        return swapchain, [image.image for image in images], DEPTH_FORMATS[depth_format][1]

    def __len__(self) -> int:
        return len(self._eyes)

    @property
    def depth_submitted(self) -> bool:
        return self.depth_format is not None

    @contextmanager
    def image(self, index: int):
        """(framebuffer, viewport) of the eye's next swapchain image (and depth image), released
        when done."""
        swapchain, size, framebuffers, depth_chain = self._eyes[index]
        with ExitStack() as images:
            image = _acquire(swapchain, images)
            framebuffer = framebuffers[image]
            if depth_chain is not None:
                depth_swapchain, depth_images, stencil = depth_chain
                depth_image = _acquire(depth_swapchain, images)
                attach_depth_texture(framebuffer, depth_images[depth_image], stencil)
            yield framebuffer, (0, 0, *size)

    def projection_view(self, index: int, view) -> xr.CompositionLayerProjectionView:
        """The eye's released image as seen from ``view`` (its located pose and field of view),
        with its depth chained where depth is submitted (kept alive by the returned view)."""
        swapchain, size, _, depth_chain = self._eyes[index]
        rect = xr.Rect2Di(extent=xr.Extent2Di(*size))
        projection = xr.CompositionLayerProjectionView(
            pose=view.pose,
            fov=view.fov,
            sub_image=xr.SwapchainSubImage(swapchain=swapchain, image_rect=rect),
        )
        if depth_chain is not None:
            near, far = self.near_far
            depth = xr.CompositionLayerDepthInfoKHR(
                sub_image=xr.SwapchainSubImage(swapchain=depth_chain[0], image_rect=rect),
                min_depth=0.0,
                max_depth=1.0,
                near_z=near,
                far_z=far,
            )
            projection.next = ctypes.cast(ctypes.pointer(depth), ctypes.c_void_p)
            projection._depth_info = depth  # the runtime reads it at xrEndFrame
        return projection


def _swapchain(session, usage, image_format: int, width: int, height: int):
    """A swapchain of single-sampled 2D images of one mip level."""
    return xr.create_swapchain(
        session,
        xr.SwapchainCreateInfo(
            usage_flags=usage, format=image_format, sample_count=1, width=width, height=height,
            face_count=1, array_size=1, mip_count=1,
        ),
    )  # fmt: skip


def _acquire(swapchain, stack: ExitStack) -> int:
    """Acquire and wait for the swapchain's next image; released when ``stack`` closes."""
    image = xr.acquire_swapchain_image(swapchain, xr.SwapchainImageAcquireInfo())
    stack.callback(xr.release_swapchain_image, swapchain, xr.SwapchainImageReleaseInfo())
    xr.wait_swapchain_image(swapchain, xr.SwapchainImageWaitInfo(timeout=xr.INFINITE_DURATION))
    return image
