"""Numpy reference of cascade+'s superseded-estimates kernel (beyond the paper;
gymtrack/tracking/_kernels/records.py): tracking.records.superseded before it was compiled."""

from __future__ import annotations

import numpy as np


def superseded_numpy(frame: np.ndarray, track_id: np.ndarray, window: np.ndarray, members,
               order: np.ndarray | None = None) -> np.ndarray:
    """(n,) bool: estimates (frame, track_id, window) (n,) that had member detections in their
    frame and lost all of them to another track (each detection goes to the latest window's
    track, as in :meth:`WindowRecords.boxes`). Estimates without detections in their frame
    (interpolated or held boxes) are never superseded. ``order``: ``np.lexsort((-window, det))``
    of the members when the caller has it."""
    det, win, tid = members.det, members.window, members.track_id
    if not len(det) or not len(frame):
        return np.zeros(len(frame), bool)
    if order is None:
        order = np.lexsort((-win, det))  # per detection, the latest window first
    d = det[order]
    first = np.ones(len(d), bool)
    np.not_equal(d[1:], d[:-1], out=first[1:])
    t = tid[order]
    if not np.any(~first[1:] & (t[1:] != t[:-1])):  # no detection changed track: nothing superseded
        return np.zeros(len(frame), bool)
    winner = np.repeat(t[first], np.diff(np.append(np.flatnonzero(first), len(d))))
    kept = np.empty(len(det), bool)
    kept[order] = winner == t
    # per (frame, track, window) of the members: does any member detection still belong to it?
    span = int(max(window.max(), win.max())) + 1
    tspan = int(max(track_id.max(), tid.max())) + 1
    key_m = (members.frame * tspan + tid) * span + win
    key_e = (frame * tspan + track_id) * span + window
    has = np.isin(key_e, key_m)
    return has & ~np.isin(key_e, key_m[kept])
