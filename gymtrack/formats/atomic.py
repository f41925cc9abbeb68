"""Atomic output folders: a run either leaves its complete outputs or the previous ones, never a mix.

Paper: none directly; this is how the outputs of the tracker of Section III (and of the pose
stage) reach the disk. Every command that writes an output folder goes through it:

* :func:`atomic_output` (``gymtrack track``, batch runs): the outputs are written into a staging
  folder beside ``out`` (``.<name>.gymtrack-tmp-<pid>-<random>``), a marker file
  :data:`MARKER` is added last, and the staging folder then takes the place of ``out`` in one
  ``renameat2(RENAME_EXCHANGE)`` (Linux; elsewhere two renames). A previous gymtrack output is
  replaced whole (no stale per-camera files); a non-empty folder that is not a gymtrack output
  is only replaced with ``overwrite=True``. On any exception (including Ctrl-C) the staging
  folder is removed and ``out`` is left as it was; the exception gets a note saying so.
* :func:`atomic_update` (``gymtrack pose``): adds or replaces files and folders inside a
  complete output folder: they are written to a staging folder inside ``out``, each moved into
  place with a rename, and the marker is rewritten (temp file + rename) last.

Checks (:func:`check_output_folder`) run when the context is entered, so a command opens it
before any work and a bad ``--out`` fails in a second, with a one-line
:class:`~gymtrack.errors.InputError`. Staging folders left by a killed run (dead pid) are
removed the next time.

The marker (JSON): ``{"gymtrack_output": 1, "command", "version", "created" (UTC ISO time),
"inputs": {name: value}, "files": {relative path: sha256}, "updates": [{"command", "version",
"time", "inputs", "files": [relative paths]}]}``.
"""

from __future__ import annotations

import ctypes
import datetime as _dt
import hashlib
import json
import os
import shutil
import signal
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

from .. import interrupts
from ..errors import InputError
from .folder_lock import disk_full_error, folder_lock, is_disk_full

#: The marker file that identifies a complete gymtrack output folder.
MARKER = ".gymtrack-output.json"
_TMP_TAG = ".gymtrack-tmp-"


# ------------------------------------------------------------------ marker
def read_marker(folder: str | Path) -> dict | None:
    """The marker of ``folder`` as a dict, or None when there is none (or it is not valid JSON)."""
    p = Path(folder) / MARKER
    try:
        data = json.loads(p.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and data.get("gymtrack_output") else None


def is_gymtrack_output(folder: str | Path) -> bool:
    """True when ``folder`` holds a complete gymtrack output (a valid marker)."""
    return read_marker(folder) is not None


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat().replace("+00:00", "Z")


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _files(folder: Path) -> list[Path]:
    """Regular files under ``folder`` (relative, sorted), leaving out the marker and staging folders."""
    out = []
    for root, dirs, names in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if _TMP_TAG not in d)
        rel = Path(root).relative_to(folder)
        out += [rel / n for n in sorted(names) if n != MARKER]
    return sorted(out)


def checksums(folder: str | Path) -> dict[str, str]:
    """Relative path (posix) -> sha256 of every file of an output folder but the marker."""
    folder = Path(folder)
    return {p.as_posix(): _sha256(folder / p) for p in _files(folder)}


def _write_json_atomic(path: Path, data: Mapping) -> None:
    tmp = path.with_name(path.name + f".tmp-{os.getpid()}")
    with open(tmp, "w") as fh:
        fh.write(json.dumps(data, indent=2) + "\n")
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def _jsonable(inputs: Mapping[str, Any] | None) -> dict:
    return {str(k): (v if isinstance(v, (int, float, bool, type(None))) else str(v)) for k, v in (inputs or {}).items()}


