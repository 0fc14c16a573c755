"""The appearance sweep: shipped and random valid presets at every distance and two suns.

For each preset and view it measures what a person would see go wrong: NaN or inf in the HDR
frame, the share of the ground clipped white in the final frame (bloom, exposure, ACES, sRGB,
through the whole renderer), and the ratio of the close range's mean radiance to the far
range's on the probe's plane, with the sparkle at its expectation (the model) and as drawn
(with the Poisson spread of the facets drawn), and the same ratio in the final frames; and
how much of each shipped sand's ground sparkles. The suite runs a small version of it;
``sand-editor bench appearance`` runs it whole.
"""

from __future__ import annotations

import numpy as np

from sand_editor.bench.probe import MaterialProbe
from sand_editor.colour import luminance, srgb_to_linear
from sand_editor.preset import FIELDS, Color, Preset
from sand_editor.render.camera import camera_at_distance
from sand_editor.render.exposure import light_exposure
from sand_editor.render.material import SandMaterial
from sand_editor.render.renderer import SandRenderer
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import parse_time, sky_at
from sand_editor.resources import bundled_preset

SHIPPED = ("paper-default", "black-volcanic", "pale-quartz", "red-desert")
DISTANCES = (0.3, 1.0, 3.0, 10.0, 30.0)
# Noon, and a low sun ahead of the camera (glints towards it); as scene times for the frames.
SUNS = {"noon": ((0.2, 0.95, -0.25), "12:00"), "low": ((0.0, 0.2, -0.98), "17:45")}
CLIPPED = 250  # an 8-bit channel value at or above which a pixel reads as white
PITCH_DEG = 35.0
FOV_Y_DEG = 60.0  # camera_at_distance's
# Close and far agree on average over many grains: a view whose ground spans fewer grains than
# this (a few thousand in its lower half) shows the colours and normals of the grains in it, not
# the tile's average, and is not compared (a 1 m tile of period 1, seen from 0.3 m, is one grain).
MIN_GRAINS_ACROSS = 100
# The drawn sparkles are Poisson counts of real facets: a frame's mean light differs from its
# expectation by up to this many standard deviations of the draw.
DRAW_SIGMAS = 3.0


def draw_bound(sigma: float, largest: float, sigmas: float = DRAW_SIGMAS) -> float:
    """How far a frame's mean drawn light may lie from its expectation: Bernstein's bound on a
    sum of independent Poisson terms, with the exponent a normal tail has at ``sigmas`` standard
    deviations (−ln p = sigmas²/2). ``sigma`` is the draw's standard deviation and ``largest``
    the most one facet adds to the mean. Where many facets each add little, it is ``sigmas``·σ;
    where a few facets carry the light, one of them may lie far out on its own, and the bound
    says how far."""
    log_chance = 0.5 * sigmas * sigmas  # −ln p
    # t² = 2·ln(1/p)·(σ² + b·t/3), for t.
    b = 2.0 * log_chance * largest / 3.0
    return float(0.5 * (b + np.sqrt(b * b + 8.0 * log_chance * sigma * sigma)))


def _colour(rng: np.random.Generator) -> Color:
    return Color.from_hex(f"#{int(rng.integers(0, 1 << 24)):06x}")


def _number(rng: np.random.Generator, low: float, high: float) -> float:
    """The minimum, the maximum or a value between (equal chances): log-uniform where the range
    spans a decade or more of positive values, uniform elsewhere."""
    pick = rng.integers(3)
    if pick == 0:
        return low
    if pick == 1:
        return high
    if low > 0 and high / low >= 10.0:
        return float(np.exp(rng.uniform(np.log(low), np.log(high))))
    return float(rng.uniform(low, high))


def random_preset(rng: np.random.Generator, name: str = "random") -> Preset:
    """A valid preset drawn from the whole field table: each number at its minimum, its maximum
    or in between (log-uniform over decades), colours and weights at random."""
    changes = {}
    for spec in FIELDS:
        if spec.section == "" or spec.kind == "text":
            continue
        if spec.kind == "color":
            changes[spec.path] = _colour(rng)
        elif spec.kind == "colors":
            changes[spec.path] = tuple(_colour(rng) for _ in range(spec.count))
        elif spec.kind == "weights":
            weights = rng.integers(0, 101, size=spec.count).astype(float)
            weights[rng.integers(spec.count)] = max(weights.max(), 1.0)
            changes[spec.path] = tuple(weights)
        else:
            value = _number(rng, spec.minimum, spec.maximum)
            changes[spec.path] = int(round(value)) if spec.kind == "int" else value
    return Preset(name=name).replace(**changes)


