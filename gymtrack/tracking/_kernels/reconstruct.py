"""Compiled kernels of the triangulation stage (paper Section III-B, Eq. 3-4).

:func:`cluster_points` gathers the centre, top-centre and bottom-centre pixels of every cluster
and frame of a window, views-major, for Eq. 3 (:func:`gymtrack.geometry.primitives.triangulate_points`,
the same solver the public :func:`gymtrack.geometry.triangulation.triangulate` runs);
:func:`outliers` is Eq. 4 (:func:`outliers_at_mean`, ``cascade+``'s: the space test on the
mean position); :func:`opposite_clusters` and :func:`segments_of`: the cascade's (III-C)
two-view opposite clusters and the segments it hands the plane. Numpy references: ``tests/reference/reconstruct.py``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ...geometry.primitives import triangulate_points
from .sample import sample

_NAN = np.nan


@njit(cache=True)
def cluster_points(box, observed, members):
    """The pixels :func:`gymtrack.tracking.reconstruct.triangulate_clusters` triangulates and its observed-view
    counts: box (K, W, 4) segment boxes (NaN where not valid), observed (K, W), members (M, C)
    segment per cluster and camera (-1: none).

    Returns u, v (C, 3 M W) centre, top-centre and bottom-centre pixels, views-major (NaN
    where the camera has no member or the box is not valid), and n_views (M, W) int8.
    """
    M, C = members.shape
    W = box.shape[1]
    u = np.full((C, 3 * M * W), _NAN)
    v = np.full((C, 3 * M * W), _NAN)
    n_views = np.zeros((M, W), np.int8)
    for m in range(M):
        for c in range(C):
            k = members[m, c]
            if k < 0:
                continue
            for t in range(W):
                x, y, half = box[k, t, 0], box[k, t, 1], box[k, t, 3] / 2
                q = m * W + t
                for p in range(3):
                    u[c, p * M * W + q] = x
                v[c, q] = y
                v[c, M * W + q] = y - half
                v[c, 2 * M * W + q] = y + half
                if observed[k, t]:
                    n_views[m, t] += 1
    return u, v, n_views


@njit(cache=True, inline="always")
def too_fast(xyz, m, p, t, max_speed):
    """Eq. 4's speed test between valid points ``p < t`` of tracklet ``m``: further apart than
    ``max_speed`` metres per frame."""
    d0 = xyz[m, t, 0] - xyz[m, p, 0]
    d1 = xyz[m, t, 1] - xyz[m, p, 1]
    d2 = xyz[m, t, 2] - xyz[m, p, 2]
    return np.sqrt(d0 * d0 + d1 * d1 + d2 * d2) > max_speed * (t - p)


@njit(cache=True)
def outliers(xyz, valid, space, max_speed):
    """Eq. 4, :func:`gymtrack.tracking.reconstruct.outliers`: xyz (M, W, 3), valid (M, W), space (6,),
    max_speed (metres per frame) -> (M,) bool, True = outlier."""
    M, W = valid.shape
    bad = np.zeros(M, np.bool_)
    for m in range(M):
        any_valid = False
        p = -1
        for t in range(W):
            if not valid[m, t]:
                continue
            any_valid = True
            for q in range(3):
                x = xyz[m, t, q]
                if not (x >= space[q] and x <= space[3 + q]):
                    bad[m] = True
            if p >= 0 and too_fast(xyz, m, p, t, max_speed):
                bad[m] = True
            p = t
        if not any_valid:
            bad[m] = True
    return bad


@njit(cache=True)
def outliers_at_mean(xyz, valid, space, max_speed):
    """``cascade+``'s Eq. 4, :func:`gymtrack.tracking.reconstruct.outliers_at_mean`: the speed test
    on consecutive valid points, the tracking-space test on the mean of the valid points."""
    M, W = valid.shape
    bad = np.zeros(M, np.bool_)
    for m in range(M):
        n = 0
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        p = -1
        for t in range(W):
            if not valid[m, t]:
                continue
            n += 1
            s0 += xyz[m, t, 0]
            s1 += xyz[m, t, 1]
            s2 += xyz[m, t, 2]
            if p >= 0 and too_fast(xyz, m, p, t, max_speed):
                bad[m] = True
            p = t
        if n == 0:
            bad[m] = True
            continue
        c0, c1, c2 = s0 / n, s1 / n, s2 / n
        if not (c0 >= space[0] and c0 <= space[3] and c1 >= space[1] and c1 <= space[4]
                and c2 >= space[2] and c2 <= space[5]):
            bad[m] = True
    return bad


@njit(cache=True)
def opposite_clusters(members, opposite):
    """:func:`gymtrack.tracking.reconstruct.opposite_clusters`: members (M, C) int64, opposite
    (C, C) bool -> (M,) bool, clusters of exactly two views ``a``, ``b`` with ``opposite[a, b]``
    or ``opposite[b, a]``."""
    M, C = members.shape
    out = np.zeros(M, np.bool_)
    for m in range(M):
        a, b, n = -1, -1, 0
        for c in range(C):
            if members[m, c] >= 0:
                n += 1
                if a < 0:
                    a = c
                else:
                    b = c
        out[m] = n == 2 and (opposite[a, b] or opposite[b, a])
    return out


@njit(cache=True)
def segments_of(members, chosen):
    """The segments (sorted) of the clusters ``chosen`` (M,) bool; members (M, C) int64 (-1: none).
    The cascade's segments for the plane (III-C) and the floor's ghost pairs."""
    M, C = members.shape
    n = 0
    for m in range(M):
        if chosen[m]:
            for c in range(C):
                n += members[m, c] >= 0
    out = np.empty(n, np.int64)
    n = 0
    for m in range(M):
        if chosen[m]:
            for c in range(C):
                if members[m, c] >= 0:
                    out[n] = members[m, c]
                    n += 1
    return np.sort(out)


def warm_up() -> None:
    """Compile (or load) the kernels: the sample person triangulated from both views."""
    s = sample()
    u, v, n_views = cluster_points(s.box, s.observed, np.array([[0, 1]], np.int64))
    X, _ = triangulate_points(s.rig.arrays.P, u, v, np.isfinite(u), 1)
    xyz = np.ascontiguousarray(X.reshape(3, 3, 1, -1)[:, 0].transpose(1, 2, 0))
    outliers(xyz, np.isfinite(xyz).all(axis=2), np.array([-5.0, -5.0, 0.0, 5.0, 5.0, 3.0]), 0.5)
    outliers_at_mean(xyz, np.isfinite(xyz).all(axis=2), np.array([-5.0, -5.0, 0.0, 5.0, 5.0, 3.0]), 0.5)
    members = np.array([[0, 1], [-1, 2]], np.int64)
    opposite_clusters(members, np.ones((2, 2), bool))
    segments_of(members, np.ones(2, bool))
