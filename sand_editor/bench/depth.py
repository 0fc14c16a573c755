"""``sand-editor bench depth``: our frames against the same renderer supersampled 8×8, per
distance, with each depth feature on and off — speed against error.

Each view (paper-default, 16:30, pitch 15°, the issue's 320×180) is rendered at its size and at
8× its size, the latter averaged down 8×8 in linear light and encoded again: the truth a frame
of that size should show. The truth's samples draw the ripples unfiltered (each as it is at the
sample's centre): a truth drawn with the ripples' filter would hold what it measures. FLIP
(NVIDIA's perceptual metric, PyPI ``flip-evaluator``) compares the two over the ground (the
frame's lower half, below any horizon). One fixed exposure, from the light, serves both, so the
metering of frames of different sizes does not enter. The features: the grains' relief
(``SandRenderer.relief``), the ripples filtered along each pixel's footprint
(``SandRenderer.sharp_ripples``), the grain textures read in taps along a grazing footprint
(``SandRenderer.anisotropic``) and the shadows (``SandRenderer.shadows``); each row gives the
frame with all of them, and without one. Beside them, the FLIP of the same renderer
supersampled 2×2 and 4×4 (SUPERSAMPLED_FLOORS): what four and sixteen times the work per pixel
would buy. And the truth's own 64 samples with their light averaged before the tone curve
rather than after it, as a camera's pixel gathers light (and ``render --samples``, and a
multisampled frame resolved in light): how far the truth itself moves with that choice, which
up close, where sparkles far brighter than white lie within a pixel, is the larger part of
every frame's FLIP. Every timed frame's clock moves on by a minute, as in a time-lapse, so that
each frame draws one of the four shadow maps again (a still view draws none, a first frame all
four). Up close the sparkles are stochastic per pixel by design: their FLIP is reported, not a
target.

The flicker figure: the camera moves sideways by a quarter of a pixel (at the view's distance)
per frame, PAN_FRAMES frames; the mean change of a ground pixel between frames, over the same
change of the supersampled frames (the truth moves by a quarter pixel too, and changes as much
as its content does). Above 1 the frame shimmers more than what it shows.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from sand_editor.bench._optional import optional_module
from sand_editor.render.request import FrameRequest

DISTANCES = (0.05, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0)
QUICK_DISTANCES = (0.05, 10.0)
SIZE = (320, 180)
SUPERSAMPLE = 8
TIME = 16.5
PITCH_DEG = 15.0
FEATURES = ("relief", "sharp_ripples", "anisotropic", "shadows")
FEATURE_LABELS = {"relief": "no relief", "sharp_ripples": "isotropic ripples",
                  "anisotropic": "isotropic textures", "shadows": "no shadows"}  # fmt: skip
# The same renderer with more samples per pixel (k×k, averaged as the truth is): how near to the
# truth a frame gets by spending k² times its work.
SUPERSAMPLED_FLOORS = (2, 4)
CLOCK_STEP_H = 1.0 / 60.0
REPEATS = 7  # timed frames per setting, the median kept
PAN_STEP_PX = 0.25  # the flicker figure's camera step per frame, in pixels at the view's distance
PAN_FRAMES = 5


def supersampled(image: np.ndarray, factor: int) -> np.ndarray:
    """An sRGB uint8 frame averaged down ``factor``×``factor`` in linear light, as sRGB floats
    in [0, 1]."""
    from sand_editor.colour import linear_to_srgb, srgb_to_linear

    h, w = image.shape[0] // factor, image.shape[1] // factor
    encoded = image[: h * factor, : w * factor] / 255.0
    linear = srgb_to_linear(encoded).reshape(h, factor, w, factor, 3)
    return linear_to_srgb(linear.mean(axis=(1, 3)))


def flip_error(reference: np.ndarray, test: np.ndarray) -> float:
    """Mean FLIP of two sRGB frames in [0, 1] over their lower half (the ground)."""
    flip_evaluator = optional_module("flip_evaluator", "bench depth")
    half = reference.shape[0] // 2
    ref = np.ascontiguousarray(reference[half:], dtype=np.float32)
    tst = np.ascontiguousarray(test[half:], dtype=np.float32)
    _, mean, _ = flip_evaluator.evaluate(ref, tst, "LDR", applyMagma=False)
    return float(mean)


class Views:
    """One renderer and material, drawing the bench's views at any size."""

    def __init__(self, texture_size: int) -> None:
        from sand_editor.gl import standalone_context
        from sand_editor.preset import Preset
        from sand_editor.render.exposure import light_exposure
        from sand_editor.render.material import SandMaterial
        from sand_editor.render.renderer import SandRenderer
        from sand_editor.render.sky import sky_at
        from sand_editor.resources import bundled_preset

        self.ctx = standalone_context()
        self.material = SandMaterial(self.ctx, texture_size)
        self.material.update(Preset.load(bundled_preset("paper-default")))
        self.renderer = SandRenderer(self.ctx)
        self.renderer.set_material(self.material)
        self.sky_at = sky_at
        self.exposure = light_exposure(sky_at(TIME))

    def frame(
        self,
        distance: float,
        size: tuple[int, int],
        later_h: float = 0.0,
        pan_px: float = 0.0,
        filter_ripples: bool = True,
        **features,
    ) -> tuple[np.ndarray, float]:
        """The view at ``distance`` drawn at ``size``, ``later_h`` hours after the bench's time,
        its camera moved sideways by ``pan_px`` of its pixels at that distance,
        and the milliseconds it took. ``filter_ripples`` False: the truth's samples (below)."""
        for name in FEATURES:
            setattr(self.renderer, name, features.get(name, True))
        self.renderer.filter_ripples = filter_ripples
        width, height = size
        camera = self.camera(distance, pan_px, size)
        sky = self.sky_at(TIME + later_h)
        start = time.perf_counter()
        request = FrameRequest(camera, sky, "full", exposure=self.exposure)
        image = self.renderer.render_to_array(width, height, request)
        return image, (time.perf_counter() - start) * 1e3

    def truth(self, distance: float, pan_px: float = 0.0, size=SIZE) -> np.ndarray:
        """The view drawn SUPERSAMPLE× larger and averaged down, as sRGB floats: each of its
        samples with the ripples as they are at its centre, so that the truth does not hold
        the ripples' filter that it measures (that filter drawn at 8× still drew strong
        ripples 0.07–0.27 FLIP from the same view at 16× or 32×, which agree within 0.007)."""
        large = (size[0] * SUPERSAMPLE, size[1] * SUPERSAMPLE)
        big = self.frame(distance, large, pan_px=pan_px * SUPERSAMPLE, filter_ripples=False)[0]
        return supersampled(big, SUPERSAMPLE)

    def camera(self, distance: float, pan_px: float = 0.0, size=SIZE):
        """The bench's camera at ``distance``, moved right by ``pan_px`` pixels of a frame of
        ``size``'s width."""
        from sand_editor.render.camera import Camera, camera_at_distance, look_at_matrix

        terrain = self.renderer.terrain
        aspect = size[0] / size[1]
        camera = camera_at_distance(
            distance, PITCH_DEG, aspect, lambda x, z: float(terrain.height(x, z))
        )
        if pan_px == 0.0:
            return camera
        # A pixel spans 2 d tan(fov_x / 2) / width at the distance d the view looks to.
        half_width = distance / float(camera.projection[0, 0])
        step = pan_px * 2.0 * half_width / size[0]
        forward = camera.forward.astype(np.float64)
        right = np.cross(forward, (0.0, 1.0, 0.0))
        right /= np.linalg.norm(right)
        eye = camera.eye + step * right
        view = look_at_matrix(eye, eye + distance * forward)
        return Camera(view, camera.projection, eye)

    def flicker(self, distance: float, size=SIZE) -> dict:
        """Mean change of a ground pixel between frames of a quarter-pixel pan, for frames of
        ``size`` and their truths, and their ratio."""
        ours, truth = [], []
        for k in range(PAN_FRAMES):
            pan = k * PAN_STEP_PX
            ours.append(self.frame(distance, size, pan_px=pan)[0] / 255.0)
            truth.append(self.truth(distance, pan, size))
        half = size[1] // 2
        change = [
            float(np.abs(np.diff(np.stack(f)[:, half:], axis=0)).mean()) for f in (ours, truth)
        ]
        return {"ours": change[0], "truth": change[1], "ratio": change[0] / max(change[1], 1e-9)}

    def gathered(self, distance: float) -> np.ndarray:
        """The truth's 8×8 samples a pixel with their light gathered before the tone curve, as a
        camera's pixel gathers it (``SandRenderer.render_still``, ``render --samples 8``)."""
        for name in FEATURES:
            setattr(self.renderer, name, True)
        self.renderer.filter_ripples = False
        request = FrameRequest(self.camera(distance), self.sky_at(TIME), "full",
                               exposure=self.exposure)  # fmt: skip
        return self.renderer.render_still(*SIZE, request, SUPERSAMPLE)

    def timed(self, distance: float, **features) -> tuple[np.ndarray, float]:
        """The view at the bench's time, and the median milliseconds of frames whose clock moves
        on by CLOCK_STEP_H each."""
        self.frame(distance, SIZE, **features)  # warm: compiled, allocated
        steps = range(1, REPEATS + 1)
        runs = [self.frame(distance, SIZE, k * CLOCK_STEP_H, **features)[1] for k in steps]
        return self.frame(distance, SIZE, **features)[0], float(np.median(runs))

    def release(self) -> None:
        self.renderer.release()
        self.material.release()


