"""``sand-editor bench editor``: how quickly the editor answers while it works.

Event-loop latency is the lateness of a 10 ms timer: how long a click or key press would wait.
It is measured while the editor does what users do (drag a generation slider on a 2D map, orbit
the 3D view, edit the sand with the 3D view open, run the day clock), for the scenario and the
half second after it, so the full-resolution frame that follows an interaction counts too.
Then the time from a slider edit to the new low-resolution and full 2D tile on screen, and to
the 3D view drawing a frame with the new grains.
"""

from __future__ import annotations

import statistics
import sys
import time

import PySide6
from PySide6.QtCore import QElapsedTimer, QTimer
from PySide6.QtWidgets import QApplication, QSlider

from sand_editor.bench._report import report
from sand_editor.bench.generator import machine_description
from sand_editor.preset import Preset
from sand_editor.resources import bundled_preset

PROBE_MS = 10
WINDOW_SIZE = (1280, 820)
SCENARIOS = ("2D edits", "3D orbit", "3D edits", "3D clock")
EDIT_FIELD = "generation.threshold"
TARGETS = {"p95_ms": 50.0, "max_ms": 150.0, "low_res_ms": 100.0, "full_ms": 300.0, "3d_ms": 500.0}


class LatencyProbe:
    """A 10 ms timer that records how late each of its ticks came."""

    def __init__(self) -> None:
        self.samples: list[float] = []
        self._clock = QElapsedTimer()
        self._timer = QTimer(interval=PROBE_MS)
        self._timer.timeout.connect(self._tick)

    def start(self) -> None:
        self.samples = []
        self._clock.start()
        self._timer.start()

    def stop(self) -> list[float]:
        self._timer.stop()
        return self.samples

    def _tick(self) -> None:
        elapsed_ms = self._clock.nsecsElapsed() / 1e6
        self._clock.restart()
        self.samples.append(max(0.0, elapsed_ms - PROBE_MS))


def _wait(app: QApplication, seconds: float, until=None) -> bool:
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        app.processEvents()
        if until is not None and until():
            return True
        time.sleep(0.001)
    return until is None


def _percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


