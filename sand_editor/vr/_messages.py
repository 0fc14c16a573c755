"""The editor's messages to the viewer's frame loop: each line the link delivers is applied or
answered with one error line, and no line, whatever it holds, ends the viewer."""

from __future__ import annotations

import sys
import time
import traceback
from dataclasses import replace

from sand_editor.preset import Preset, PresetError
from sand_editor.render.modes import MODES
from sand_editor.vr.errors import LinkBrokenError
from sand_editor.vr.link import (
    EDITOR_MESSAGES,
    LinkError,
    check_grains,
    check_move,
    check_seq,
    check_time_fields,
    error_text,
)
from sand_editor.vr.workbench import BUTTONS

MAX_REPORTED_ERRORS = 200  # the report keeps the first errors; each is still answered
LINK = "link"  # the source of view changes the editor made: not sent back to it


def handle_link(loop) -> None:
    """Answer everything the editor sent since the last frame; a link that broke ends the loop."""
    for message in loop.link.poll():
        if isinstance(message, LinkError):  # a line that is no message
            answer_error(loop, str(message))
            continue
        try:
            handle_message(loop, message)
        except (LinkError, PresetError) as exc:
            answer_error(loop, f"{message['type']}: {exc}")
        except Exception as exc:  # noqa: BLE001 - no line may end the viewer
            traceback.print_exc(file=sys.stderr)
            answer_error(loop, f"{message['type']}: not applied: {type(exc).__name__}: {exc}")
    if loop.link.closed:
        if loop.link.broken is not None:
            raise LinkBrokenError(f"the link to the editor broke: {loop.link.broken}")
        loop.backend.request_exit()


def handle_message(loop, message: dict) -> None:
    kind = message["type"]
    if kind == "preset":
        seq = check_seq(message)
        shared = check_grains(message)
        preset = Preset.from_dict(message.get("preset"), source="the editor's preset")
        label = f"{preset.name} (editing)"
        if loop.presets[0][0].endswith("(editing)"):
            loop.presets[0] = (label, preset)
        else:
            loop.presets.insert(0, (label, preset))
        loop.controls = replace(loop.controls, preset_index=0, preset_count=len(loop.presets))
        loop.worker.request(preset, seq, shared)
        loop.pending = (seq, time.perf_counter())
    elif kind == "time":
        loop.view.update(LINK, **check_time_fields(message))
    elif kind == "mode":
        mode = message.get("mode")
        if not isinstance(mode, str) or mode not in MODES:
            shown = repr(mode) if isinstance(mode, str) else type(mode).__name__
            raise LinkError(f"unknown mode {shown}; allowed: {', '.join(MODES)}")
        loop.view.update(LINK, mode=mode)
    elif kind == "move":
        loop.move(**check_move(message))
    elif kind == "press":
        # A panel button pressed from afar, as a controller's trigger on it presses it.
        button = message.get("button")
        if not isinstance(button, str) or button not in BUTTONS:
            shown = repr(button) if isinstance(button, str) else type(button).__name__
            raise LinkError(f"unknown button {shown}; allowed: {', '.join(BUTTONS)}")
        loop.run_command(BUTTONS[button].command)
    elif kind == "quit":
        loop.backend.request_exit()
    else:
        raise LinkError(f"unknown message type {kind!r}; allowed: {', '.join(EDITOR_MESSAGES)}")


def answer_error(loop, text: str) -> None:
    """Tell the editor (one bounded line) and keep it for the report."""
    text = error_text(text)
    loop.stats.error_count += 1
    if len(loop.stats.errors) < MAX_REPORTED_ERRORS:
        loop.stats.errors.append(text)
    loop.link.send(type="error", message=text)
