"""Compiled kernels of ``cascade+``'s 3D-motion link of broken 2D tracks (beyond the paper: issue 12).

:func:`link_costs`: one round of :class:`gymtrack.tracking.motion_link.MotionLinker` -- the old
2D tracks' last boxes, the new tracks' first boxes and views, the (L, T) mean offset from the
projected constant-velocity prediction and the view / gap gates -- in one call instead of ~40
numpy calls (the arrays are a window's: ~15 old entries, ~3 new tracks). :func:`remember`:
what :meth:`~gymtrack.tracking.motion_link.MotionLinker.remember` keeps per (tracklet, view);
:func:`new_tracks`: a window's new 2D tracks (:func:`new_near`: and whether the first round links any); :func:`old_entries`: the previous window's, one
entry per 2D track; :func:`keep_views`: the 2D track a view without a member keeps.
The numpy code they replace is ``tests/reference/motion_link.py``; the arithmetic is written in
the reference's order (numpy's einsum order, no fused multiply-add), so the results are the same to the last bit and
the links never change.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_NAN = np.nan


@njit(cache=True, error_model="numpy")
def tracklet_ends(xyz, valid, start, max_speed):
    """:func:`gymtrack.tracking.linking.tracklet_ends`: xyz (M, W, 3), valid (M, W) (a valid point
    per row) -> last frame (M,), last xyz (M, 3), velocity (M, 3) metres per frame (clipped)."""
    M, W = valid.shape
    lf = np.empty(M, np.int64)
    lx = np.empty((M, 3))
    lv = np.empty((M, 3))
    for m in range(M):
        last = 0
        for t in range(W - 1, -1, -1):
            if valid[m, t]:
                last = t
                break
        early = W
        for t in range(max(last - 4, 0), W):
            if valid[m, t]:
                early = t
                break
        dt = max(last - early, 1)
        v0 = (xyz[m, last, 0] - xyz[m, early, 0]) / dt
        v1 = (xyz[m, last, 1] - xyz[m, early, 1]) / dt
        v2 = (xyz[m, last, 2] - xyz[m, early, 2]) / dt
        speed = np.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
        f = min(1.0, max_speed / max(speed, 1e-12))
        lv[m, 0], lv[m, 1], lv[m, 2] = v0 * f, v1 * f, v2 * f
        lx[m, 0], lx[m, 1], lx[m, 2] = xyz[m, last, 0], xyz[m, last, 1], xyz[m, last, 2]
        lf[m] = start + last
    return lf, lx, lv


@njit(cache=True, error_model="numpy")
def last_observed(members, observed, seg_start):
    """(M, C) the last observed frame of each member segment (``members`` (M, C) index
    ``observed`` (K, W)), ``-1 << 40`` where a view has none."""
    M, C = members.shape
    W = observed.shape[1]
    out = np.full((M, C), -(1 << 40), np.int64)
    for m in range(M):
        for c in range(C):
            s = members[m, c]
            if s < 0:
                continue
            k = 0  # argmax of the reversed row: the last True, else index W - 1 - 0
            for t in range(W - 1, -1, -1):
                if observed[s, t]:
                    k = W - 1 - t
                    break
            out[m, c] = seg_start + W - 1 - k
    return out


@njit(cache=True, error_model="numpy")
def _first_boxes(new, frame, track2d, camera, ubox, n):
    """The first ``n`` boxes of each new track (sorted ids ``new`` (T,)) among the rows (frame
    order): their frames fr (T, n), undistorted boxes bx (T, n, 4), count cnt (T,) and view cam_n (T,)."""
    T = len(new)
    fr = np.zeros((T, n), np.int64)
    bx = np.full((T, n, 4), _NAN)
    cnt = np.zeros(T, np.int64)
    cam_n = np.zeros(T, np.int64)
    for i in range(len(frame)):
        j = np.searchsorted(new, track2d[i])
        if j < T and new[j] == track2d[i]:
            cam_n[j] = camera[i]
            k = cnt[j]
            if k < n:
                fr[j, k] = frame[i]
                for q in range(4):
                    bx[j, k, q] = ubox[i, q]
                cnt[j] = k + 1
    return fr, bx, cnt, cam_n


@njit(cache=True, error_model="numpy")
def _offset(fr, bx, cnt, j, lf, lx, lv, m, P, c):
    """The mean offset of new track j's first boxes from the projection into view c of old end
    m's constant-velocity prediction, in box widths / heights; NaN behind the camera."""
    s = 0.0
    for k in range(cnt[j]):
        dt = float(fr[j, k] - lf[m])
        X0 = lx[m, 0] + lv[m, 0] * dt
        X1 = lx[m, 1] + lv[m, 1] * dt
        X2 = lx[m, 2] + lv[m, 2] * dt
        # (p0 + p2) + p1: the order numpy's einsum sums three products in (the reference's bits)
        h0 = (P[c, 0, 0] * X0 + P[c, 0, 2] * X2) + P[c, 0, 1] * X1 + P[c, 0, 3]
        h1 = (P[c, 1, 0] * X0 + P[c, 1, 2] * X2) + P[c, 1, 1] * X1 + P[c, 1, 3]
        h2 = (P[c, 2, 0] * X0 + P[c, 2, 2] * X2) + P[c, 2, 1] * X1 + P[c, 2, 3]
        o0 = (h0 / h2 - bx[j, k, 0]) / bx[j, k, 2]
        o1 = (h1 / h2 - bx[j, k, 1]) / bx[j, k, 3]
        d = np.sqrt(o0 * o0 + o1 * o1)
        if not h2 > 0 or np.isnan(d):
            return _NAN
        s += d
    return s / cnt[j]


