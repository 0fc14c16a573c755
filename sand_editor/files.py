"""Output files written whole or not at all: the one place the product writes files.

Every writer goes through :func:`write_atomic` (one file) or :func:`write_folder` (a set of files
that belong together, such as a bake):

- the bytes go to a temporary file beside the target, are flushed to disk, and replace the
  target in one rename, so a reader sees the old file or the new one, never a mix;
- only regular files are replaced: a path naming a device, FIFO, socket or folder is refused
  (renaming over ``/dev/full`` would swap the device node for a PNG);
- temporary files are removed on any failure, and those a killed process left behind (their
  names carry the writer's process id) are removed by the next write into that folder;
- a folder's files are written under an exclusive lock on the folder, so two bakes into one
  folder never mix their files;
- a folder's files are plain names inside it: a name with a separator, ``..`` or NUL is refused
  before anything is written, and :func:`file_stem` makes names from outside (a preset's name)
  into such names;
- every failure is an :class:`OutputError` naming the file and the reason.

Standard library only: the preset package writes its files through here.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import secrets
import stat
from collections.abc import Iterator, Mapping
from pathlib import Path

try:  # POSIX; elsewhere folders are written without the lock
    import fcntl
except ImportError:  # pragma: no cover - not on Linux
    fcntl = None  # type: ignore[assignment]

TEMP_SUFFIX = ".tmp"
NEW_FILE_MODE = 0o644  # outputs are for sharing; a replaced file keeps its own mode
# File names end at 255 bytes on most file systems; a stem gets a suffix ("_BaseColor.png") and,
# while written, a temporary name around it (".{name}.{pid}-{token}.tmp").
MAX_STEM_BYTES = 100
DEFAULT_STEM = "sand"
# Separators, and the characters Windows reserves in names.
_NOT_IN_NAMES = frozenset('/\\<>:"|?*')
_WINDOWS_DEVICES = frozenset(
    {"CON", "PRN", "AUX", "NUL", *(f"{port}{i}" for port in ("COM", "LPT") for i in range(1, 10))}
)
_DOT_RUNS = re.compile(r"\.{2,}")

_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISSOCK, "a socket"),
)


class OutputError(OSError):
    """A file could not be written; ``str()`` is ``"{path}: {reason}"``, one line.

    ``cause`` is the system's reason (``"No space left on device"``) when a write failed, and
    None when the path was refused before writing.
    """

    def __init__(self, path: str | os.PathLike[str], reason: str, cause: str | None = None):
        super().__init__(reason)
        self.path = os.fspath(path)
        self.reason = reason
        self.cause = cause

    def __str__(self) -> str:
        return f"{self.path}: {self.reason}"


def _reason(error: OSError) -> str:
    if error.errno == errno.ENOENT:
        return "its folder does not exist"
    return error.strerror or str(error)


def _failed(path: str | os.PathLike[str], verb: str, error: OSError) -> OutputError:
    cause = _reason(error)
    return OutputError(path, f"cannot {verb}: {cause}", cause)


def check_regular_target(path: str | os.PathLike[str]) -> None:
    """Raise :class:`OutputError` when ``path`` exists and is not a regular file."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        return
    except OSError as error:
        raise _failed(path, "write", error) from None
    if stat.S_ISREG(info.st_mode):
        return
    kind = next((name for test, name in _KINDS if test(info.st_mode)), "not a regular file")
    raise OutputError(path, f"is {kind}; allowed a regular file or a new file name")


def check_output(path: str | os.PathLike[str]) -> None:
    """Raise :class:`OutputError` now for what would make ``write_atomic(path, …,
    make_folder=True)`` fail later without writing a byte: ``path`` is not a regular file, a
    folder on the way is a file, or the nearest existing folder cannot be written in.

    For an output written after minutes of work (a benchmark's ``--json``), checked first.
    """
    check_regular_target(path)  # a file on the way fails its stat: "Not a directory"
    folder = os.path.dirname(os.path.abspath(_resolved(path)))
    while not os.path.isdir(folder):  # missing: write_atomic makes it, inside this one
        folder = os.path.dirname(folder)
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputError(path, f"cannot write: {folder} is not writable")


def file_stem(text: str) -> str:
    """A file stem made from ``text`` (a preset's name, which a downloaded file may carry) that
    names one file in a folder on any system.

    Separators, the characters Windows reserves (``<>:"|?*``) and control, format and other
    non-printable characters become ``_``; runs of dots become one, and dots and spaces at
    either end go (no ``..``, no hidden file); a Windows device name (``CON``, ``LPT1``) gets a
    ``_`` before it; the stem is cut to :data:`MAX_STEM_BYTES` bytes of UTF-8, and an empty one
    is :data:`DEFAULT_STEM`.
    """
    kept = "".join(
        "_" if char in _NOT_IN_NAMES or not (char.isprintable() or char == " ") else char
        for char in text
    )
    kept = _DOT_RUNS.sub(".", kept).strip(" .")
    if kept.split(".")[0].rstrip().upper() in _WINDOWS_DEVICES:
        kept = f"_{kept}"
    kept = kept.encode("utf-8")[:MAX_STEM_BYTES].decode("utf-8", "ignore").rstrip(" .")
    return kept or DEFAULT_STEM


