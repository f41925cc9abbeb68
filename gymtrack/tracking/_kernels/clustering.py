"""Compiled kernels of the cross-view clustering (paper Section III-B, Eq. 1-2, Algorithm 1).

:func:`tracklet_distances` is Eq. 2 over a window's segments, built on the Eq. 1 primitives of
:mod:`gymtrack.geometry.primitives`; :func:`complete_linkage` is Algorithm 1 in reciprocal-
nearest-neighbour rounds (also used for the plane candidates, Eq. 8). Numpy references:
``tests/reference/clustering.py``. Shapes: camera (K,) int64, box (K, W, 4), observed (K, W),
F (C, C, 3, 3), D (K, K).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ...geometry.epipolar import fundamental_matrices
from ...geometry.primitives import epipolar_line, line_distance, scaled_centre
from .sample import sample

_NAN = np.nan


@njit(cache=True, inline="always")
def fmax(x, y):
    """``np.fmax`` of two scalars: NaN only if both are NaN."""
    if x != x:
        return y
    if y != y:
        return x
    return x if x >= y else y


@njit(cache=True, error_model="numpy")
def tracklet_distances(camera, box, observed, F):
    """Eq. 2, :func:`gymtrack.tracking.clustering.tracklet_distances`: camera (K,) int64, box (K, W, 4),
    observed (K, W) bool, F (C, C, 3, 3) -> (K, K) (NaN: no shared frame; inf: same camera)."""
    K, W = observed.shape
    C = F.shape[0]
    xh = np.zeros((K, W, 3))
    for k in range(K):
        for t in range(W):
            if observed[k, t]:
                xh[k, t, 0], xh[k, t, 1], xh[k, t, 2] = scaled_centre(box[k, t, 0], box[k, t, 1], box[k, t, 2],
                                                                      box[k, t, 3])
    # lines[k, c, t]: epipolar line in view c of segment k's centre at frame t, unit normal
    lines = np.zeros((K, C, W, 3))
    for k in range(K):
        ck = camera[k]
        for c in range(C):
            if c == ck:
                continue
            for t in range(W):
                if not observed[k, t]:
                    continue
                lines[k, c, t, 0], lines[k, c, t, 1], lines[k, c, t, 2] = epipolar_line(
                    F, ck, c, xh[k, t, 0], xh[k, t, 1], xh[k, t, 2])
    D = np.empty((K, K))
    for i in range(K):
        D[i, i] = np.inf
        for j in range(i + 1, K):
            if camera[i] == camera[j]:
                D[i, j] = np.inf
                D[j, i] = np.inf
                continue
            ci, cj = camera[i], camera[j]
            s = 0.0
            n = 0
            for t in range(W):
                if observed[i, t] and observed[j, t]:
                    n += 1
                    # centre of j against the line of i in view cj, and the other way round
                    s += line_distance(xh[j, t, 0], xh[j, t, 1], xh[j, t, 2],
                                       lines[i, cj, t, 0], lines[i, cj, t, 1], lines[i, cj, t, 2])
                    s += line_distance(xh[i, t, 0], xh[i, t, 1], xh[i, t, 2],
                                       lines[j, ci, t, 0], lines[j, ci, t, 1], lines[j, ci, t, 2])
            v = s / n if n > 0 else _NAN
            D[i, j] = v
            D[j, i] = v
    return D


@njit(cache=True)
def number_by_first_member(owner):
    """(K,) cluster representatives -> labels
    0..n-1 in order of each cluster's first member."""
    K = owner.shape[0]
    first = np.full(K, K, np.int64)
    for i in range(K):
        o = owner[i]
        if i < first[o]:
            first[o] = i
    label_of = np.full(K, -1, np.int64)
    labels = np.empty(K, np.int64)
    n = 0
    for i in range(K):
        f = first[owner[i]]
        if label_of[f] < 0:
            label_of[f] = n
            n += 1
        labels[i] = label_of[f]
    return labels


NO_GROUP = np.zeros(0, np.int64)  #: no person ids (the method's own association)
NO_APART = np.zeros((0, 0), bool)  #: no pairs known apart


@njit(cache=True)
def constraints(idx, D2, cut, person):
    """Algorithm 1's constraints for the segments ``idx`` (K,) int64 of a window: ``apart`` (K, K)
    bool, pairs Eq. 2 says are different people (``D2`` (N, N) >= ``cut``; (0, 0): none, gives
    :data:`NO_APART`), and ``group`` (K,) their person ids (``person`` (N,); (0,): none, gives
    :data:`NO_GROUP`)."""
    K = len(idx)
    apart = NO_APART
    if D2.shape[0] > 0:
        apart = np.empty((K, K), np.bool_)
        for i in range(K):
            for j in range(K):
                apart[i, j] = D2[idx[i], idx[j]] >= cut
    group = NO_GROUP
    if person.shape[0] > 0:
        group = person[idx]
    return apart, group


@njit(cache=True)
def complete_linkage(D, threshold):
    """Algorithm 1, :func:`gymtrack.tracking.clustering.complete_linkage` (the same reciprocal-nearest-neighbour
    rounds, ties and NaN / inf rules): D (K, K) float64 -> (K,) labels."""
    K = D.shape[0]
    S = D.copy()
    owner = np.arange(K)
    if K < 2:
        return number_by_first_member(owner)
    for i in range(K):
        S[i, i] = _NAN
    nn = np.empty(K, np.int64)
    d = np.empty(K)
    I = np.empty(K, np.int64)
    while True:
        for i in range(K):  # nearest neighbour; unknown (NaN) counts as +inf; ties: first
            best, bj = np.inf, 0
            for j in range(K):
                x = S[i, j]
                if x == x and x < best:
                    best, bj = x, j
            nn[i] = bj
            d[i] = best
        m = 0
        for i in range(K):
            j = nn[i]
            if nn[j] == i and i < j and d[i] < threshold:
                I[m] = i
                m += 1
        if m == 0:
            best, bi = d[0], 0
            for i in range(1, K):
                if d[i] < best:
                    best, bi = d[i], i
            if not best < threshold:
                break
            I[0] = bi
            m = 1
        for a in range(m):  # rows, then columns (fmax is order-independent)
            i, j = I[a], nn[I[a]]
            for q in range(K):
                S[i, q] = fmax(S[i, q], S[j, q])
        for a in range(m):
            i, j = I[a], nn[I[a]]
            for q in range(K):
                S[q, i] = fmax(S[q, i], S[q, j])
        for a in range(m):
            i, j = I[a], nn[I[a]]
            for q in range(K):
                S[j, q] = _NAN
                S[q, j] = _NAN
        for a in range(m):
            S[I[a], I[a]] = _NAN
        relabel = np.arange(K)
        for a in range(m):
            relabel[nn[I[a]]] = I[a]
        for q in range(K):
            owner[q] = relabel[owner[q]]
    return number_by_first_member(owner)



def warm_up() -> None:
    """Compile (or load) the kernels on the sample scene's window."""
    s = sample()
    D = tracklet_distances(s.camera, s.box, s.observed, fundamental_matrices(s.rig))
    complete_linkage(D, 0.3)