class EditorBench:
    def __init__(self, app: QApplication, quick: bool) -> None:
        from sand_editor.app import EditorWindow

        self.app = app
        self.quick = quick
        self.seconds = 3.0 if quick else 8.0
        self.window = EditorWindow(Preset.load(bundled_preset("paper-default")))
        self.window.resize(*WINDOW_SIZE)
        self.window.show()
        self.slider: QSlider = self.window.controls.findChild(QSlider, f"{EDIT_FIELD}:slider")
        self.probe = LatencyProbe()
        self._wait_generated()

    def _wait_generated(self) -> None:
        _wait(self.app, 60.0, lambda: not self.window.regenerator.busy)

    def _drive(self, name: str, every_ms: int, step, view=None) -> dict:
        """Latency while ``step(i)`` runs every ``every_ms`` for the scenario's length, and the
        frames ``view`` drew a second meanwhile (a view that stopped drawing would answer at
        once)."""
        driver = QTimer(interval=every_ms)
        count = [0]

        def tick() -> None:
            step(count[0])
            count[0] += 1

        driver.timeout.connect(tick)
        self.probe.start()
        first_frame = view.frames if view is not None else 0
        driver.start()
        _wait(self.app, self.seconds)
        driver.stop()
        frames = view.frames - first_frame if view is not None else None
        _wait(self.app, 0.5)
        samples = self.probe.stop()
        self._wait_generated()
        return {
            "scenario": name,
            "samples": len(samples),
            "p50_ms": round(statistics.median(samples), 1),
            "p95_ms": round(_percentile(samples, 0.95), 1),
            "max_ms": round(max(samples), 1),
            "frames_per_s": None if frames is None else round(frames / self.seconds, 1),
        }

    def _slider_drag(self, i: int) -> None:
        # A drag back and forth across a quarter of the slider, as a hand would.
        span = self.slider.maximum() // 4
        phase = i % 40
        self.slider.setSliderDown(True)
        self.slider.setValue(self.slider.maximum() // 4 + span * min(phase, 40 - phase) // 20)

    def latency(self) -> list[dict]:
        window = self.window
        rows = [self._drive("2D edits", 30, self._slider_drag)]
        self.slider.setSliderDown(False)
        panel = window.preview.show_3d()
        _wait(self.app, 30.0, lambda: panel.view.frames > 0 and panel.view.at_rest)
        self.machine = panel.view.call_in_context(machine_description)
        view = panel.view
        rows.append(self._drive("3D orbit", 16, lambda i: view.orbited.emit(1.5, 0.0), view))
        rows.append(self._drive("3D edits", 30, self._slider_drag, view))
        self.slider.setSliderDown(False)
        panel.day_speed.setValue(1.0)  # an hour a second
        rows.append(self._drive("3D clock", 1000, lambda i: None, view))
        panel.day_speed.setValue(0)
        return rows

    def edit_to_screen(self) -> dict:
        """Median ms from a slider edit to the new low-res and full 2D tiles and the 3D frame."""
        window = self.window
        repeats = 3 if self.quick else 7
        window.preview.tabs.setCurrentIndex(0)
        window.preview.size_combo.setCurrentIndex(window.preview.size_combo.count() - 1)
        self._wait_generated()
        low, full = [], []
        events: dict[str, float] = {}

        def shown(textures, final) -> None:
            events.setdefault("full" if final else "low", time.perf_counter())

        window.regenerator.produced.connect(shown)
        for i in range(repeats):
            events.clear()
            start = time.perf_counter()
            self.slider.setValue(self.slider.value() + (7 if i % 2 == 0 else -5))
            _wait(self.app, 30.0, lambda: "full" in events)
            self.app.processEvents()  # the tile's image is made in the slot that got it
            low.append((events.get("low", events["full"]) - start) * 1e3)
            full.append((events["full"] - start) * 1e3)
        window.regenerator.produced.disconnect(shown)

        panel = window.preview.show_3d()
        view = panel.view
        window.preview.size_combo.setCurrentIndex(1)  # the default 512² tile
        self._wait_generated()
        _wait(self.app, 30.0, lambda: view.at_rest)
        in_3d = []
        drawn_at: list[float] = []

        def drawn(timings) -> None:
            if not drawn_at and view.grains_generation == window.model.preset.generation:
                drawn_at.append(time.perf_counter())

        view.rendered.connect(drawn)
        for i in range(repeats):
            drawn_at.clear()
            start = time.perf_counter()
            self.slider.setValue(self.slider.value() + (7 if i % 2 == 0 else -5))
            _wait(self.app, 30.0, lambda: bool(drawn_at))
            in_3d.append((drawn_at[0] - start) * 1e3)
            _wait(self.app, 30.0, lambda: view.at_rest)
        view.rendered.disconnect(drawn)
        return {
            "size_2d": window.preview.size_combo.itemData(window.preview.size_combo.count() - 1),
            "low_res_ms": round(statistics.median(low), 1),
            "full_ms": round(statistics.median(full), 1),
            "3d_ms": round(statistics.median(in_3d), 1),
            "low_res_max_ms": round(max(low), 1),
            "full_max_ms": round(max(full), 1),
            "3d_max_ms": round(max(in_3d), 1),
        }

    def close(self) -> None:
        self.window.model.undo_stack.setClean()
        self.window.close()


def format_table(results: dict) -> str:
    lines = [
        "Editor latency on {cpu_count} cores, {gl_renderer}, PySide6 {pyside6}, "
        "window {window}".format(window=results["window"], **results["machine"]),
        "",
        "| Scenario | p50 ms | p95 ms | max ms | samples | 3D frames/s |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for row in results["latency"]:
        fps = "–" if row["frames_per_s"] is None else row["frames_per_s"]
        lines.append(
            f"| {row['scenario']} | {row['p50_ms']} | {row['p95_ms']} | {row['max_ms']} | "
            f"{row['samples']} | {fps} |"
        )
    edit = results["edit_to_screen"]
    lines += [
        "",
        "| After a slider edit | median ms | max ms |",
        "|---|---:|---:|",
        f"| low-resolution 2D tile | {edit['low_res_ms']} | {edit['low_res_max_ms']} |",
        f"| full {edit['size_2d']}² 2D tile | {edit['full_ms']} | {edit['full_max_ms']} |",
        f"| 3D view with the new grains | {edit['3d_ms']} | {edit['3d_max_ms']} |",
    ]
    return "\n".join(lines)


def _no_plot(results: dict, path: str) -> None:
    raise ValueError("the editor benchmark draws no plot; use --json")


def main(quick: bool = False, json_path: str | None = None, plot_path: str | None = None) -> int:
    from sand_editor.app import require_display

    require_display()
    app = QApplication.instance() or QApplication(sys.argv[:1])
    bench = EditorBench(app, quick)
    try:
        latency = bench.latency()
        results = {
            "machine": {**bench.machine, "pyside6": PySide6.__version__},
            "window": f"{WINDOW_SIZE[0]}×{WINDOW_SIZE[1]}",
            "quick": quick,
            "targets": TARGETS,
            "latency": latency,
            "edit_to_screen": bench.edit_to_screen(),
        }
    finally:
        bench.close()
    return report(results, format_table, _no_plot, json_path, plot_path)
