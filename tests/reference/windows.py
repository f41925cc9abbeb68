"""Numpy reference of the window stage's filling (paper Section III-A): the kernel
:func:`gymtrack.tracking._kernels.windows.fill_missing` must give exactly this."""

from __future__ import annotations

import numpy as np


def fill_missing(box: np.ndarray, observed: np.ndarray, max_extrapolate: int) -> tuple[np.ndarray, np.ndarray]:
    """Interpolate / extrapolate the missing boxes of K segments at once.

    box: (K, W, 4) boxes, anything where not observed; observed: (K, W) bool, each row with at
    least one True; max_extrapolate: frames the first/last box is held beyond the observations.

    Returns (filled (K, W, 4) with NaN where not valid, valid (K, W) bool).
    """
    K, W = observed.shape
    t = np.arange(W)
    prev = np.maximum.accumulate(np.where(observed, t, -1), axis=1)  # last observed index <= t
    nxt = np.minimum.accumulate(np.where(observed, t, W)[:, ::-1], axis=1)[:, ::-1]  # first observed >= t
    # observed frames keep their box; only the missing ones (a minority) are computed, as flat indices
    filled = box.copy()
    valid = observed.copy()
    miss = np.flatnonzero(~observed)
    if len(miss):
        p, n = prev.ravel()[miss], nxt.ravel()[miss]
        tm = miss % W
        hasp, hasn = p >= 0, n < W
        inside = hasp & hasn
        ok = inside | (~hasp & (n - tm <= max_extrapolate)) | (~hasn & (tm - p <= max_extrapolate))
        lo = np.where(hasp, p, n)  # 'before' frames hold the first box
        hi = np.where(hasn, n, p)  # 'after' frames hold the last box
        a = np.where(inside, (tm - lo) / np.maximum(hi - lo, 1), 0.0)[:, None]  # inside: hi - lo >= 2
        flat = box.reshape(K * W, 4)
        row = miss - tm
        vals = flat[row + lo] * (1.0 - a) + flat[row + hi] * a
        vals[~ok] = np.nan
        filled.reshape(K * W, 4)[miss] = vals
        valid.ravel()[miss] = ok
    return filled, valid


