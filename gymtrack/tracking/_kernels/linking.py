"""Compiled kernel of cross-window linking (paper Section III-B, Eq. 10).

:func:`link_distances`: the mean 3D distance of every pair of tracklets of two consecutive
windows over their overlap; numpy reference in ``tests/reference/linking.py``.
Shapes: xyz (M, W, 3), valid (M, W).

:func:`link_by_2d`: ``cascade+``'s floor tracklets continuing their 2D tracks' track,
one loop instead of a few numpy calls per floor tracklet; numpy reference ``tests/reference/linking.py``.

:func:`merge_overlaps`: Eq. 12, one point per (frame, track) from the window estimates covering
it (with ``cascade+``'s ``best_only``, beyond the paper) -- one stable sort and one pass
over the groups instead of some twenty numpy calls per window; numpy reference
``tests/reference/linking.py``. Sums are taken in numpy's ``add.reduceat`` order (the first
estimate plus the sum of the others), so the points are bit-identical for groups of up to 8
estimates (a (frame, track) has one per window covering it: 2 at the default window and step).
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


@njit(cache=True, error_model="numpy")
def merge_overlaps(frame, track_id, xyz, top_z, bottom_z, source, n_views, best_only):
    """Eq. 12, :func:`gymtrack.tracking.linking.merge_overlaps`: rows (N,) (``xyz`` (N, 3)), N > 0
    -> frame, track_id (G,), xyz (G, 3), top_z, bottom_z (G,), source, n_views (G,) int8, one row
    per (frame, track), sorted by (frame, track_id)."""
    n = len(frame)
    lo = track_id.min()
    key = (frame - frame.min()) * (track_id.max() - lo + 1) + (track_id - lo)
    order = np.argsort(key, kind="mergesort")  # stable, as the reference's
    G = 1
    for r in range(1, n):
        if key[order[r]] != key[order[r - 1]]:
            G += 1
    o_frame = np.empty(G, frame.dtype)
    o_track = np.empty(G, track_id.dtype)
    o_xyz = np.empty((G, 3))
    o_top = np.empty(G)
    o_bottom = np.empty(G)
    o_source = np.empty(G, np.int8)
    o_views = np.empty(G, np.int8)
    p = 0
    g = 0
    while p < n:
        q = p + 1
        while q < n and key[order[q]] == key[order[p]]:
            q += 1
        strong_only = False  # best_only: a group with an over-determined triangulation keeps only those
        if best_only and q - p > 1:
            for r in range(p, q):
                i = order[r]
                if source[i] == 0 and n_views[i] >= 3:
                    strong_only = True
                    break
        i0 = -1
        cnt = 0
        rx, ry, rz, rt, rb = -0.0, -0.0, -0.0, -0.0, -0.0  # the others' sums (reduceat's order)
        nt, nb = 0.0, 0.0
        ft, fb = 0.0, 0.0
        src, nv = 0, 0
        for r in range(p, q):
            i = order[r]
            if strong_only and not (source[i] == 0 and n_views[i] >= 3):
                continue
            t = top_z[i] if np.isfinite(top_z[i]) else 0.0
            b = bottom_z[i] if np.isfinite(bottom_z[i]) else 0.0
            if i0 < 0:
                i0 = i
                ft, fb = t, b
                src, nv = source[i], n_views[i]
            else:
                rx += xyz[i, 0]
                ry += xyz[i, 1]
                rz += xyz[i, 2]
                rt += t
                rb += b
                src = min(src, source[i])
                nv = max(nv, n_views[i])
            nt += np.isfinite(top_z[i])
            nb += np.isfinite(bottom_z[i])
            cnt += 1
        o_frame[g] = frame[i0]
        o_track[g] = track_id[i0]
        if cnt == 1:  # one estimate: itself (heights as the reference's 0 / 0 where unknown)
            o_xyz[g, 0], o_xyz[g, 1], o_xyz[g, 2] = xyz[i0, 0], xyz[i0, 1], xyz[i0, 2]
        else:
            o_xyz[g, 0] = (xyz[i0, 0] + rx) / cnt
            o_xyz[g, 1] = (xyz[i0, 1] + ry) / cnt
            o_xyz[g, 2] = (xyz[i0, 2] + rz) / cnt
        o_top[g] = (ft + rt) / nt
        o_bottom[g] = (fb + rb) / nb
        o_source[g] = src
        o_views[g] = nv
        g += 1
        p = q
    return o_frame, o_track, o_xyz, o_top, o_bottom, o_source, o_views

@njit(cache=True, error_model="numpy")
def link_by_2d(rows, members, track2d, prev_2d, prev_owner, ids):
    """``cascade+``'s link by 2D tracks (:meth:`gymtrack.tracking.linking.WindowLinker._link_by_2d`,
    beyond the paper): each tracklet ``rows`` (r,) in order, ``members`` (M, C), whose
    2D tracks (``track2d`` (K,)) are all in ``prev_2d`` (n,) under one ``prev_owner`` (n,) continues
    that track unless ``ids`` (M,) already holds it (written into ``ids``). Returns the links made."""
    links = 0
    C = members.shape[1]
    for m in rows:
        n_t2 = 0
        for c in range(C):
            if members[m, c] >= 0:
                n_t2 += 1
        count, owner, same = 0, -1, True
        for p in range(len(prev_2d)):  # the previous window's entries of these 2D tracks
            hit = False
            for c in range(C):
                if members[m, c] >= 0 and track2d[members[m, c]] == prev_2d[p]:
                    hit = True
                    break
            if hit:
                if count == 0:
                    owner = prev_owner[p]
                elif prev_owner[p] != owner:
                    same = False
                count += 1
        if count == n_t2 and count > 0 and same:
            taken = False
            for i in range(len(ids)):
                if ids[i] == owner:
                    taken = True
                    break
            if not taken:
                ids[m] = owner
                links += 1
    return links


def warm_up() -> None:
    """Compile (or load) the kernel on the sample person's track, linked to itself."""
    s = sample()
    xyz = np.ascontiguousarray(s.xyz[None])
    valid = np.ones((1, WIDTH), bool)
    link_distances(xyz, valid, xyz, valid, WIDTH // 2)
    f = np.array([3, 3, 4], np.int64)
    ids = np.full(2, -1, np.int64)
    link_by_2d(np.zeros(1, np.int64), np.array([[0, 1], [-1, 0]], np.int64), f, f, f, ids)
    merge_overlaps(f, f, np.zeros((3, 3)), np.ones(3), np.zeros(3), np.zeros(3, np.int8), np.ones(3, np.int8), True)
