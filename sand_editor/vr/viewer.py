"""``sand-editor vr``: start a backend (headset or desktop preview), run the frame loop, write
the report, and end with an exit status from ``sand_editor.vr.link``."""

from __future__ import annotations

import json
import signal
import sys
import traceback
from contextlib import contextmanager
from pathlib import Path

from sand_editor.files import OutputError, write_atomic
from sand_editor.vr.errors import GraphicsError, NoHeadsetError, ViewerError
from sand_editor.vr.link import (
    EXIT_BAD_INPUT,
    EXIT_GRAPHICS,
    EXIT_INTERRUPTED,
    EXIT_OK,
    NullLink,
    StdioLink,
)
from sand_editor.vr.loop import FrameLoop, ViewerOptions


def run_viewer(
    options: ViewerOptions,
    desktop: bool = False,
    control: str | None = None,
    report_path: Path | None = None,
    render_scale: float = 1.0,
) -> int:
    link = StdioLink() if control == "stdio" else NullLink()
    backend = loop = None
    errors: list[str] = []
    report: dict = {"backend": "desktop" if desktop else "xr", "errors": errors}
    status = EXIT_OK
    try:
        backend = _desktop_backend(render_scale) if desktop else _xr_backend(render_scale)
        loop = FrameLoop(backend, backend.windows, link, options)
        if loop.start():
            with _stopping_on_signals(loop):
                loop.run()
        if loop.stop_requested:
            status = EXIT_INTERRUPTED
            loop.stats.errors.append("interrupted")
        if getattr(backend, "lost", False):
            raise NoHeadsetError(
                "the OpenXR runtime ended the session (LOSS_PENDING): the headset or the "
                "runtime went away; reconnect it and start the viewer again"
            )
        if status == EXIT_OK:
            report = loop.report()
    except ViewerError as exc:
        status = exc.status
        _fail(link, report, str(exc))
    except KeyboardInterrupt:
        status = EXIT_INTERRUPTED
        errors.append("interrupted")
    except Exception as exc:  # a failure in the GL or runtime layers: reported, not hidden
        traceback.print_exc(file=sys.stderr)
        status = EXIT_GRAPHICS
        _fail(link, report, f"{type(exc).__name__}: {exc}")
    finally:
        if loop is not None:
            if status != EXIT_OK:
                try:
                    report = {**loop.report(), "errors": [*loop.stats.errors, *errors]}
                except Exception:  # noqa: BLE001 - the GL state may be what failed
                    pass
            loop.close()
        if backend is not None:
            backend.close()
    if report_path is not None:
        try:
            write_report(report, report_path)
        except OutputError as exc:
            print(f"sand-editor vr: error: {exc}", file=sys.stderr)
            status = status or EXIT_BAD_INPUT
    link.send(type="bye", status=status)
    return status


def _fail(link, report: dict, message: str) -> None:
    print(f"sand-editor vr: error: {message}", file=sys.stderr)
    report["errors"].append(message)  # the same list as ``errors`` in run_viewer
    link.send(type="error", message=message)


@contextmanager
def _stopping_on_signals(loop):
    """SIGINT and SIGTERM (Ctrl+C, or the editor terminating the viewer) end the session
    cleanly: the runtime sees STOPPING and EXITING instead of a frozen frame."""

    def stop(signum, frame):
        loop.stop_requested = True

    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _windows(size: tuple[int, int], visible: bool):
    from sand_editor.vr.glwindow import GLWindows, WindowError

    try:
        return GLWindows(size, "Sand Editor — VR", visible)
    except WindowError as exc:
        raise GraphicsError(str(exc)) from None


def _desktop_backend(render_scale: float):
    from sand_editor.vr.desktop import DesktopBackend, eye_size

    size = eye_size(render_scale)
    windows = _windows((2 * size[0], size[1]), visible=True)
    try:
        return DesktopBackend(windows, size)
    except BaseException:
        windows.close()
        raise


def _xr_backend(render_scale: float):
    try:
        from sand_editor.vr.xr_backend import XrBackend
    except ImportError as exc:  # pyopenxr or its loader library missing
        from sand_editor.vr.errors import RUNTIME_HELP, NoRuntimeError

        reason = f"the OpenXR loader cannot be loaded ({exc})"
        raise NoRuntimeError(f"{reason}. {RUNTIME_HELP}") from None
    return XrBackend(lambda: _windows((64, 64), visible=False), render_scale)


def write_report(report: dict, path: Path) -> None:
    """JSON, written through a temporary file renamed into place."""
    text = json.dumps(report, indent=2) + "\n"
    write_atomic(path, text.encode(), make_folder=True)
