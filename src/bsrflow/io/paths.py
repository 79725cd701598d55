"""Output paths of the commands, checked before any work starts.

The rule, the same for every command (``bsrflow <command> --help`` and the README say it):

* an output **file** (``run --out``, ``--json``, ``init PATH``, ``sweep --out``/``--figure``):
  the folder that holds it must exist and be writable; the path must not be a directory or
  another non-regular file (a device, a pipe); an existing regular file must be writable (it
  is replaced);
* an output **directory** (``--figures``, ``plot --out``, ``demo --out``): created if it does
  not exist, but the folder that holds it must exist (one level is created, never a chain of
  missing folders); it must not be a file; it must be writable.

Missing parent folders are therefore refused everywhere, never created: a mistyped path fails
at once instead of scattering results into a new tree.

Writability is tested by creating (and removing) a probe file in the folder, not with
``os.access``, so read-only mounts, ``/proc`` and the like are caught also for root.

Both functions raise :class:`OutputPathError` (a ``ValueError``; the command line prints it as
one line, exit code 2) whose message starts with the option name.
"""

from __future__ import annotations

import errno
import os
import shutil
import stat
import tempfile

from .config import ConfigError

__all__ = ["OutputPathError", "check_output_file", "check_output_dir", "check_distinct", "check_free_space",
           "FILE_RULE", "DIR_RULE"]

FILE_RULE = "its folder must exist"
"""For ``--help`` texts of output-file options."""
DIR_RULE = "created if missing; the folder holding it must exist"
"""For ``--help`` texts of output-directory options."""


class OutputPathError(ConfigError):
    """An output path that cannot be written: ``str(err)`` is ``<option>: <problem>``."""


def _why(exc: OSError) -> str:
    if exc.errno == errno.ENOENT:          # /proc and similar: the file system takes no new files
        return "the file system does not accept new files"
    return exc.strerror or type(exc).__name__


def _check_folder(folder: str, option: str, target: str) -> None:
    """``folder`` (the one that will hold ``target``) exists, is a directory and is writable."""
    if not os.path.exists(folder):
        # the nearest existing ancestor tells whether the path runs through a file
        up = folder
        while up and not os.path.exists(up):
            nxt = os.path.dirname(up)
            if nxt == up:
                break
            up = nxt
        if up and os.path.exists(up) and not os.path.isdir(up):
            raise OutputPathError(option, f"{target}: {up} is a file, not a directory")
        raise OutputPathError(option, f"directory {folder} does not exist (missing folders are not "
                                      f"created; create it first, e.g. mkdir -p {folder})")
    if not os.path.isdir(folder):
        raise OutputPathError(option, f"{target}: {folder} is a file, not a directory")
    try:
        fd, probe = tempfile.mkstemp(prefix=".bsrflow-write-test-", dir=folder)
    except OSError as exc:
        raise OutputPathError(option, f"cannot write in the directory {folder} ({_why(exc)})") from None
    os.close(fd)
    try:
        os.remove(probe)
    except OSError:
        pass


SIDE_FILE_SUFFIX_ROOM = len(".ckpt.tmp") + 10
"""Characters the package may append to an output file's name for the files it writes beside
it (``<out>.ckpt``, the temporary ``<out>.tmp<pid>`` and ``<out>.ckpt.tmp<pid>`` of an atomic
write; a process id has at most 10 digits)."""


def _name_max(folder: str) -> int:
    """The longest file name the folder's file system takes (255 when it does not say)."""
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError, AttributeError):
        return 255


def check_output_file(path, option: str) -> str:
    """Check that ``path`` can be written as a file (module docstring); returns it as a string.
    ``option`` names the option in the message (``--out``, ``--json``, ...).  The file name must
    leave room for the files written beside it (:data:`SIDE_FILE_SUFFIX_ROOM` characters below the
    file system's longest name)."""
    path = os.fspath(path)
    if not path:
        raise OutputPathError(option, "empty path; give a file name")
    if os.path.isdir(path):
        raise OutputPathError(option, f"{path} is a directory; give a file name")
    name = os.path.basename(path)
    if os.path.isdir(os.path.dirname(os.path.abspath(path))):
        limit = _name_max(os.path.dirname(os.path.abspath(path))) - SIDE_FILE_SUFFIX_ROOM
        size = len(name.encode("utf-8", "surrogateescape"))
        if size > limit:
            raise OutputPathError(option, f"the file name is {size} bytes long (UTF-8); the valid range is 1 to "
                                          f"{limit} bytes here (the file system takes {limit + SIDE_FILE_SUFFIX_ROOM}, "
                                          f"and the checkpoint and temporary files beside it add up to "
                                          f"{SIDE_FILE_SUFFIX_ROOM})")
    if os.path.exists(path):
        mode = os.stat(path).st_mode
        if not stat.S_ISREG(mode):
            raise OutputPathError(option, f"{path} exists and is not a regular file; give a file name")
    folder = os.path.dirname(os.path.abspath(path))
    _check_folder(folder, option, path)
    if os.path.exists(path):
        try:
            fd = os.open(path, os.O_WRONLY)            # no truncation: only whether it opens
        except OSError as exc:
            raise OutputPathError(option, f"{path} cannot be overwritten ({_why(exc)})") from None
        os.close(fd)
    return path


def check_output_dir(path, option: str, create: bool = False) -> str:
    """Check that ``path`` can be used as an output directory (module docstring): an existing
    writable directory, or a missing one whose parent folder exists and is writable.
    ``create=True`` creates it (one level) right away.  Returns the path as a string."""
    path = os.fspath(path)
    if not path:
        raise OutputPathError(option, "empty path; give a directory")
    if os.path.exists(path):
        if not os.path.isdir(path):
            raise OutputPathError(option, f"{path} is a file; give a directory")
        _check_folder(os.path.abspath(path), option, path)
        return path
    _check_folder(os.path.dirname(os.path.abspath(path)), option, path)
    if create:
        try:
            os.mkdir(path)
        except FileExistsError:
            pass
        except OSError as exc:
            raise OutputPathError(option, f"cannot create the directory {path} ({_why(exc)})") from None
    return path


def check_distinct(*named) -> None:
    """Refuse two options that name the same place: ``named`` are (option, path or None) pairs,
    the outputs (and inputs that an output must not overwrite) of one command.  Checked before any
    path is created, so that ``--json x --figures x`` is refused up front rather than failing
    when the second is written."""
    seen: dict[str, str] = {}
    for option, path in named:
        if path is None or not os.fspath(path):
            continue
        key = os.path.realpath(os.path.abspath(os.fspath(path)))
        if key in seen:
            raise OutputPathError(option, f"{os.fspath(path)} is also given as {seen[key]}; give different paths")
        seen[key] = option


def _size(n: float) -> str:
    for unit in ("bytes", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} GiB"


def check_free_space(path, needed_bytes: int, option: str, what: str = "") -> None:
    """Refuse an output ``path`` of about ``needed_bytes`` that the free space of its folder
    cannot hold: :class:`OutputPathError` naming ``option``, the sizes and what the output
    holds (``what``), before anything is written."""
    folder = os.path.dirname(os.path.abspath(os.fspath(path)))
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        return                                      # no figure to check against: let the write tell
    if needed_bytes > free:
        held = f" ({what})" if what else ""
        raise OutputPathError(option, f"{os.fspath(path)} needs about {_size(needed_bytes)}{held} but "
                                      f"{folder} has {_size(free)} free; free some space, choose another "
                                      f"folder or save fewer snapshots")
