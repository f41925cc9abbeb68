"""Compiled kernel of ``cascade+``'s superseded window estimates (beyond the paper;
:func:`gymtrack.tracking.records.superseded`).

:func:`superseded`: which window estimates lost every member detection of their frame to a later
window's track -- one pass over the members sorted by detection and one binary search per
estimate instead of two ``np.isin`` and a dozen other numpy calls per window. The numpy code it
replaces is ``tests/reference/records.py``; the answer is a yes / no per estimate, the same.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, error_model="numpy")
def superseded(frame, track_id, window, det, m_frame, m_track, m_window, order):
    """Estimates frame, track_id, window (n,); members det, m_frame, m_track, m_window (m,) and
    ``order`` (m,): the members by detection, the latest window first. -> (n,) bool."""
    n, m = len(frame), len(det)
    out = np.zeros(n, np.bool_)
    if n == 0 or m == 0:
        return out
    kept = np.empty(m, np.bool_)  # the member's detection went to its own track
    changed = False
    p = 0
    while p < m:  # one detection at a time: the latest window's track wins it
        q = p + 1
        while q < m and det[order[q]] == det[order[p]]:
            q += 1
        winner = m_track[order[p]]
        for r in range(p, q):
            kept[order[r]] = m_track[order[r]] == winner
            if r > p and m_track[order[r]] != m_track[order[r - 1]]:
                changed = True
        p = q
    if not changed:  # no detection changed track: nothing superseded
        return out
    span = max(window.max(), m_window.max()) + 1
    tspan = max(track_id.max(), m_track.max()) + 1
    key = (m_frame * tspan + m_track) * span + m_window
    by_key = np.argsort(key)
    sorted_key = key[by_key]
    for i in range(n):
        k = (frame[i] * tspan + track_id[i]) * span + window[i]
        a = np.searchsorted(sorted_key, k)
        if a == m or sorted_key[a] != k:
            continue  # no member detection in its frame: never superseded
        lost = True
        while a < m and sorted_key[a] == k:
            if kept[by_key[a]]:
                lost = False
                break
            a += 1
        out[i] = lost
    return out


def warm_up() -> None:
    """Compile (or load) the kernel with the tracker's argument types."""
    i = np.array([5, 5], np.int64)
    t = np.array([7, 9], np.int64)
    w = np.array([0, 1], np.int64)
    superseded(i, t, w, np.array([1, 1], np.int64), i, t, w, np.array([1, 0], np.int64))
