"""Compiled kernel of the window stage: filling a window's missing boxes (paper Section III-A).

:func:`fill_missing` interpolates between observed frames and holds the first / last box for
at most ``max_extrapolate`` frames (see :mod:`gymtrack.tracking.windows`); its numpy
reference is ``tests/reference/windows.py``. Shapes: box (K, W, 4), observed (K, W).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .sample import sample

_NAN = np.nan


@njit(cache=True)
def fill_missing(box, observed, max_extrapolate):
    """:func:`gymtrack.tracking.windows.build_window`'s filling: box (K, W, 4), observed (K, W) bool ->
    (filled (K, W, 4) NaN where not valid, valid (K, W) bool)."""
    K, W = observed.shape
    filled = box.copy()
    valid = observed.copy()
    prev = np.empty(W, np.int64)
    nxt = np.empty(W, np.int64)
    for k in range(K):
        p = -1
        for t in range(W):
            if observed[k, t]:
                p = t
            prev[t] = p
        n = W
        for t in range(W - 1, -1, -1):
            if observed[k, t]:
                n = t
            nxt[t] = n
        for t in range(W):
            if observed[k, t]:
                continue
            p, n = prev[t], nxt[t]
            hasp, hasn = p >= 0, n < W
            inside = hasp and hasn
            ok = inside or ((not hasp) and n - t <= max_extrapolate) or ((not hasn) and t - p <= max_extrapolate)
            valid[k, t] = ok
            if not ok:
                for q in range(4):
                    filled[k, t, q] = _NAN
                continue
            lo = p if hasp else n
            hi = n if hasn else p
            a = (t - lo) / max(hi - lo, 1) if inside else 0.0
            for q in range(4):
                filled[k, t, q] = box[k, lo, q] * (1.0 - a) + box[k, hi, q] * a
    return filled, valid



def warm_up() -> None:
    """Compile (or load) the kernel on the sample scene's window."""
    s = sample()
    fill_missing(s.box, s.observed, 2)