def run(quick: bool = False) -> dict:
    from sand_editor.bench.generator import machine_description

    views = Views(512 if quick else 1024)
    machine = machine_description(views.ctx)
    rows = []
    try:
        for distance in QUICK_DISTANCES if quick else DISTANCES:
            truth = views.truth(distance)
            row = {"distance_m": distance}
            for label, features in [("all", {}), *((f"no_{f}", {f: False}) for f in FEATURES)]:
                image, ms = views.timed(distance, **features)
                row[label] = {"flip": flip_error(truth, image / 255.0), "ms": ms}
            row["supersampled"] = {
                str(k): flip_error(
                    truth, supersampled(views.frame(distance, (SIZE[0] * k, SIZE[1] * k))[0], k)
                )
                for k in SUPERSAMPLED_FLOORS
            }
            row["gathered"] = flip_error(truth, views.gathered(distance) / 255.0)
            row["flicker"] = views.flicker(distance)
            rows.append(row)
            print(f"  depth at {distance} m", file=sys.stderr, flush=True)
    finally:
        views.release()
    return {"machine": machine, "size": list(SIZE), "supersample": SUPERSAMPLE, "rows": rows}


def format_table(results: dict) -> str:
    lines = [
        f"Depth: FLIP over the ground against the same renderer 8×8 supersampled (its "
        f"ripples unfiltered), "
        f"{results['size'][0]}×{results['size'][1]}, 16:30, pitch 15; flicker: the mean "
        f"change between frames of a {PAN_STEP_PX}-pixel pan over the supersampled pan's; "
        f"{results['machine']['gl_renderer']}, {results['machine']['cpu_count']} CPUs",
        "",
        "| distance | FLIP | "
        + " | ".join(f"FLIP, {FEATURE_LABELS[f]}" for f in FEATURES)
        + "".join(f" | FLIP, {k}×{k} samples" for k in SUPERSAMPLED_FLOORS)
        + f" | FLIP, {SUPERSAMPLE}×{SUPERSAMPLE} gathered before the curve"
        + " | flicker ×truth | ms | "
        + " | ".join(f"ms, {FEATURE_LABELS[f]}" for f in FEATURES)
        + " |",
        "|" + " ---: |" * (5 + 2 * len(FEATURES) + len(SUPERSAMPLED_FLOORS)),
    ]
    for row in results["rows"]:
        cells = [row["all"], *(row[f"no_{f}"] for f in FEATURES)]
        flips = " | ".join(f"{c['flip']:.3f}" for c in cells)
        costs = " | ".join(f"{c['ms']:.0f}" for c in cells)
        floors = "".join(f" | {row['supersampled'][str(k)]:.3f}" for k in SUPERSAMPLED_FLOORS)
        gathered = f"{row['gathered']:.3f}" if "gathered" in row else ""
        flicker = f"{row['flicker']['ratio']:.2f}" if "flicker" in row else ""
        lines.append(
            f"| {row['distance_m']:g} m | {flips}{floors} | {gathered} | {flicker} | {costs} |"
        )
    return "\n".join(lines)


def before_after(path: str, distances=(0.05, 10.0)) -> None:
    """Per distance (rows): every depth feature off, all on, and the 8×8 supersampled truth."""
    from PIL import Image

    views = Views(1024)
    width, height = SIZE
    sheet = Image.new("RGB", (3 * width, height * len(distances)))
    try:
        for row, distance in enumerate(distances):
            off = views.frame(distance, SIZE, **{name: False for name in FEATURES})[0]
            on = views.frame(distance, SIZE)[0]
            truth = (views.truth(distance) * 255.0 + 0.5).astype(np.uint8)
            for column, image in enumerate((off, on, truth)):
                sheet.paste(Image.fromarray(image), (column * width, row * height))
    finally:
        views.release()
    sheet.save(path)


def main(quick: bool = False, json_path: str | None = None, plot_path: str | None = None) -> int:
    from sand_editor.bench._report import report

    optional_module("flip_evaluator", "bench depth")  # before the run: said at once
    return report(run(quick), format_table, lambda _r, p: before_after(p), json_path, plot_path)
