"""Numpy reference of the linking kernel (paper Section III-B, Eq. 10)."""

from __future__ import annotations

import numpy as np


def link_distances_numpy(prev_xyz, prev_valid, new_xyz, new_valid, offset):
    Wo = prev_xyz.shape[1] - offset
    a, av = prev_xyz[:, offset:], prev_valid[:, offset:]
    b, bv = new_xyz[:, :Wo], new_valid[:, :Wo]
    both = av[:, None] & bv[None]
    d = np.linalg.norm(a[:, None] - b[None], axis=-1)
    n = both.sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        D = np.where(both, d, 0.0).sum(axis=-1) / n
    D[n == 0] = np.nan
    return D