@njit(cache=True, error_model="numpy")
def link_costs(frame, track2d, camera, ubox, new, cam_o, t_o, last_o, lf, lx, lv, P, n, max_gap):
    """One round of the motion link. Rows frame, track2d, camera (N,), ubox (N, 4) centre form, in
    frame order; new (T,) sorted new 2D track ids; per old entry (L,): its view cam_o, 2D track
    t_o (-1: none), last frame seen last_o, the 3D track's end frame lf, point lx (L, 3),
    velocity lv (L, 3); P (C, 3, 4); n boxes compared; max_gap frames.
    Returns D (L, T): mean normalised offset of the new track's first ``n`` boxes from the
    projected prediction, NaN where another view, a gap outside 1 .. max_gap + 1 (old tracks
    only) or a prediction behind the camera."""
    N, L, T = len(frame), len(t_o), len(new)
    last = last_o.copy()  # the old track's last box: in the rows still held, else the previous window's
    for i in range(N):
        for l in range(L):
            if t_o[l] >= 0 and t_o[l] == track2d[i] and frame[i] > last[l]:
                last[l] = frame[i]
    fr, bx, cnt, cam_n = _first_boxes(new, frame, track2d, camera, ubox, n)
    D = np.full((L, T), _NAN)
    for l in range(L):
        c = cam_o[l]
        for j in range(T):
            if cam_n[j] != c or cnt[j] == 0:
                continue
            gap = fr[j, 0] - last[l]
            if t_o[l] >= 0 and (gap < 1 or gap > max_gap + 1):
                continue
            D[l, j] = _offset(fr, bx, cnt, j, lf, lx, lv, l, P, c)
    return D


@njit(cache=True, error_model="numpy")
def new_tracks(frame, track2d, start, stop, fresh_from, seen):
    """The 2D tracks (sorted ids) of the rows frame, track2d (N,) (frame order) in the frames
    ``start .. stop - 1`` whose first box there lies at ``fresh_from`` or later and which are
    not among ``seen`` (M,)."""
    a = np.searchsorted(frame, start)
    f = max(np.searchsorted(frame, fresh_from), a)
    b = np.searchsorted(frame, stop)
    if f >= b:
        return np.zeros(0, np.int64)
    lo, hi = track2d[f], track2d[f]
    for i in range(f, b):
        lo = min(lo, track2d[i])
        hi = max(hi, track2d[i])
    span = hi - lo + 1
    if span > 8 * (b - f) + 256:  # ids too spread out for a table over their range
        return _new_tracks_sorted(frame, track2d, a, f, b, seen)
    # ids are small integers: one table over the fresh rows' id range (no sort, no search)
    state = np.zeros(span, np.int8)  # 1: a fresh row's track, 2: not new
    for i in range(f, b):
        state[track2d[i] - lo] = 1
    for i in range(a, f):  # a track with a box before fresh_from is not new
        r = track2d[i] - lo
        if r >= 0 and r < span:
            state[r] = 2
    for q in range(len(seen)):
        r = seen[q] - lo
        if r >= 0 and r < span:
            state[r] = 2
    n = 0
    for r in range(span):
        n += state[r] == 1
    out = np.empty(n, np.int64)
    n = 0
    for r in range(span):
        if state[r] == 1:
            out[n] = lo + r
            n += 1
    return out