def sweep_presets(random_count: int, seed: int = 2026) -> list[Preset]:
    rng = np.random.default_rng(seed)
    shipped = [Preset.load(bundled_preset(name)) for name in SHIPPED]
    return shipped + [random_preset(rng, f"random-{seed}-{i}") for i in range(random_count)]


def grains_across(preset: Preset, distance_m: float, aspect: float) -> float:
    """Grains along the width of the ground at the view's centre."""
    width_m = 2.0 * distance_m * np.tan(np.radians(FOV_Y_DEG / 2.0)) * aspect
    return float(width_m * preset.shading.uv_scale * preset.generation.period)


def _ground(image: np.ndarray) -> np.ndarray:
    """Luminance of the lower half of a top-down (height, width, 3) image."""
    return luminance(image[image.shape[0] // 2 :])


class Sweep:
    """A material, its probe and a renderer on one context, reused for every preset."""

    def __init__(self, ctx, texture_size: int = 256, probe_size=(96, 54), frame_size=(160, 90)):
        self.material = SandMaterial(ctx, texture_size)
        self.probe = MaterialProbe(self.material, *probe_size)
        self.renderer = SandRenderer(ctx)
        self.frame_size = frame_size

    def measure(self, preset: Preset, distances=DISTANCES, suns=tuple(SUNS)) -> list[dict]:
        self.material.update(preset)
        self.renderer.set_material(self.material)
        aspect = self.probe.width / self.probe.height
        rows = []
        for sun in suns:
            direction, time_text = SUNS[sun]
            self.probe.sun_direction = np.array(direction, dtype=float)
            for distance in distances:
                across = grains_across(preset, distance, aspect)
                rows.append({"preset": preset.name, "sun": sun, "distance_m": distance,
                             "grains_across": across, "compared": across >= MIN_GRAINS_ACROSS,
                             **self._view(distance, time_text)})  # fmt: skip
        return rows

    def _probe(self, camera, mode: str, glint_filter: str) -> np.ndarray:
        self.probe.glint_filter = glint_filter
        image, _ = self.probe.render(camera, mode, lower_half=True)
        return image

    def _view(self, distance: float, time_text: str) -> dict:
        camera = self.probe.camera(distance, PITCH_DEG)
        images = {
            "drawn": self._probe(camera, "close", "ours"),
            "expected": self._probe(camera, "close", "ours-mean"),
            "far": self._probe(camera, "far", "ours"),
            "glints": self._probe(camera, "glints", "ours-mean"),
            "one_facet": self._probe(camera, "glints", "one-facet"),
        }
        finite = all(bool(np.isfinite(image).all()) for image in images.values())
        ground = {name: _ground(image) for name, image in images.items()}
        means = {name: float(values.mean()) for name, values in ground.items()}
        # The drawn light of a pixel is Poisson in units of one facet's: its variance is the
        # expected glint times that unit, and the frame's mean has the mean of those over N.
        variance = np.maximum(ground["glints"] * ground["one_facet"], 0.0)
        draw_sigma = float(np.sqrt(variance.sum()) / variance.size)
        draw_largest = float(ground["one_facet"].max() / variance.size)
        far = means["far"]
        frames = {mode: self.frame(distance, time_text, mode) for mode in ("full", "close", "far")}
        finite &= all(ok for _, ok in frames.values())
        frame = frames["full"][0]
        lit = {
            mode: float(_ground(srgb_to_linear(f / 255.0)).mean())
            for mode, (f, _) in frames.items()
        }
        return {
            "finite": finite,
            "close": means["drawn"],
            "expected": means["expected"],
            "far": far,
            "glint_share": means["glints"] / far if far > 0 else 0.0,
            "draw_sigma": draw_sigma,
            "draw_largest": draw_largest,
            "close_over_far": means["expected"] / far if far > 0 else 1.0,
            "drawn_over_far": means["drawn"] / far if far > 0 else 1.0,
            "frame_close": lit["close"],
            "frame_far": lit["far"],
            "clipped": float((frame[frame.shape[0] // 2 :].min(axis=-1) >= CLIPPED).mean()),
        }

    def frame(
        self, distance: float, time_text: str, mode: str = "full", metered: bool | None = None
    ) -> tuple[np.ndarray, bool]:
        """The renderer's frame and whether its HDR scene was finite: metered (by default for
        ``full``) or at the light's exposure (by default for the other modes, so that close and
        far compare)."""
        width, height = self.frame_size
        terrain = self.renderer.terrain
        camera = camera_at_distance(
            distance, PITCH_DEG, width / height,
            ground_height=lambda x, z: float(terrain.height(x, z)),
        )  # fmt: skip
        sky = sky_at(parse_time(time_text))
        metered = mode == "full" if metered is None else metered
        exposure = None if metered else light_exposure(sky)
        frame = self.renderer.render_to_array(
            width, height, FrameRequest(camera, sky, mode, exposure=exposure)
        )
        hdr = np.frombuffer(self.renderer.post.scene_texture.read(), dtype=np.float16)
        return frame, bool(np.isfinite(hdr).all())

    def release(self) -> None:
        self.renderer.release()
        self.probe.release()
        self.material.release()


def run(quick: bool = False) -> dict:
    from sand_editor.bench.generator import machine_description
    from sand_editor.gl import standalone_context

    ctx = standalone_context()
    sweep = Sweep(ctx)
    try:
        rows = [row for p in sweep_presets(4 if quick else 16) for row in sweep.measure(p)]
        sweep.material.release()
        sweep.material = SandMaterial(ctx, 1024)  # the editor's tile, for the sparkles
        sweep.renderer.set_material(sweep.material)
        sparkles = sparkle_shares(sweep)
    finally:
        sweep.release()
    from sand_editor.bench.mitsuba_reference import compare

    shipped = [Preset.load(bundled_preset(name)) for name in SHIPPED]
    presets = shipped[:1] if quick else shipped
    distances = (3.0,) if quick else (1.0, 3.0, 10.0, 30.0)
    reference = compare(presets, distances, spp=16 if quick else 64)
    return {"machine": machine_description(ctx), "rows": rows, "sparkles": sparkles,
            "mitsuba": reference}  # fmt: skip


def format_table(results: dict) -> str:
    lines = [
        "Appearance sweep, {gl_renderer}, {cpu_count} CPUs".format(**results["machine"]),
        "",
        "Close over far, mean HDR light of the ground, in views that span at least "
        f"{MIN_GRAINS_ACROSS} grains: as expected (sparkles at their expectation) and as drawn "
        "(± one standard deviation of the facets' Poisson draw); the final frames' decoded "
        "luminance at the light's exposure (the display clips sparkles that HDR keeps).",
        "",
        "| preset | expected, worst (at) | drawn, worst | final frames, worst | views compared "
        "| clipped white, most | NaN or inf |",
        "| --- | ---: | ---: | ---: | ---: | ---: | --- |",
    ]
    names = dict.fromkeys(row["preset"] for row in results["rows"])
    for name in names:
        rows = [row for row in results["rows"] if row["preset"] == name]
        clipped = max(row["clipped"] for row in rows)
        finite = "none" if all(row["finite"] for row in rows) else "**yes**"
        compared = [row for row in rows if row["compared"]]
        if compared:
            worst = max(compared, key=lambda row: abs(row["close_over_far"] - 1.0))
            at = f"{worst['distance_m']:g} m, {worst['sun']} sun"
            drawn = max(compared, key=lambda row: abs(row["drawn_over_far"] - 1.0))
            sigma = drawn["draw_sigma"] / drawn["far"] if drawn["far"] > 0 else 0.0
            final = max(compared, key=lambda row: abs(_frame_ratio(row) - 1.0))
            agreement = (
                f"{worst['close_over_far']:.3f} ({at}) | {drawn['drawn_over_far']:.2f} ± "
                f"{sigma:.2f} | {_frame_ratio(final):.2f}"
            )
        else:
            agreement = "— | — | —"
        lines.append(
            f"| {name} | {agreement} | {len(compared)} of {len(rows)} | {clipped * 100:.2f} % "
            f"| {finite} |"
        )
    if results.get("sparkles"):
        views = [f"{d:g} m {t}" for d, t in SPARKLE_VIEWS]
        lines += [
            "",
            f"Sparkle share: ground pixels that glints lift to at least {SPARKLE_CONTRAST:g}× the "
            f"median of their {SPARKLE_NEIGHBOURHOOD}×{SPARKLE_NEIGHBOURHOOD} neighbourhood and "
            "to as many times what they show without glints, final "
            f"{SPARKLE_FRAME[0]}×{SPARKLE_FRAME[1]} frame, pitch {PITCH_DEG:g}°, 1024² tile:",
            "",
            "| preset | " + " | ".join(views) + " |",
            "| --- |" + " ---: |" * len(views),
        ]
        for name, shares in results["sparkles"].items():
            cells = " | ".join(f"{row['share'] * 100:.3f} %" for row in shares)
            lines.append(f"| {name} | {cells} |")
    if results.get("mitsuba"):
        from sand_editor.bench.mitsuba_reference import format_rows

        lines += [
            "",
            "Against Mitsuba 3 (scalar_rgb), mean HDR luminance, ours over Mitsuba's:",
            "",
        ]
        lines.append(format_rows(results["mitsuba"]))
    return "\n".join(lines)


SPARKLE_VIEWS = tuple((d, t) for t in ("12:00", "16:30") for d in (0.3, 1.0))
SPARKLE_FRAME = (320, 180)
SPARKLE_CONTRAST = 2.0  # a sparkle: at least this many times its neighbourhood's median
SPARKLE_NEIGHBOURHOOD = 7  # pixels across


def sparkle_share(frame: np.ndarray, without_glints: np.ndarray) -> float:
    """Share of the ground's pixels (top-down 8-bit sRGB frames' lower halves) that glints make
    sparkle: at least SPARKLE_CONTRAST times the median of their neighbourhood in linear
    luminance, and at least that many times what the same pixel shows without glints (so that
    bright grains beside dark ones do not count)."""
    luminance = _ground(srgb_to_linear(frame / 255.0))
    plain = _ground(srgb_to_linear(without_glints / 255.0))
    r = SPARKLE_NEIGHBOURHOOD // 2
    padded = np.pad(luminance, r, mode="edge")
    windows = np.lib.stride_tricks.sliding_window_view(padded, (2 * r + 1, 2 * r + 1))
    median = np.maximum(np.median(windows, axis=(-2, -1)), 1e-6)
    sparkles = (luminance >= SPARKLE_CONTRAST * median) & (luminance >= SPARKLE_CONTRAST * plain)
    return float(sparkles.mean())


def sparkle_shares(sweep: Sweep) -> dict:
    """Each shipped sand's sparkle share in the final frame of each of SPARKLE_VIEWS, at the
    light's exposure (the same for the frame without glints)."""
    size, sweep.frame_size = sweep.frame_size, SPARKLE_FRAME
    shares = {}
    try:
        for name in SHIPPED:
            preset = Preset.load(bundled_preset(name))
            frames = {}
            for clear in (0.0, preset.shading.clear_grains):
                sweep.material.update(preset.replace(**{"shading.clear_grains": clear}))
                sweep.renderer.set_material(sweep.material)
                frames[clear > 0] = [sweep.frame(d, t, "full", metered=False)[0]
                                     for d, t in SPARKLE_VIEWS]  # fmt: skip
            shares[name] = [
                {"distance_m": d, "time": t, "share": sparkle_share(lit, plain)}
                for (d, t), lit, plain in zip(
                    SPARKLE_VIEWS, frames[True], frames[False], strict=True
                )
            ]
    finally:
        sweep.frame_size = size
    return shares


def _frame_ratio(row: dict) -> float:
    return row["frame_close"] / row["frame_far"] if row["frame_far"] > 0 else 1.0


def contact_sheet(path: str, size=(320, 180), distances=(0.3, 3.0, 30.0), time_text="16:30"):
    """The shipped sands (rows) at each distance (columns), as the renderer shows them."""
    from PIL import Image

    from sand_editor.gl import standalone_context

    ctx = standalone_context()
    sweep = Sweep(ctx, texture_size=1024, frame_size=size)
    sheet = Image.new("RGB", (size[0] * len(distances), size[1] * len(SHIPPED)))
    try:
        for row, name in enumerate(SHIPPED):
            sweep.material.update(Preset.load(bundled_preset(name)))
            sweep.renderer.set_material(sweep.material)
            for column, distance in enumerate(distances):
                frame, _ = sweep.frame(distance, time_text)
                sheet.paste(Image.fromarray(frame), (column * size[0], row * size[1]))
    finally:
        sweep.release()
    sheet.save(path)


def main(quick: bool = False, json_path: str | None = None, plot_path: str | None = None) -> int:
    from sand_editor.bench._report import report
    from sand_editor.bench.mitsuba_reference import load_mitsuba

    load_mitsuba()  # before the run, so that a missing Mitsuba is said at once
    return report(run(quick), format_table, lambda _r, p: contact_sheet(p), json_path, plot_path)
