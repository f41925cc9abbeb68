"""gymtrack's version: the installed package's metadata, else the source's own number.

Rule: every output names the version that wrote it (the marker of :mod:`gymtrack.formats.atomic`,
``summary.json``) and ``gymtrack --version`` prints it. Core (no gymtrack import), so every layer
may ask. :data:`SOURCE_VERSION` is kept equal to ``pyproject.toml``'s (a test checks).
"""

from __future__ import annotations

__all__ = ["SOURCE_VERSION", "version"]

SOURCE_VERSION = "0.1.0"


def version() -> str:
    """The installed distribution's version; the source's when gymtrack runs from a checkout
    that is not installed (``PYTHONPATH``) or is installed at another version (the code running is
    the checkout's)."""
    from importlib import metadata
    from pathlib import Path

    try:
        dist = metadata.distribution("gymtrack")
    except metadata.PackageNotFoundError:
        return SOURCE_VERSION
    # an installed copy elsewhere (not this source tree) does not say what is running here
    try:
        here = Path(__file__).resolve().parent
        files = [f for f in (dist.files or []) if f.name == "version.py" and f.parent.name == "gymtrack"]
        if files and Path(dist.locate_file(files[0])).resolve().parent != here:
            return SOURCE_VERSION
    except (OSError, TypeError, ValueError):
        pass
    return dist.version