@njit(cache=True, error_model="numpy")
def _new_tracks_sorted(frame, track2d, a, f, b, seen):
    """:func:`new_tracks` of the rows ``a .. b - 1`` (fresh from ``f``) by sorting the fresh rows' ids."""
    fresh = np.sort(track2d[f:b])
    cand = np.empty(len(fresh), np.int64)  # the fresh frames' tracks, once each (a handful)
    n = 0
    for p in range(len(fresh)):
        if p == 0 or fresh[p] != fresh[p - 1]:
            cand[n] = fresh[p]
            n += 1
    cand = cand[:n]
    keep = np.ones(n, np.bool_)
    # each earlier row is looked up among the few candidates (no sort of the many)
    for i in range(a, f):
        k = np.searchsorted(cand, track2d[i])
        if k < n and cand[k] == track2d[i]:
            keep[k] = False
    for q in range(len(seen)):
        k = np.searchsorted(cand, seen[q])
        if k < n and cand[k] == seen[q]:
            keep[k] = False
    return cand[keep]


@njit(cache=True, error_model="numpy")
def new_near(C, ids, last_obs, track_id, lf, lx, lv, frame, track2d, camera, ubox, start, stop, fresh_from, seen, P, n,
             max_gap, gate, ends_apply):  # (track_id: unused, the ends as MotionLinker keeps them)
    """:class:`~gymtrack.tracking.motion_link.MotionLinker`'s step up to its first decision, in
    one call: the window's new 2D tracks (:func:`new_tracks`) and whether any lies within the
    gate (``D <= gate``) of the first round's costs (:func:`link_costs` of :func:`old_entries`
    of the ends; tested only when there are new tracks and ``ends_apply``: the ends are the
    previous window's)."""
    new = new_tracks(frame, track2d, start, stop, fresh_from, seen)
    near = False
    if len(new) and ends_apply:
        near = _first_near(C, ids, last_obs, lf, lx, lv, frame, track2d, camera, ubox, new, P, n, max_gap, gate)
    return new, near


@njit(cache=True, error_model="numpy")
def _first_near(C, ids, last_obs, lf, lx, lv, frame, track2d, camera, ubox, new, P, n, max_gap, gate):
    """Whether the first round (:func:`link_costs` of :func:`old_entries` of the ends) has a cost
    within ``gate``, without building its (L, T) matrix:
    only the old entries (:func:`old_entries`' choice: the first (tracklet, view) of each 2D
    track) of a view a new track is in are costed, with :func:`link_costs`' arithmetic."""
    N, T = len(frame), len(new)
    fr, bx, cnt, cam_n = _first_boxes(new, frame, track2d, camera, ubox, n)
    flat, lo = ids.ravel(), last_obs.ravel()
    for e in range(flat.size):
        c, m, t = e % C, e // C, flat[e]
        wanted = False
        for j in range(T):
            if cam_n[j] == c and cnt[j] > 0:
                wanted = True
        if not wanted:
            continue
        last = lo[e]
        if t >= 0:
            first = True  # one entry per 2D track: its first (tracklet, view)
            for e2 in range(e):
                if flat[e2] == t:
                    first = False
                    break
            if not first:
                continue
            for i in range(N):  # the old track's last box: in the rows still held
                if track2d[i] == t and frame[i] > last:
                    last = frame[i]
        for j in range(T):
            if cam_n[j] != c or cnt[j] == 0:
                continue
            gap = fr[j, 0] - last
            if t >= 0 and (gap < 1 or gap > max_gap + 1):
                continue
            if _offset(fr, bx, cnt, j, lf, lx, lv, m, P, c) <= gate:  # (NaN compares False)
                return True
    return False


@njit(cache=True, error_model="numpy")
def old_entries(C, ids, last_obs, track_id, lf, lx, lv):
    """One entry per old 2D track from the previous window's (M, C) views: ids, last_obs (M, C),
    track_id, lf (M,), lx, lv (M, 3) -> their view, 2D track, last frame seen, 3D track, end frame,
    end point and velocity, ordered as ``np.unique`` orders the keys (views without a 2D track
    first, latest tracklet first; then by 2D track, each at its first (tracklet, view))."""
    n = ids.size
    flat = ids.ravel()
    key = np.empty(n, np.int64)
    for e in range(n):
        key[e] = flat[e] if flat[e] >= 0 else -1 - e
    order = np.argsort(key, kind="mergesort")  # stable: the first (tracklet, view) of a 2D track first
    keep = np.empty(n, np.int64)
    k = 0
    for p in range(n):
        if p > 0 and key[order[p]] == key[order[p - 1]]:
            continue
        keep[k] = order[p]
        k += 1
    keep = keep[:k]
    m = keep // C
    lo = last_obs.ravel()
    cam, t, last, tid, f = keep % C, flat[keep], lo[keep], track_id[m], lf[m]
    x = np.empty((k, 3))
    v = np.empty((k, 3))
    for i in range(k):
        for q in range(3):
            x[i, q] = lx[m[i], q]
            v[i, q] = lv[m[i], q]
    return cam, t, last, tid, f, x, v


