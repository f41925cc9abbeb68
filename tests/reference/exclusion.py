"""Numpy reference of cascade+'s duplicate-suppression kernel (beyond the paper;
gymtrack/tracking/_kernels/exclusion.py): tracking.exclusion.too_close before it was compiled."""

from __future__ import annotations

import numpy as np

from gymtrack.errors import InputError

MIN_SEPARATION = 0.5
DENSE = 400  #: up to this many points all pairs are compared in one (n, n) matrix


def too_close_numpy(frame: np.ndarray, track_id: np.ndarray, xyz: np.ndarray, min_separation: float = MIN_SEPARATION
              ) -> np.ndarray:
    """(N,) bool: the points (frame (N,), track_id (N,), xyz (N, 3)) closer than ``min_separation``
    to a point of an older track (smaller id) in the same frame. NaN points are never close."""
    if not min_separation > 0:
        raise InputError(f"min_separation must be a positive number of metres, got {min_separation!r}",
                         field="min_separation")
    n = len(frame)
    out = np.zeros(n, bool)
    if n < 2:
        return out
    if n <= DENSE:  # every pair at once: a few numpy calls (the usual case, a few frames of people)
        d2 = np.zeros((n, n))
        for k in range(xyz.shape[1]):
            diff = xyz[:, k][:, None] - xyz[:, k][None, :]
            d2 += diff * diff
        with np.errstate(invalid="ignore"):
            hit = (d2 < min_separation * min_separation) & (frame[:, None] == frame[None, :])
        hit &= track_id[None, :] < track_id[:, None]
        return hit.any(axis=1)
    for f in np.unique(frame):  # a long stretch (the end of a stream): frame by frame
        at = np.flatnonzero(frame == f)
        out[at] = too_close_numpy(frame[at], track_id[at], xyz[at], min_separation)
    return out
