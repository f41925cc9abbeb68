"""Simulating a suite: the grid apparatus x routine x n_cam written as routine folders.

Paper: Section IV-A evaluates 20 routines per apparatus, each with ``n_cam`` = 2, 3 and 4 valid
views; :func:`simulate_suite` makes such a grid (``<out>/<apparatus>/ncam<n>/r<k>/``) with a
seed per routine from :func:`routine_seed`, so a routine is the same performance for every n_cam.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Sequence

import numpy as np

from ..apparatus import APPARATUS_NAMES
from ..errors import InputError
from .routine import check_args, simulate_n_cams
from .venue import CAMERA_NAMES

__all__ = ["routine_seed", "simulate_suite"]


def routine_seed(base_seed: int, apparatus: str, k: int) -> int:
    """The seed of routine ``k`` of ``apparatus`` in a suite made with ``base_seed``."""
    a = APPARATUS_NAMES.index(apparatus)
    return int(np.random.SeedSequence([int(base_seed), a, int(k)]).generate_state(1, np.uint32)[0])


def simulate_suite(out: str | Path, per_apparatus: int, seconds: float | None = None, seed: int = 0,
                   apparatus: Sequence[str] | None = None, n_cams: Sequence[int] = (2, 3, 4), plot: bool = False,
                   progress=None) -> list[dict]:
    """Simulate the grid apparatus x routine x n_cam and write it under ``out``.

    Layout: ``<out>/<apparatus>/ncam<n>/r<k>/`` (a routine folder each) and ``<out>/suite.json``
    listing every routine (path relative to ``out``, apparatus, n_cam, seed, seconds, frames).
    Routine ``k`` of an apparatus has the seed :func:`routine_seed` (``seed``, apparatus, k) and is
    the same performance for every n_cam; ``gymtrack simulate --seed <that seed>`` reproduces it.
    ``progress(entry)`` is called after each routine is written.
    """
    names = list(APPARATUS_NAMES if apparatus is None else apparatus)
    if per_apparatus < 1:
        raise InputError(f"per_apparatus must be at least 1, got {per_apparatus}", field="per_apparatus")
    for n in n_cams:
        check_args(names[0] if names else "vault", n, 0, None)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    entries = []
    for name in names:
        for k in range(per_apparatus):
            rs = routine_seed(seed, name, k)
            _, _, rs, secs = check_args(name, None, rs, seconds)
            for n, sim in simulate_n_cams(name, rs, secs, n_cams).items():
                rel = Path(name) / f"ncam{n}" / f"r{k}"
                sim.write(out / rel, plot=plot)
                entry = {"path": rel.as_posix(), "apparatus": name, "n_cam": n, "seed": rs, "seconds": secs, "frames": sim.n_frames,
                         "target_views": [c for c, v in zip(CAMERA_NAMES, sim.target_views) if v]}
                entries.append(entry)
                if progress is not None:
                    progress(entry)
    index = {"base_seed": int(seed), "per_apparatus": int(per_apparatus), "seconds": seconds, "n_cams": list(n_cams),
             "layout": "<apparatus>/ncam<n>/r<k>", "routines": entries}
    (out / "suite.json").write_text(json.dumps(index, indent=1) + "\n")
    return entries
