"""The output folder is the unit of safety: one command at a time per folder, and a full disk said in one line.

Paper: none; this is the project's rule for output folders (:mod:`gymtrack.formats.atomic`
writes them whole). Two commands writing one folder at once (``track`` replacing it while
``pose`` adds to it) would leave tracks of one run beside poses of the other, and a marker that
validates the mix. So every command that writes ``<out>`` (or reads it to write into it) holds
:func:`folder_lock` from its first read to its last write:

* the lock is ``flock(2)`` on a file beside the folder, ``.<name>.gymtrack-lock`` (beside, not
  inside: ``track`` replaces the folder whole). Writers hold it exclusively, readers (``eval``)
  shared. The file holds the writer's pid, command and start time, so a second command can name
  the holder; it waits up to ``wait`` seconds, then refuses with :class:`FolderBusy`.
* the operating system drops the lock of a process that died, so a stale lock file is simply
  taken over (and removed by whoever releases last).
* re-entrant within a thread: a command that holds the lock may open
  :func:`~gymtrack.formats.atomic.atomic_output` on the same folder, which takes it too.

:func:`disk_full_error` turns an ``ENOSPC``/``EDQUOT`` while writing into one
:class:`DiskFullError` line naming the folder, what was written and the free space.
"""

from __future__ import annotations

import datetime as _dt
import errno
import json
import os
import shutil
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator

from ..errors import GymtrackError, InputError

__all__ = ["FolderBusy", "DiskFullError", "folder_lock", "lock_path", "holder", "disk_full_error", "is_disk_full"]

_LOCK_TAG = ".gymtrack-lock"
_held = threading.local()  # resolved folder -> [fd, count, shared]


class FolderBusy(InputError):
    """Another command holds the output folder."""


class DiskFullError(GymtrackError):
    """The disk (or quota) filled while an output folder was written; nothing was replaced."""


def lock_path(out: str | Path) -> Path:
    """The lock file of output folder ``out``: ``.<name>.gymtrack-lock`` beside it."""
    out = Path(out).resolve()
    return out.parent / f".{out.name}{_LOCK_TAG}"


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True
    return True


def holder(out: str | Path) -> dict | None:
    """What the lock file of ``out`` says of its writer (pid, command, since), or None."""
    try:
        data = json.loads(lock_path(out).read_text() or "null")
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _describe(info: dict | None) -> str:
    if not info:
        return "another gymtrack command (a reader, or one just starting)"
    pid = info.get("pid")
    gone = "" if not isinstance(pid, int) or _pid_alive(pid) else "; that process has ended, a process it started may hold it"
    return f"pid {pid} (gymtrack {info.get('command', '?')}, since {info.get('since', '?')}{gone})"


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).strftime("%Y-%m-%d %H:%M:%S UTC")


def _same_file(fd: int, path: Path) -> bool:
    try:
        a, b = os.fstat(fd), os.stat(path)
    except OSError:
        return False
    return (a.st_ino, a.st_dev) == (b.st_ino, b.st_dev)


def _acquire(path: Path, command: str, shared: bool, wait: float, notify: Callable[[str], None] | None,
             out: Path) -> int:
    import fcntl

    deadline, told = time.monotonic() + max(float(wait), 0.0), False
    mode = fcntl.LOCK_SH if shared else fcntl.LOCK_EX
    while True:
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise InputError(f"cannot create the folder's lock file: {exc.strerror or exc}", source=path) from None
        try:
            fcntl.flock(fd, mode | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            info = holder(out)
            if time.monotonic() >= deadline:
                waited = f" (waited {wait:g} s)" if wait > 0 else ""
                raise FolderBusy(f"the output folder is in use by {_describe(info)}{waited}: wait for it to end, "
                                 "or give --wait SECONDS", source=out) from None
            if notify is not None and not told:
                notify(f"waiting for {out}: in use by {_describe(info)}")
                told = True
            time.sleep(0.1)
            continue
        if not _same_file(fd, path):  # removed (or replaced) by its last holder meanwhile: start again
            os.close(fd)
            continue
        if not shared:
            info = {"pid": os.getpid(), "command": command, "since": _now(), "argv": " ".join(sys.argv[1:3])}
            os.ftruncate(fd, 0)
            os.write(fd, json.dumps(info).encode())
        return fd


def _release(fd: int, path: Path) -> None:
    import fcntl

    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # a reader upgrades: only the last one removes the file
    except BlockingIOError:
        os.close(fd)
        return
    if _same_file(fd, path):
        try:
            os.unlink(path)
        except OSError:
            pass
    os.close(fd)


@contextmanager
def folder_lock(out: str | Path, command: str, wait: float = 0.0, shared: bool = False,
                notify: Callable[[str], None] | None = None) -> Iterator[None]:
    """Hold output folder ``out`` for ``command`` inside the block (exclusive; ``shared`` for readers).

    Waits up to ``wait`` seconds for another holder (``notify`` is told once, with its name), then
    raises :class:`FolderBusy` naming it (pid, command, since when). Re-entrant in one thread.
    """
    out = Path(out).resolve()
    held = getattr(_held, "folders", None)
    if held is None:
        held = _held.folders = {}
    if out in held:
        if held[out][2] and not shared:
            raise RuntimeError(f"{out}: a shared lock cannot be upgraded in place")
        held[out][1] += 1
        try:
            yield
        finally:
            held[out][1] -= 1
        return
    path = lock_path(out)
    if not path.parent.is_dir():
        raise InputError("the folder above it does not exist", source=out)
    fd = _acquire(path, command, shared, wait, notify, out)
    held[out] = [fd, 1, shared]
    try:
        yield
    finally:
        del held[out]
        _release(fd, path)


# ------------------------------------------------------------------ a full disk
def is_disk_full(exc: BaseException) -> bool:
    """True for the OSError of a full disk or an exhausted quota."""
    return isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT)


def _size(path: Path) -> int:
    total = 0
    for root, _, names in os.walk(path):
        for n in names:
            try:
                total += os.lstat(os.path.join(root, n)).st_size
            except OSError:
                pass
    return total


def _mb(n: int) -> str:
    return f"{n / 1e6:.1f} MB" if n >= 1e5 else f"{n / 1e3:.0f} kB"


def disk_full_error(out: Path, staging: Path | None, what: str = "the outputs") -> DiskFullError:
    """One-line error for a disk that filled while ``staging`` (the new outputs of ``out``) was written.

    Call it before the staging folder is removed: its size is what the run had written."""
    written = _size(staging) if staging is not None and staging.exists() else 0
    old = _size(out) if out.is_dir() else 0
    try:
        free = shutil.disk_usage(out.parent if not out.is_dir() else out).free
    except OSError:
        free = 0
    need = max(written, old)
    prev = f"; the previous outputs there take {_mb(old)}" if old else ""
    return DiskFullError(
        f"{out}: no space left on the device while writing {what}: they need more than {_mb(need)} "
        f"({_mb(written)} written when it filled{prev}); {_mb(free)} free. Free some space and run again")
