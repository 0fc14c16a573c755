"""PySide6 6.12.0 on Python < 3.12 drops a reference to True/False/None per ``Signal.emit`` from
Python; the process aborts (``bool_dealloc``) once a singleton's count reaches zero. These tests
run the editor's own signal paths and check the singletons' counts stay where they were."""

from __future__ import annotations

import gc
import json
import subprocess
import sys
import textwrap

import pytest

from tests.app.test_view3d import open_3d

pytestmark = pytest.mark.qt

SINGLETONS = {"True": True, "False": False, "None": None}
# Emissions between two checks: True starts near 600 references on Python 3.11, so a broken
# release is caught here, well before the interpreter would abort.
CHECK_EVERY = 100
# Other objects come and go holding a singleton (a tile cache evicting, a frame's garbage), so
# the counts wander by a few hundred; a broken release loses one per emission, without bound.
TOLERANCE = 200
TOLERANCE_PER_EMISSION = 1 / 20


def allowed_drop(emissions: int) -> int:
    """How far a singleton's count may fall over ``emissions`` with a sound binding. A broken
    one (a reference per emission) passes it within about 200 emissions, with True still
    hundreds of references from zero."""
    return TOLERANCE + int(emissions * TOLERANCE_PER_EMISSION)


SOAK_FRAMES = 2500

EMIT_PROBE = textwrap.dedent(
    """
    import json, sys
    from PySide6.QtCore import QCoreApplication, QObject, Signal

    class Emitter(QObject):
        plain = Signal()
        flag = Signal(bool)
        value = Signal(object)
        pair = Signal(object, bool)

    app = QCoreApplication([])
    emitter = Emitter()
    received = []
    for signal in (emitter.plain, emitter.flag, emitter.value, emitter.pair):
        signal.connect(lambda *args: received.append(len(args)))
    result = {}
    for name, emit in {
        "plain": lambda i: emitter.plain.emit(),
        "flag": lambda i: emitter.flag.emit(i % 2 == 0),
        "value": lambda i: emitter.value.emit(None),
        "pair": lambda i: emitter.pair.emit(None, i % 2 == 0),
    }.items():
        before = [sys.getrefcount(x) for x in (True, False, None)]
        for i in range(200):
            emit(i)
        after = [sys.getrefcount(x) for x in (True, False, None)]
        result[name] = [a - b for a, b in zip(after, before)]
    result["received"] = len(received)
    print(json.dumps(result))
    """
)


def singleton_counts() -> dict[str, int]:
    return {name: sys.getrefcount(value) for name, value in SINGLETONS.items()}


def test_signal_emit_keeps_the_counts_of_true_false_and_none():
    # In a child process: a broken release aborts it within these 800 emissions (6.12.0
    # does), which must fail this test, not end the test run.
    result = subprocess.run(
        [sys.executable, "-c", EMIT_PROBE], capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0, f"the emitting process died:\n{result.stderr[-2000:]}"
    deltas = json.loads(result.stdout)
    assert deltas.pop("received") == 4 * 200
    for signature, (true, false, none) in deltas.items():
        # 200 emissions each; a broken release loses 100 or 200 references of one of them.
        assert abs(true) < 20 and abs(false) < 20 and abs(none) < 20, (signature, deltas)


class EmissionCounter:
    """Counts the Python signal emissions of the editor and checks the singletons every
    ``CHECK_EVERY`` of them, remembering the lowest counts seen."""

    def __init__(self) -> None:
        self.emissions = 0
        gc.collect()  # garbage from earlier tests must not be freed, and counted, in this one
        self.start = singleton_counts()
        self.lowest = dict(self.start)

    def __call__(self, *args) -> None:
        self.emissions += 1
        if self.emissions % CHECK_EVERY == 0:
            self.check()

    def check(self) -> None:
        for name, count in singleton_counts().items():
            self.lowest[name] = min(self.lowest[name], count)

    @property
    def fallen(self) -> dict[str, int]:
        return {name: self.start[name] - self.lowest[name] for name in SINGLETONS}

    def healthy(self) -> bool:
        return all(drop < allowed_drop(self.emissions) for drop in self.fallen.values())


def connect_counter(window, panel) -> EmissionCounter:
    counter = EmissionCounter()
    for signal in (
        window.model.changed,
        window.model.refused,
        window.regenerator.produced,
        window.regenerator.finished,
        panel.view.rendered,
        panel.view.orbited,
        panel.view.zoomed,
    ):
        signal.connect(counter)
    return counter


def test_the_editors_signal_paths_keep_the_singleton_counts(window, qtbot):
    panel = open_3d(window, qtbot)
    counter = connect_counter(window, panel)
    model = window.model
    panel.day_speed.setValue(1.0)  # an hour a second  # the day clock runs throughout
    roughness = model.preset.shading.facet_roughness

    generations = 0
    step = 0
    while counter.emissions < 12_000 and counter.healthy():
        step += 1
        # Shading edits: a model emission each and a 3D frame when the loop turns.
        model.edit("shading.facet_roughness", roughness + 0.01 * (step % 7), gesture=True)
        model.edit("shading.sss", 0.5 + 0.1 * (step % 2))
        model.edit("shading.clear_grains", -1.0)  # refused: the refusal path emits too
        panel.view.orbited.emit(0.5, 0.0)
        panel.view.zoomed.emit(1.0)
        if step % 25 == 0:
            qtbot.wait(1)  # frames, clock ticks and generation steps run here
        if step % 500 == 0:
            # A generation edit: every progressive step of the new tile emits.
            model.edit("generation.seed", model.preset.generation.seed + 1)
            qtbot.waitUntil(lambda: not window.regenerator.busy, timeout=20_000)
            generations += 1
        counter.check()

    panel.day_speed.setValue(0)
    assert counter.healthy(), f"references lost after {counter.emissions}: {counter.fallen}"
    assert counter.emissions >= 12_000
    assert generations >= 1 and panel.view.frames > 10
    end = singleton_counts()
    for name in SINGLETONS:
        drop = counter.start[name] - end[name]
        assert drop < allowed_drop(counter.emissions), (name, counter.start, end)


@pytest.mark.slow
def test_soak_the_3d_view_with_the_clock_running(window, qtbot):
    window.resize(560, 360)
    panel = open_3d(window, qtbot)
    panel.view.setFixedSize(96, 64)
    counter = connect_counter(window, panel)
    panel.day_speed.setValue(panel.day_speed.maximum())
    start_frames = panel.view.frames
    edits = 0
    while panel.view.frames - start_frames < SOAK_FRAMES and counter.healthy():
        qtbot.wait(1)
        edits += 1
        window.model.edit("shading.facet_roughness", 0.1 + 0.01 * (edits % 50), gesture=True)
    panel.day_speed.setValue(0)

    assert counter.healthy(), f"references lost after {counter.emissions}: {counter.fallen}"
    assert panel.view.frames - start_frames >= SOAK_FRAMES
    assert panel.view.error is None
    assert panel.view.gl_error() == "GL_NO_ERROR"
