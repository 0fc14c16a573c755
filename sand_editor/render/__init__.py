"""The Qt-free renderer: the desert, its sky and the sand material, into any moderngl framebuffer.

``SandMaterial`` (material.py) holds a preset's textures and shading uniforms; ``SandRenderer``
(renderer.py) draws sky, dunes and an optional sphere for a ``Camera`` (camera.py) under a
``SkyState`` (sky.py), so the editor's preview and each VR eye are just cameras.
"""
