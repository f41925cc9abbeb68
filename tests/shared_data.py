"""Where the real data sets are, and skip marks that name what is missing.

The data (WILDTRACK, MVOR) is not part of the repository: it lives in ``shared/data/<name>``
beside the repository (``../shared`` of a clone, as in CI) or in ``$GYMTRACK_DATA/<name>``. On
a clone without it the tests that need it skip, and the reason names the file they looked for.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def data_folder(name: str, marker: str) -> Path:
    """``$GYMTRACK_DATA/<name>``, else the first ``shared/data/<name>`` holding ``marker`` in a
    folder above the repository; else the expected place beside it (``../shared/data/<name>``)."""
    env = os.environ.get("GYMTRACK_DATA")
    if env:
        return Path(env) / name
    for parent in REPO.parents:
        if (parent / "shared" / "data" / name / marker).exists():
            return parent / "shared" / "data" / name
    return REPO.parent / "shared" / "data" / name


def needs_data(name: str, marker: str, what: str):
    """A skipif mark: skip unless ``data_folder(name, marker) / marker`` exists, naming it."""
    path = data_folder(name, marker) / marker
    return pytest.mark.skipif(
        not path.exists(),
        reason=f"{what}: {path} not found (put the data set in ../shared/data/{name} or set $GYMTRACK_DATA)",
    )


WILDTRACK = data_folder("wildtrack", "annotations_positions")
needs_wildtrack = needs_data("wildtrack", "annotations_positions", "needs the WILDTRACK data set")
