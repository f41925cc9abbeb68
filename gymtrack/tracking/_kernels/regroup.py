"""Compiled kernel of ``cascade+``'s regrouping (:mod:`gymtrack.tracking.regroup`): a dropped
cluster's mutually nearest opposite pairs by Eq. 2 (paper Section III-C's cascade, given a second
chance). Runs on every window: one call instead of a dozen numpy calls (numpy reference:
``tests/reference/regroup.py``)."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def regroup_pairs(tested, kept, D2, camera, opposite, cut):
    """tested (M, C), kept (M', C) int64 members (-1: none); D2 (K, K) Eq. 2; camera (K,) int64;
    opposite (C, C) bool; cut: Eq. 2's threshold. Returns (K,) int64 group labels: 0, or for the
    two segments of a pair 1 + the smaller segment index; a pair is two dropped segments (in a
    cluster of ``tested``, none of ``kept``) of opposite views, each the other's nearest opposite-view
    segment of the window below ``cut`` (the first of equal distances, as numpy's argmin)."""
    K = camera.shape[0]
    groups = np.zeros(K, np.int64)
    if kept.shape[0] == tested.shape[0]:  # nothing dropped
        return groups
    dropped = np.zeros(K, np.bool_)
    for m in range(tested.shape[0]):
        for c in range(tested.shape[1]):
            if tested[m, c] >= 0:
                dropped[tested[m, c]] = True
    for m in range(kept.shape[0]):
        for c in range(kept.shape[1]):
            if kept[m, c] >= 0:
                dropped[kept[m, c]] = False
    mate = np.full(K, -1, np.int64)
    for i in range(K):
        if not dropped[i]:
            continue
        best = cut
        for j in range(K):
            if opposite[camera[i], camera[j]] and D2[i, j] < best:
                best = D2[i, j]
                mate[i] = j
    for i in range(K):
        j = mate[i]
        if j >= 0 and dropped[j] and mate[j] == i:
            groups[i] = 1 + min(i, j)
    return groups


@njit(cache=True)
def regroup_step(tested, kept, D2, camera, opposite, cut, to_plane, floor_only):
    """The tracker's step (:func:`gymtrack.tracking.regroup.regroup`) in one call: :func:`regroup_pairs`,
    then ``to_plane`` (sorted int64) with the pairs' segments, ``floor_only`` without them, and the
    fresh pairs' segments (those not in ``floor_only``). Returns groups, the pairs' segments (sorted),
    to_plane, floor_only, fresh; the inputs themselves when there is no pair."""
    groups = regroup_pairs(tested, kept, D2, camera, opposite, cut)
    K = camera.shape[0]
    n = 0
    for k in range(K):
        n += groups[k] > 0
    seg = np.empty(n, np.int64)
    if n == 0:
        return groups, seg, to_plane, floor_only, seg
    take = np.zeros(K, np.bool_)
    ghost = np.zeros(K, np.bool_)
    for k in to_plane:
        take[k] = True
    for k in floor_only:
        ghost[k] = True
    i = n_take = n_fresh = 0
    for k in range(K):
        if groups[k] > 0:
            seg[i] = k
            i += 1
            take[k] = True
            n_fresh += not ghost[k]
        n_take += take[k]
    plane = np.empty(n_take, np.int64)
    fresh = np.empty(n_fresh, np.int64)
    i = j = 0
    for k in range(K):
        if take[k]:
            plane[i] = k
            i += 1
        if groups[k] > 0 and not ghost[k]:
            fresh[j] = k
            j += 1
    n_floor = 0
    for k in floor_only:
        n_floor += groups[k] == 0
    floor = np.empty(n_floor, np.int64)
    i = 0
    for k in floor_only:  # (floor_only: the ghost test's segments; a regrouped one may go to the plane too)
        if groups[k] == 0:
            floor[i] = k
            i += 1
    return groups, seg, plane, floor, fresh


def warm_up() -> None:
    """Compile (or load) the kernel with the tracker's argument types."""
    m = np.array([[0, 1]], np.int64)
    args = (m, np.zeros((0, 2), np.int64), np.zeros((2, 2)), np.array([0, 1], np.int64), np.ones((2, 2), np.bool_), 0.3)
    regroup_pairs(*args)
    regroup_step(*args, np.zeros(0, np.int64), np.zeros(0, np.int64))
