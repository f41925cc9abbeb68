"""numpy reference of :func:`gymtrack.tracking._kernels.regroup.regroup_pairs` (the tracker's
``regroup``: a dropped cluster's mutually nearest opposite pairs, by Eq. 2)."""

import numpy as np


def regroup_pairs_numpy(tested: np.ndarray, kept: np.ndarray, D2: np.ndarray, camera: np.ndarray, opposite: np.ndarray,
                  cut: float) -> tuple[np.ndarray, np.ndarray | None]:
    """The opposite pairs among the segments of the clusters that Eq. 4 and the ghost test dropped.

    tested: (M, C) members of the clusters before the tests (-1: none); kept: (M', C) those after
    them; D2: (K, K) Eq. 2 distances of the window's segments; camera: (K,) their views;
    opposite: (C, C) bool, the opposite camera pairs; cut: Eq. 2's threshold (``cluster_2d``).
    Returns the pairs' segments (sorted) and (K,) group labels for the plane stage (0: any
    segment; a pair: its own label), None when there is no pair. (Masks, not set operations:
    this runs on every window.)"""
    none = np.zeros(0, np.int64)
    if len(kept) == len(tested):  # nothing dropped
        return none, None
    K = len(camera)
    dropped = np.zeros(K, bool)
    dropped[tested[tested >= 0]] = True
    dropped[kept[kept >= 0]] = False
    seg = np.flatnonzero(dropped)
    if len(seg) < 2:
        return none, None
    # each dropped segment's nearest opposite-view segment of the whole window by Eq. 2, and that one's
    d = np.where(opposite[camera[seg]][:, camera] & (D2[seg] < cut), D2[seg], np.inf)
    mate = d.argmin(axis=1)
    ok = np.isfinite(d[np.arange(len(seg)), mate]) & dropped[mate]
    if not ok.any():
        return none, None
    seg, mate = seg[ok], mate[ok]
    back = np.where(opposite[camera[mate]][:, camera] & (D2[mate] < cut), D2[mate], np.inf).argmin(axis=1)
    pair = back == seg  # nearest both ways, both dropped
    if not pair.any():
        return none, None
    groups = np.zeros(K, np.int64)
    groups[seg[pair]] = 1 + np.minimum(seg, mate)[pair]
    return seg[pair], groups
