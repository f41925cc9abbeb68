"""Compiled kernel of cross-window linking (paper Section III-B, Eq. 10).

:func:`link_distances`: the mean 3D distance of every pair of tracklets of two consecutive
windows over their overlap; numpy reference in ``tests/reference/linking.py``.
Shapes: xyz (M, W, 3), valid (M, W).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .sample import WIDTH, sample

_NAN = np.nan


@njit(cache=True, error_model="numpy")
def link_distances(prev_xyz, prev_valid, new_xyz, new_valid, offset):
    """Eq. 10, :func:`gymtrack.tracking.linking.link_distances`: (Mp, W, 3), (Mp, W), (Mn, W, 3), (Mn, W) and
    the step -> (Mp, Mn) metres, NaN where no valid frame is shared."""
    Mp, W = prev_valid.shape
    Mn = new_valid.shape[0]
    Wo = W - offset
    D = np.empty((Mp, Mn))
    for i in range(Mp):
        for j in range(Mn):
            s = 0.0
            n = 0
            for t in range(Wo):
                if prev_valid[i, offset + t] and new_valid[j, t]:
                    d0 = prev_xyz[i, offset + t, 0] - new_xyz[j, t, 0]
                    d1 = prev_xyz[i, offset + t, 1] - new_xyz[j, t, 1]
                    d2 = prev_xyz[i, offset + t, 2] - new_xyz[j, t, 2]
                    s += np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                    n += 1
            D[i, j] = s / n if n > 0 else _NAN
    return D



def warm_up() -> None:
    """Compile (or load) the kernel on the sample person's track, linked to itself."""
    s = sample()
    xyz = np.ascontiguousarray(s.xyz[None])
    valid = np.ones((1, WIDTH), bool)
    link_distances(xyz, valid, xyz, valid, WIDTH // 2)
