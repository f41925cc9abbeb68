"""Cross-view clustering of 2D tracklets (paper Section III-B, Eq. 1-2 and Algorithm 1).

Two pieces, both pure functions:

* :func:`tracklet_distances`: Eq. 2, the mean over the shared frames of the normalised
  symmetric epipolar distance of box centres (Eq. 1) between every pair of segments of a
  window, computed as one (K, K, W) tensor.
* :func:`complete_linkage`: Algorithm 1, complete-linkage agglomerative clustering in which an
  *unknown* distance (NaN: two tracklets that share no frame) does not block a merge, and an
  infinite one (two tracklets of one camera) always does. Reused for the plane candidates
  (Eq. 8).

Shared frames (the paper's ``Psi_i  cap  Psi_j``) are the frames where *both* segments were
actually observed: interpolated or extrapolated boxes would only repeat their neighbours'
evidence, and counting them would make disjoint tracklets look comparable. Two tracklets of
one camera never share a cluster (distance inf whether or not their frames overlap), so a
cluster has at most one segment per view; cut-off 2D tracks are repaired by cross-window
linking instead.
"""

from __future__ import annotations

import numpy as np

from ._kernels import clustering as kernels
from .types import WindowTracklets


def complete_linkage(D: np.ndarray, threshold: float) -> np.ndarray:
    """Algorithm 1: modified complete-linkage clustering.

    Parameters
    ----------
    D: (K, K) symmetric distances; NaN = unknown (no evidence either way), inf = forbidden.
        The diagonal is ignored.
    threshold: merge while some pair of clusters is strictly closer than this (lambda).

    Returns
    -------
    (K,) int cluster labels ``0 .. n-1``, numbered in order of each cluster's first member.

    Algorithm 1 merges the closest pair of clusters while it is closer than ``threshold``; the
    merged cluster's distance to a cluster ``q`` is ``max(D[i,q], D[j,q])`` when both are known,
    the known one when only one is, unknown when neither is -- exactly ``numpy.fmax``. Since
    ``max(x, inf) = inf`` a forbidden pair stays forbidden after any merge.

    The linkage is reducible (a merged distance is never below both of its members'
    distances, unknown counting as +inf), so merges happen in non-decreasing distance and
    every pair of reciprocal nearest neighbours merges eventually, independently of the
    others: each round merges all such pairs below the threshold at once (Murtagh's
    reciprocal-nearest-neighbour scheme). The clusters are those of the one-merge-at-a-time
    loop (``complete_linkage_sequential`` in ``tests/reference/clustering.py``, the literal
    reference; ties aside) in a
    handful of rounds instead of one round per merge. The rounds are compiled
    (:func:`._kernels.clustering.complete_linkage`): a window's K is a few tens, where numpy's per-call
    overhead would dominate.
    """
    return kernels.complete_linkage(np.ascontiguousarray(D, dtype=np.float64), float(threshold))


def tracklet_distances(segs: WindowTracklets, F: np.ndarray) -> np.ndarray:
    """Eq. 2: the cross-view distance of every pair of 2D tracklet segments of a window.

    Parameters
    ----------
    segs: K segments sorted by camera (as :func:`.windows.build_window` gives them); boxes in
        undistorted pixels.
    F: (C, C, 3, 3) fundamental matrices, ``F[i, j]`` maps points of view i to lines in view j
        (:func:`gymtrack.geometry.epipolar.fundamental_matrices`).

    Returns
    -------
    (K, K) distances: the mean over shared observed frames of Eq. 1 (dimensionless); NaN
    where two segments share no observed frame; inf for two segments of one camera.

    Cost: the epipolar line of every observed centre in every other view is computed once
    ((K, C, W) lines, :func:`gymtrack.geometry.epipolar.epipolar_lines`' convention), then each
    pair of segments of different views sums its point-line distances over the shared frames;
    both loops are compiled (:func:`._kernels.clustering.tracklet_distances`, on the Eq. 1
    primitives of :mod:`gymtrack.geometry.primitives`). The result equals
    :func:`gymtrack.geometry.epipolar.epipolar_distance` averaged over the shared frames.
    """
    if len(segs) == 0:
        return np.zeros((0, 0))
    return kernels.tracklet_distances(np.ascontiguousarray(segs.camera, dtype=np.int64),
                                      np.ascontiguousarray(segs.box, dtype=np.float64),
                                      np.ascontiguousarray(segs.observed), np.ascontiguousarray(F, dtype=np.float64))