def check_file_name(folder: str | os.PathLike[str], name: str) -> None:
    """Raise :class:`OutputError` unless ``name`` names a file directly inside ``folder``: no
    separator, not ``.`` or ``..``, no NUL."""
    base = os.path.abspath(folder)
    inside = os.path.dirname(os.path.abspath(os.path.join(base, name))) == base
    separators = {os.sep, os.altsep} - {None}
    if (
        not inside
        or name in ("", ".", "..")
        or "\0" in name
        or any(separator in name for separator in separators)
    ):
        raise OutputError(
            folder,
            f"refused to write {name!r}: allowed a file name inside this folder, without "
            "separators, '..' or NUL",
        )


def _temporary_prefix(name: str) -> str:
    return f".{name}."


def _temporary_name(name: str) -> str:
    return f"{_temporary_prefix(name)}{os.getpid()}-{secrets.token_hex(4)}{TEMP_SUFFIX}"


def _writer_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, OverflowError):  # OverflowError: past any process id
        return False
    except PermissionError:
        return True  # another user's live process
    return True


def remove_stray_temporaries(folder: str | os.PathLike[str], *names: str) -> int:
    """Remove temporary files for each of ``names`` in ``folder`` whose writing process is
    gone, listing the folder once.

    Returns how many were removed. Temporary files of live writers are left alone.
    """
    prefixes = tuple(_temporary_prefix(name) for name in names)
    removed = 0
    try:
        entries = os.listdir(folder)
    except OSError:
        return 0
    for entry in entries:
        prefix = max((p for p in prefixes if entry.startswith(p)), key=len, default=None)
        if prefix is None or not entry.endswith(TEMP_SUFFIX):
            continue
        pid_text = entry[len(prefix) : -len(TEMP_SUFFIX)].partition("-")[0]
        # isdigit() alone is true of "²", which int() refuses: ASCII digits only.
        if not (pid_text.isascii() and pid_text.isdigit()) or _writer_alive(int(pid_text)):
            continue
        with contextlib.suppress(OSError):
            os.unlink(os.path.join(folder, entry))
            removed += 1
    return removed


def _mode_for(target: str) -> int:
    try:
        return stat.S_IMODE(os.stat(target).st_mode)
    except OSError:
        return NEW_FILE_MODE


def _write_temporary(target: str, data: bytes) -> str:
    """``data`` in a new temporary file beside ``target``, on disk; returns its path."""
    folder, name = os.path.split(target)
    temporary = os.path.join(folder, _temporary_name(name))
    descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    try:
        with os.fdopen(descriptor, "wb") as stream:
            descriptor = -1
            stream.write(data)
            stream.flush()
            os.fsync(stream.fileno())
        os.chmod(temporary, _mode_for(target))
    except BaseException:
        if descriptor >= 0:
            os.close(descriptor)
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise
    return temporary


def _resolved(path: str | os.PathLike[str]) -> str:
    # Through a symlink, replace the file it points to rather than the link.
    return os.path.realpath(os.fspath(path))


def write_atomic(path: str | os.PathLike[str], data: bytes, *, make_folder: bool = False) -> None:
    """Replace ``path`` with ``data`` in one rename; the old file survives any failure.

    With ``make_folder``, missing folders on the way are created.

    Raises
    ------
    OutputError
        Naming ``path``: not a regular file, a missing folder, no space, no permission...
    """
    shown = os.fspath(path)
    target = _resolved(path)
    check_regular_target(target)
    folder, name = os.path.split(target)
    try:
        if make_folder:
            os.makedirs(folder, exist_ok=True)
        remove_stray_temporaries(folder, name)
        temporary = _write_temporary(target, data)
        try:
            os.replace(temporary, target)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(temporary)
            raise
    except OSError as error:
        raise _failed(shown, "write", error) from None
    _sync_folder(folder)


@contextlib.contextmanager
def _folder_lock(folder: str) -> Iterator[None]:
    """An exclusive lock on the folder itself (no lock file is left in it)."""
    if fcntl is None:  # pragma: no cover
        yield
        return
    descriptor = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX)
        yield
    finally:
        os.close(descriptor)  # closing releases the lock


def write_folder(folder: str | os.PathLike[str], files: Mapping[str, bytes]) -> None:
    """Write a set of files into ``folder`` (created if missing) as one unit.

    Under an exclusive lock on the folder, every file is first written to a temporary name and
    only then are they all renamed into place, in order (put the file that marks the set complete
    last): a failure while writing leaves the old files as they were, and two writers into one
    folder never mix their files.

    Raises
    ------
    OutputError
        Naming the file (or the folder) that could not be written.
    """
    shown = Path(folder)
    target = _resolved(folder)
    for name in files:
        check_file_name(shown, name)
    try:
        os.makedirs(target, exist_ok=True)
    except OSError as error:
        raise _failed(shown, "make the folder", error) from None
    for name in files:
        check_regular_target(os.path.join(target, name))
    current = os.fspath(shown)
    written: list[tuple[str, str]] = []
    try:
        with _folder_lock(target):
            remove_stray_temporaries(target, *files)
            for name, data in files.items():
                current = os.fspath(shown / name)
                final = os.path.join(target, name)
                written.append((_write_temporary(final, data), final))
            for temporary, final in written:
                current = os.fspath(shown / os.path.basename(final))
                os.replace(temporary, final)
            written.clear()
    except OSError as error:
        raise _failed(current, "write", error) from None
    finally:
        for temporary, _ in written:
            with contextlib.suppress(OSError):
                os.unlink(temporary)
    _sync_folder(target)


def _sync_folder(folder: str) -> None:
    # Makes the renames themselves durable on POSIX; folders cannot be opened so on Windows.
    with contextlib.suppress(OSError, AttributeError):
        descriptor = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(descriptor)
        finally:
            os.close(descriptor)
