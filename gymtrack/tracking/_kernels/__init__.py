"""Compiled (numba) kernels of the tracker's small per-frame and per-window loops, one module per stage.

Paper: no method of its own; these are the hot loops of Section III-A (:mod:`.single_view`,
:mod:`.windows`), III-B (:mod:`.clustering`: Eq. 2, Algorithm 1; :mod:`.reconstruct`: Eq. 3-4;
:mod:`.linking`: Eq. 10-12, cascade+'s link by 2D tracks), III-C (:mod:`.plane`: Eq. 5-9; :mod:`.floor`: ``cascade+``'s floor, Eq. 5-9 on z = 0; :mod:`.fusion`: ``cascade+``'s ray-plane fusion;
:mod:`.exclusion`: ``cascade+``'s duplicate suppression, :mod:`.regroup`: its dropped clusters' opposite pairs, :mod:`.records`: its superseded estimates) and the venue check (:mod:`.drift`: the residuals of a knocked or late camera) and III-D (:mod:`.target`: Eq. 14),
and ``cascade+``'s motion-predicting per-view tracker (:mod:`.single_view_motion`),
written as plain loops over the scalar primitives of :mod:`gymtrack.geometry.primitives`.
The arrays of one frame or window are small (tens of boxes, tracklets of 10 frames), so
numpy's per-call overhead dominated the vectorised versions; each kernel replaces a dozen or
more numpy calls by one call.

Every kernel computes what its numpy reference in ``tests/reference/`` computes (the tests
compare them on random inputs): the same comparisons, tie-breaking and NaN rules, so
identifiers and counts never change; floating-point results are the same up to rounding where
the reference sums in a different order (matrix products).

Compiled with ``cache=True`` (later processes load the machine code from numba's cache, next
to these files or in ``NUMBA_CACHE_DIR``). Each module's ``warm_up`` compiles or loads its
kernels by running them on a tiny real scene (:mod:`.sample`); :func:`warm_up` runs them all
(and the loops of the public geometry API the MvPT baseline uses), once per process. The
:class:`~gymtrack.tracking.tracker.Tracker` calls it when it is constructed, so that
compilation is never counted as tracking time.

numba's cache notices edits of a kernel's own file only; these kernels inline the primitives of
:mod:`gymtrack.geometry.primitives` and read :mod:`gymtrack.geometry.arrays`, and the plane
kernel calls the clustering one. :func:`drop_stale_cache` (run on import) deletes the cached
kernels older than any of those files, so that an edit there is never run as stale machine code.
(A cache outside the source tree, ``NUMBA_CACHE_DIR``, is not checked: clear it by hand.)
"""

from __future__ import annotations

import gc
from pathlib import Path

from ...geometry import arrays, primitives


def drop_stale_cache() -> int:
    """Delete the cached kernels (``__pycache__/*.nbi``, ``*.nbc`` beside these files) older than
    the newest file they depend on; returns how many files were deleted."""
    here = Path(__file__).parent
    deps = [Path(primitives.__file__), Path(arrays.__file__), *here.glob("*.py")]
    try:
        newest = max(p.stat().st_mtime for p in deps)
        stale = [p for p in (here / "__pycache__").glob("*.nb[ic]") if p.stat().st_mtime < newest]
        for p in stale:
            p.unlink()
    except OSError:  # a read-only install: nothing is edited there
        return 0
    return len(stale)


drop_stale_cache()

from . import (clustering, drift, exclusion, floor, fusion, linking, plane, reconstruct, records,  # noqa: E402
               regroup, single_view, single_view_motion, target, windows)  # (after the check)

_WARM = False


def warm_up() -> None:
    """Compile (or load from numba's cache) every kernel with the argument types the tracker
    uses; once per process, a few milliseconds when cached."""
    global _WARM
    if _WARM:
        return
    for module in (single_view, single_view_motion, windows, clustering, reconstruct, linking, exclusion, records, plane, floor, fusion, target,
                   drift, regroup, primitives):
        module.warm_up()
    # a full collection now, not during the first tracking call: after a first compile Python's
    # collector has the compiler's many objects to walk (a demo's first mode ran at 1/3 speed)
    gc.collect()
    _WARM = True
