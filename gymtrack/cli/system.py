"""What a bug report needs (``gymtrack info --system``) and the first-compile notice.

Paper: none (support). The tracker's kernels (Section III, compiled with numba, ``cache=True``)
are compiled on the first run, 40-60 s; numba keeps the result in index (``*.nbi``) and data
files, by default in the ``__pycache__`` folders beside the package's modules, or under
``NUMBA_CACHE_DIR`` when set, or numba's user-wide cache folder when the package is read-only.
:func:`numba_cache` scans those places generically (the kernels may move between modules) and
:func:`compile_notice` says when no index file is there yet.
"""

from __future__ import annotations

import hashlib
import os
import platform
import sys
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

#: Expected duration of the first compile, for the notice.
FIRST_COMPILE = "about 40-60 s"


@dataclass(frozen=True)
class NumbaCache:
    """Where numba caches the package's kernels and how many index files are there."""

    locations: tuple[Path, ...]
    index_files: int

    @property
    def warm(self) -> bool:
        return self.index_files > 0


def _package_dir() -> Path:
    return Path(__file__).resolve().parents[1]


def _cache_roots() -> list[Path]:
    """Folders numba may keep a module's cache under, besides its ``__pycache__``: ``NUMBA_CACHE_DIR``
    when set, else numba's user-wide cache folder (used when the package folder is read-only)."""
    env = os.environ.get("NUMBA_CACHE_DIR")
    if env:
        return [Path(env)]
    try:
        from numba.misc.appdirs import AppDirs

        return [Path(AppDirs(appname="numba", appauthor=False).user_cache_dir)]
    except Exception:  # numba's layout may change; the in-tree caches are then all we check
        return []


def numba_cache() -> NumbaCache:
    """The cache folders numba uses for this package's modules and the ``*.nbi`` files in them.

    Every package folder ``d`` is looked at (the kernels may move between modules): its
    ``__pycache__``, and ``<root>/<d.name>_<sha1 of d's path>`` under each cache root, which is
    how numba names a module's folder under ``NUMBA_CACHE_DIR`` or its user-wide cache.
    """
    pkg = _package_dir()
    folders = [pkg] + sorted(p for p in pkg.rglob("*") if p.is_dir() and (p / "__init__.py").is_file())
    roots = _cache_roots()
    candidates: list[Path] = []
    for d in folders:
        if not os.environ.get("NUMBA_CACHE_DIR"):
            candidates.append(d / "__pycache__")
        candidates += [r / f"{d.name}_{hashlib.sha1(str(d).encode()).hexdigest()}" for r in roots]
    found = {c: sum(1 for _ in c.glob("*.nbi")) for c in candidates if c.is_dir()}
    used = tuple(sorted(c for c, n in found.items() if n))
    if not used:  # cold: say where the cache will go
        used = (tuple(roots) if os.environ.get("NUMBA_CACHE_DIR")
                else (pkg / "tracking" / "_kernels" / "__pycache__", pkg / "geometry" / "__pycache__"))
    return NumbaCache(used, sum(found.values()))


def compile_notice() -> str | None:
    """A one-line notice when the kernels have not been compiled yet, else None."""
    cache = numba_cache()
    if cache.warm:
        return None
    where = ", ".join(str(p) for p in cache.locations[:2])
    return (f"first run: compiling the tracking kernels with numba, {FIRST_COMPILE} (once; cached in {where})")


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "not installed"


def system_rows() -> list[tuple[str, str]]:
    """(what, value) rows of ``gymtrack info --system``."""
    from gymtrack.version import version as gymtrack_version

    rows = [
        ("gymtrack", f"{gymtrack_version()} ({_package_dir()})"),  # as `gymtrack --version` says
        ("python", f"{platform.python_version()} ({sys.executable})"),
        ("platform", platform.platform()),
    ]
    for dist in ("numpy", "scipy", "numba", "llvmlite", "opencv-python", "opencv-python-headless", "pydantic", "typer", "rich"):
        v = _version(dist)
        if v != "not installed" or dist in ("numpy", "numba", "opencv-python"):
            rows.append((dist, v))
    try:
        import cv2

        rows.append(("cv2 (imported)", cv2.__version__))
    except ImportError:
        rows.append(("cv2 (imported)", "cannot import"))
    cache = numba_cache()
    rows.append(("numba cache", ", ".join(str(p) for p in cache.locations)))
    rows.append(("numba cache index files", f"{cache.index_files} ({'compiled' if cache.warm else 'cold: the next run compiles, ' + FIRST_COMPILE})"))
    for var in ("NUMBA_CACHE_DIR", "NUMBA_NUM_THREADS", "NUMBA_DISABLE_JIT"):
        if os.environ.get(var):
            rows.append((var, os.environ[var]))
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    rows.append(("CPUs", f"{os.cpu_count()} ({usable} usable by this process)"))
    return rows
