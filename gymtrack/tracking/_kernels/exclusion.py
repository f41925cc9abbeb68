"""Compiled kernel of ``cascade+``'s duplicate suppression (beyond the paper; :mod:`..exclusion`).

:func:`too_close`: per final point, whether a point of an older track (smaller id) of the same
frame lies closer than the minimum separation -- one pass over each frame's points instead of
an (n, n) numpy matrix and its temporaries. The numpy code it replaces is
``tests/reference/exclusion.py``; the squared distance is summed in the reference's order, so
the answers are the same.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, error_model="numpy")
def too_close(frame, track_id, xyz, skip, min_sq):
    """frame, track_id (N,) int64, xyz (N, D), skip (N,) bool (points left out: neither tested
    nor compared with), min_sq: squared separation -> (N,) bool. NaN points are never close."""
    N, Dm = xyz.shape
    out = np.zeros(N, np.bool_)
    order = np.argsort(frame, kind="mergesort")
    a = 0
    while a < N:  # one run of equal frames at a time
        b = a + 1
        while b < N and frame[order[b]] == frame[order[a]]:
            b += 1
        for p in range(a, b):
            i = order[p]
            if skip[i]:
                continue
            for q in range(a, b):
                j = order[q]
                if skip[j] or not track_id[j] < track_id[i]:
                    continue
                d2 = 0.0
                for k in range(Dm):
                    d = xyz[i, k] - xyz[j, k]
                    d2 += d * d
                if d2 < min_sq:
                    out[i] = True
                    break
        a = b
    return out


@njit(cache=True, error_model="numpy")
def drop_close(frame, track_id, xyz, gone, min_sq):
    """:func:`too_close` with ``gone`` (N,) bool as ``skip``, and what the suppression drops:
    -> drop (N,) bool (``gone`` or too close), the number too close, the number dropped."""
    close = too_close(frame, track_id, xyz, gone, min_sq)
    drop = close | gone
    return drop, np.count_nonzero(close), np.count_nonzero(drop)


def warm_up() -> None:
    """Compile (or load) the kernel with the tracker's argument types."""
    i = np.array([0, 0], np.int64)
    too_close(i, np.array([0, 1], np.int64), np.zeros((2, 3)), np.zeros(2, np.bool_), 0.25)
    drop_close(i, np.array([0, 1], np.int64), np.zeros((2, 3)), np.zeros(2, np.bool_), 0.25)