# ------------------------------------------------------------------ renames
def _exchange(a: Path, b: Path) -> bool:
    """Swap two existing paths atomically (Linux ``renameat2(RENAME_EXCHANGE)``); False when the
    platform or file system cannot."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd, rename_exchange = -100, 2
    if fn(at_fdcwd, os.fsencode(str(a)), at_fdcwd, os.fsencode(str(b)), rename_exchange) == 0:
        return True
    return False


def _swap_in(new: Path, dest: Path) -> Path | None:
    """Put folder ``new`` at ``dest``; returns where the previous ``dest`` now is (to delete), or None."""
    if not dest.exists():
        os.rename(new, dest)
        return None
    if _exchange(new, dest):
        return new
    # Fallback (no RENAME_EXCHANGE): a short moment without ``dest``; the old one is kept aside.
    aside = dest.with_name(f".{dest.name}{_TMP_TAG}{os.getpid()}-old")
    os.rename(dest, aside)
    os.rename(new, dest)
    return aside


@contextmanager
def _no_sigint() -> Iterator[None]:
    """Hold SIGINT back while renames run (a Ctrl-C then lands after them, not between)."""
    if hasattr(signal, "pthread_sigmask"):
        try:
            old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        except (ValueError, OSError):
            old = None
        try:
            yield
        finally:
            if old is not None:
                signal.pthread_sigmask(signal.SIG_SETMASK, old)
    else:  # pragma: no cover
        yield


def _folder_mode(folder: Path, like: Path | None) -> None:
    """Give a ``mkdtemp`` folder (0700) the mode of ``like``, or the usual one under the umask."""
    if like is not None:
        mode = like.stat().st_mode & 0o7777
    else:
        umask = os.umask(0)
        os.umask(umask)
        mode = 0o777 & ~umask
    os.chmod(folder, mode)


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _remove_stale(folder: Path, prefix: str) -> None:
    """Remove staging folders ``<prefix><pid>-...`` in ``folder`` whose process is gone."""
    try:
        entries = list(folder.iterdir())
    except OSError:
        return
    for p in entries:
        if not p.name.startswith(prefix):
            continue
        pid = p.name[len(prefix):].split("-", 1)[0]
        if pid.isdigit() and not _pid_alive(int(pid)):
            shutil.rmtree(p, ignore_errors=True) if p.is_dir() else p.unlink(missing_ok=True)


# ------------------------------------------------------------------ checks
def check_output_folder(out: str | Path, overwrite: bool = False, protect: Sequence[str | Path] = ()) -> Path:
    """Check that ``out`` can take a new output folder; returns its absolute path.

    Raises InputError (naming ``out``) when it is a file, a non-empty folder that is not a
    gymtrack output (without ``overwrite``), read-only, its parent cannot be created or
    written, or it is (or holds) one of the ``protect`` paths (the inputs of the run).
    """
    out = Path(out).resolve()
    for p in protect:
        p = Path(p).resolve()
        if p == out or out in p.parents:
            raise InputError(f"--out would replace {p}, an input of this run; choose another folder", source=out)
    if out.exists() and not out.is_dir():
        raise InputError("--out exists and is not a folder", source=out)
    if out.is_dir():
        if not os.access(out, os.W_OK | os.X_OK):
            raise InputError("--out is not writable (permission denied)", source=out)
        try:
            non_empty = any(True for _ in out.iterdir())
        except OSError as exc:
            raise InputError(f"--out cannot be read: {exc.strerror}", source=out) from None
        if non_empty and not is_gymtrack_output(out) and not overwrite:
            raise InputError(
                f"--out is a non-empty folder that is not a gymtrack output (no {MARKER}); choose another folder "
                "or pass --overwrite to replace its contents", source=out,
            )
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        above = next((p for p in out.parents if p.exists()), out.parent)
        raise InputError("is a file, not a folder: --out cannot be created below it", source=above) from None
    except OSError as exc:
        raise InputError(f"cannot create the folder above --out: {exc.strerror or exc}", source=out.parent) from None
    if not os.access(out.parent, os.W_OK | os.X_OK):
        raise InputError("cannot write beside --out (permission denied on its parent folder)", source=out.parent)
    return out


def _untouched(exc, out: Path, existed: bool):
    """``exc`` (a one-line error) with what happened to ``out`` added to its message."""
    what = "the previous outputs are untouched" if existed else "nothing was written"
    exc.args = (f"{exc.args[0]}; {what}",)
    return exc


def _untouched_note(exc: BaseException, out: Path, existed: bool) -> None:
    what = f"the previous contents of {out} are untouched" if existed else f"nothing was written to {out}"
    if hasattr(exc, "add_note"):
        exc.add_note(f"no outputs written: {what}")


# ------------------------------------------------------------------ whole folder
@contextmanager
def atomic_output(
    out: str | Path, command: str, inputs: Mapping[str, Any] | None = None, overwrite: bool = False,
    protect: Sequence[str | Path] = (),
) -> Iterator[Path]:
    """Write a whole output folder atomically; yields the staging folder to write into.

    Enter it before any work: it checks ``out`` (:func:`check_output_folder`) and creates the
    staging folder beside it (so an unwritable place fails at once). On a normal exit the marker
    is written and the staging folder replaces ``out``; on an exception nothing changes at ``out``.
    ``protect``: input paths ``out`` must not be or contain.
    """
    out = check_output_folder(out, overwrite, protect)
    with folder_lock(out, command):
        with _atomic_output(out, command, inputs) as staging:
            yield staging


@contextmanager
def _atomic_output(out: Path, command: str, inputs: Mapping[str, Any] | None) -> Iterator[Path]:
    prefix = f".{out.name}{_TMP_TAG}"
    _remove_stale(out.parent, prefix)
    try:
        staging = Path(tempfile.mkdtemp(prefix=f"{prefix}{os.getpid()}-", dir=out.parent))
    except OSError as exc:
        if is_disk_full(exc):
            raise disk_full_error(out, None) from None
        raise InputError(f"cannot write beside --out: {exc.strerror or exc}", source=out.parent) from None
    existed, swapped, old = out.exists(), False, None
    _folder_mode(staging, out if existed else None)
    try:
        yield staging
        marker = {
            "gymtrack_output": 1, "command": command, "version": _version(), "created": _now(),
            "inputs": _jsonable(inputs), "files": checksums(staging), "updates": [],
        }
        _write_json_atomic(staging / MARKER, marker)
        interrupts.check()  # a Ctrl-C swallowed on its way (numba, a callback) still keeps the old outputs
        with _no_sigint():
            old = _swap_in(staging, out)
            swapped = True
            interrupts.record_outcome(f"the new outputs were complete and are in {out}")
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException as exc:
        if not swapped:
            full = disk_full_error(out, staging) if is_disk_full(exc) else None
            shutil.rmtree(staging, ignore_errors=True)
            if full is not None:
                raise _untouched(full, out, existed) from None
            _untouched_note(exc, out, existed)
        else:  # interrupted right after the swap: the new outputs are in place
            if old is not None:
                shutil.rmtree(old, ignore_errors=True)
            if hasattr(exc, "add_note"):
                exc.add_note(f"the new outputs were complete and are in {out}")
        raise


# ------------------------------------------------------------------ adding to a folder
@contextmanager
def atomic_update(out: str | Path, command: str, inputs: Mapping[str, Any] | None = None) -> Iterator[Path]:
    """Add or replace files and folders inside the complete gymtrack output ``out``.

    Yields a staging folder (inside ``out``); every top-level file or folder written there then
    replaces its namesake in ``out`` (one rename each; folders swapped whole), and the marker is
    rewritten last with the new checksums and an entry in ``updates``. On an exception ``out``
    is left as it was.
    """
    out = Path(out).absolute()
    marker = read_marker(out)
    if not out.is_dir() or marker is None:
        raise InputError(f"not a complete gymtrack output folder (no {MARKER}); run `gymtrack track` into it first", source=out)
    if not os.access(out, os.W_OK | os.X_OK):
        raise InputError("the output folder is not writable (permission denied)", source=out)
    with folder_lock(out, command):
        with _atomic_update(out, command, inputs, marker) as staging:
            yield staging


@contextmanager
def _atomic_update(out: Path, command: str, inputs: Mapping[str, Any] | None, marker: dict) -> Iterator[Path]:
    _remove_stale(out, _TMP_TAG)
    try:
        staging = Path(tempfile.mkdtemp(prefix=f"{_TMP_TAG}{os.getpid()}-", dir=out))
    except OSError as exc:
        if is_disk_full(exc):
            raise _untouched(disk_full_error(out, None, f"the {command} outputs"), out, True) from None
        raise InputError(f"cannot write into the output folder: {exc.strerror or exc}", source=out) from None
    _folder_mode(staging, None)
    try:
        yield staging
        entries = sorted(p.name for p in staging.iterdir())
        new_sums = checksums(staging)
        interrupts.check()
        with _no_sigint():
            for name in entries:
                src, dest = staging / name, out / name
                if src.is_dir():
                    old = _swap_in(src, dest)
                    if old is not None:
                        shutil.rmtree(old, ignore_errors=True)
                else:
                    if dest.is_dir():
                        shutil.rmtree(dest)
                    os.replace(src, dest)
            files = {k: v for k, v in marker.get("files", {}).items() if k.split("/", 1)[0] not in entries}
            files.update(new_sums)
            marker["files"] = dict(sorted(files.items()))
            marker.setdefault("updates", []).append(
                {"command": command, "version": _version(), "time": _now(), "inputs": _jsonable(inputs),
                 "files": sorted(new_sums)}
            )
            _write_json_atomic(out / MARKER, marker)
            interrupts.record_outcome(f"the {command} outputs were complete and are in {out}")
    except BaseException as exc:
        if is_disk_full(exc):
            full = disk_full_error(out, staging, f"the {command} outputs")
            shutil.rmtree(staging, ignore_errors=True)
            full.args = (f"{full.args[0]}; its marker still lists what it holds",)
            raise full from None
        if hasattr(exc, "add_note"):
            exc.add_note(f"the {command} outputs were not (all) added to {out}; its marker still lists what it holds")
        raise
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _version() -> str:
    """gymtrack's version (:func:`gymtrack.version.version`: the metadata, else the source's)."""
    from ..version import version

    return version()


# ------------------------------------------------------------------ which routine
def check_routine(out: str | Path, routine: str | Path, force: bool = False) -> None:
    """Refuse (InputError naming both paths) to use output folder ``out`` with ``routine`` when its
    marker records another routine; ``force`` skips the check. A marker without a routine (a
    demo) passes; one that records only a folder name (a batch run) is compared by name."""
    marker = read_marker(out)
    recorded = (marker or {}).get("inputs", {}).get("routine")
    if force or not recorded:
        return
    given = Path(routine).resolve()
    rec = Path(str(recorded))
    same = rec.resolve() == given if rec.is_absolute() else rec.name == given.name
    if not same:
        raise InputError(f"was made from the routine {rec}, not {given}: give the routine it was made from, "
                         "or --force to use it anyway", source=Path(out).absolute())
