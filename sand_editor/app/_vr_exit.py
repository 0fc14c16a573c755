"""What the end of a viewer process means, in words: its exit status (``sand_editor.vr.link``
names them) or the signal that killed it, the fix where there is one, and its last log lines.

Standard library only: the sentences can be read and checked without Qt.
"""

from __future__ import annotations

import signal

from sand_editor.vr.link import (
    EXIT_BAD_INPUT,
    EXIT_GRAPHICS,
    EXIT_INTERRUPTED,
    EXIT_LINK_BROKEN,
    EXIT_NO_HEADSET,
    EXIT_NO_RUNTIME,
    EXIT_OK,
)

# Between what happened and the viewer's last log lines, in the message of ``finished``.
LOG_HEADING = "\n\nLast lines from the viewer:\n"

EXIT_MEANINGS = {
    EXIT_BAD_INPUT: "the viewer refused its input (preset or arguments)",
    EXIT_NO_RUNTIME: "no OpenXR runtime is installed or active",
    EXIT_NO_HEADSET: "the OpenXR runtime has no headset ready (none found, or it was lost)",
    EXIT_GRAPHICS: "the viewer could not set up graphics (no OpenGL context, or the runtime "
    "refused the session)",
    EXIT_LINK_BROKEN: "the viewer lost its link to the editor (reading the editor's messages "
    "failed)",
    EXIT_INTERRUPTED: "the viewer was interrupted",
}
FIXES = {
    EXIT_NO_RUNTIME: "Install and activate an OpenXR runtime such as SteamVR, Monado or WiVRn "
    "(make it the active runtime in its settings, or point XR_RUNTIME_JSON at its manifest), "
    "then press View in VR again.",
    EXIT_NO_HEADSET: "Connect the headset and turn it on (for WiVRn or ALVR, start the app on "
    "the headset), make sure the runtime shows it as ready, then press View in VR again.",
}


# Signal numbers by name, where the platform has them (Windows has no SIGKILL or SIGBUS).
SIGKILL = int(getattr(signal, "SIGKILL", 9))
_CRASH_SIGNALS = frozenset(
    int(getattr(signal, name))
    for name in ("SIGSEGV", "SIGBUS", "SIGABRT", "SIGILL", "SIGFPE")
    if hasattr(signal, name)
)


def exit_meaning(status: int) -> str:
    """What an exit status of ``sand-editor vr`` means, in words; negative: killed by a signal."""
    if status < 0:
        name = signal_name(-status)
        if -status == SIGKILL:
            return (
                f"the viewer was killed ({name}: by another program, or by the system when "
                "memory ran out)"
            )
        if -status in _CRASH_SIGNALS:
            return f"the viewer crashed ({name})"
        return f"the viewer was ended by {name}"
    if status == EXIT_OK:
        return "the viewer closed"
    return EXIT_MEANINGS.get(status, f"the viewer stopped with exit status {status}")


def signal_name(number: int) -> str:
    """The name of signal ``number`` (``SIGTERM``), or ``signal N`` where it has none here."""
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


def describe_exit(status: int, stop_reason: str | None, shown: bool, log_tail: str) -> str:
    """The message of ``finished`` for a viewer that ended with ``status``: what happened, the
    fix where there is one, and ``log_tail`` (its last log lines) unless it closed normally.

    ``stop_reason`` says why the editor ended the viewer itself (None: it exited on its own);
    ``shown`` whether it had shown its first frame.
    """
    sentence = exit_meaning(status)
    if stop_reason is not None:
        ending = signal_name(-status) if status < 0 else f"exit status {status}"
        sentence = f"the viewer was stopped because {stop_reason} (it ended with {ending})"
    elif status == EXIT_OK and not shown:
        sentence = "the viewer closed before it showed anything"
    message = sentence[0].upper() + sentence[1:] + "."
    if status in FIXES:
        message += " " + FIXES[status]
    if log_tail and (status != EXIT_OK or stop_reason is not None):
        message += LOG_HEADING + log_tail
    return message
