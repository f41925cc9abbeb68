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

from . import _compiled
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
    loop (:func:`complete_linkage_sequential`, kept as the literal reference; ties aside) in a
    handful of rounds instead of one round per merge. The rounds are compiled
    (:func:`._compiled.complete_linkage`): a window's K is a few tens, where numpy's per-call
    overhead would dominate.
    """
    return _compiled.complete_linkage(np.ascontiguousarray(D, dtype=np.float64), float(threshold))


def _number_by_first_member(owner: np.ndarray) -> np.ndarray:
    """(K,) cluster representatives (any member index) -> labels 0..n-1 in order of each
    cluster's first member (table lookups: cheaper than np.unique and two argsorts)."""
    K = len(owner)
    idx = np.arange(K)
    first = np.full(K, K)
    np.minimum.at(first, owner, idx)  # first member of each representative's cluster
    is_first = first[owner] == idx
    return (np.cumsum(is_first) - 1)[first[owner]]


def complete_linkage_sequential(D: np.ndarray, threshold: float, merges: list | None = None) -> np.ndarray:
    """Algorithm 1 literally, one merge per step (the closest pair, ties: first in row-major
    order). Same inputs and labels as :func:`complete_linkage`; slower, kept as the reference.

    merges: if a list is given, each merge is appended as ``(i, j, distance)``: the clusters are
    named by their smallest original member (``j`` joins ``i``)."""
    S = np.array(D, dtype=np.float64)
    K = S.shape[0]
    owner = np.arange(K)
    if K >= 2:
        np.fill_diagonal(S, np.nan)
        while True:
            W = np.where(np.isnan(S), np.inf, S)
            i, j = divmod(int(np.argmin(W)), K)
            if not W[i, j] < threshold:
                break
            if merges is not None:
                merges.append((int(i), int(j), float(W[i, j])))
            merged = np.fmax(S[i], S[j])
            S[i], S[:, i] = merged, merged
            S[j], S[:, j] = np.nan, np.nan
            S[i, i] = np.nan
            owner[owner == j] = i
    return _number_by_first_member(owner)


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
    both loops are compiled (:func:`._compiled.tracklet_distances`). The result equals
    :func:`gymtrack.geometry.epipolar.epipolar_distance` averaged over the shared frames.
    """
    if len(segs) == 0:
        return np.zeros((0, 0))
    return _compiled.tracklet_distances(np.ascontiguousarray(segs.camera, dtype=np.int64),
                                        np.ascontiguousarray(segs.box, dtype=np.float64),
                                        np.ascontiguousarray(segs.observed), np.ascontiguousarray(F, dtype=np.float64))