@njit(cache=True, error_model="numpy")
def keep_views(members, ids, track_id, prev_track_id, prev_ids):
    """In place: where a tracklet (M) has no member in a view (``members`` (M, C) < 0), ``ids``
    (M, C) gets the 2D track its 3D track ``track_id`` had there in the previous window
    (``prev_ids`` (P, C) of ``prev_track_id`` (P,); the last row of an id, as a dict built from
    the rows keeps), else -1."""
    M, C = members.shape
    for m in range(M):
        j = -1
        for c in range(C):
            if members[m, c] >= 0:
                continue
            if j == -1:
                j = -2  # looked up once per row
                for q in range(len(prev_track_id)):
                    if prev_track_id[q] == track_id[m]:
                        j = q
            ids[m, c] = prev_ids[j, c] if j >= 0 else -1
    return ids


@njit(cache=True, error_model="numpy")
def remember(xyz, valid, start, max_speed, members, observed, seg_start, track2d, track_id, prev_track_id, prev_ids):
    """What :meth:`~gymtrack.tracking.motion_link.MotionLinker.remember` keeps of a linked window,
    in one call: :func:`tracklet_ends` of xyz (M, W, 3), valid (M, W); per (tracklet, view) of
    ``members`` (M, C) its segment's 2D track (``track2d`` (K,)) and :func:`last_observed` frame
    (``observed`` (K, W) from ``seg_start``; K = 0: none), a view without a member the 2D track
    :func:`keep_views` gives (``prev_track_id`` (P,), ``prev_ids`` (P, C)); and a copy of
    ``track_id`` (M,). Returns lf, lx, lv, last_obs, ids, track_id."""
    M, C = members.shape
    lf, lx, lv = tracklet_ends(xyz, valid, start, max_speed)
    if len(track2d):
        last_obs = last_observed(members, observed, seg_start)
        ids = np.empty((M, C), np.int64)
        for m in range(M):
            for c in range(C):
                ids[m, c] = track2d[max(members[m, c], 0)]
    else:
        last_obs = np.full((M, C), -(1 << 40), np.int64)
        ids = np.zeros((M, C), np.int64)
    ids = keep_views(members, ids, track_id, prev_track_id, prev_ids)
    return lf, lx, lv, last_obs, ids, track_id.copy()


def warm_up() -> None:
    """Compile (or load) the kernels on a tiny input of the tracker's argument types."""
    xyz = np.zeros((1, 4, 3))
    valid = np.ones((1, 4), bool)
    tracklet_ends(xyz, valid, 0, 0.5)
    last_observed(np.zeros((1, 2), np.int64), np.ones((1, 4), bool), 0)
    i1 = np.zeros(1, np.int64)
    P = np.zeros((1, 3, 4))
    P[0, 0, 0] = P[0, 1, 1] = P[0, 2, 2] = P[0, 2, 3] = 1.0
    new_tracks(i1, i1, 0, 4, 2, i1)
    remember(xyz, valid, 0, 0.5, np.zeros((1, 2), np.int64), np.ones((1, 4), bool), 0, i1, i1, i1,
             np.zeros((1, 2), np.int64))
    keep_views(np.full((1, 2), -1, np.int64), np.zeros((1, 2), np.int64), i1, i1, np.zeros((1, 2), np.int64))
    old_entries(2, np.zeros((1, 2), np.int64), np.zeros((1, 2), np.int64), i1, i1, np.zeros((1, 3)), np.zeros((1, 3)))
    new_near(2, np.zeros((1, 2), np.int64), np.zeros((1, 2), np.int64), i1, i1, np.zeros((1, 3)), np.zeros((1, 3)),
             i1, i1, i1, np.ones((1, 4)), 0, 4, 2, i1, P, 3, 5, 1.0, True)
    link_costs(i1, i1, i1, np.ones((1, 4)), i1, i1, i1 - 1, i1, i1, np.zeros((1, 3)), np.zeros((1, 3)), P, 3, 5)
