"""Compiled kernels of the single-view IoU tracker (paper Section III-A).

The arrays of one frame are small (tens of boxes), so numpy's per-call overhead dominated the
vectorised version; a frame is two kernel calls (:func:`iou_frame`, :func:`iou_commit`) plus
the caller's assignment on the conflicting tracks and boxes. The numpy reference is
``tests/reference/single_view.py``. Track state: tbox (5, T) corners and area (shifted per
camera, :func:`gymtrack.tracking.single_view.corners`), tcam, tlast, tid (T,) int64.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .sample import sample

_NAN = np.nan


@njit(cache=True, inline="always")
def nan_min(x, y):
    """``np.minimum`` of two scalars: NaN if either is NaN."""
    if x != x or y != y:
        return _NAN
    return x if x <= y else y


@njit(cache=True, inline="always")
def nan_max(x, y):
    """``np.maximum`` of two scalars: NaN if either is NaN."""
    if x != x or y != y:
        return _NAN
    return x if x >= y else y


@njit(cache=True, error_model="numpy")
def iou_frame(tbox, tcam, tlast, tid, frame, max_age, camera, box, threshold):
    """One frame of :class:`gymtrack.tracking.single_view.IoUTracker` up to the assignment.

    tbox: (5, T) live tracks' last boxes as :func:`gymtrack.tracking.single_view.corners` rows; tcam, tlast,
    tid: (T,) their camera, last frame and id; camera: (N,) int64; box: (N, 4) centre-form boxes.

    Drops tracks older than ``max_age + 1`` frames, builds the boxes' corners (shifted per
    camera) and the IoU (:func:`gymtrack.tracking.single_view.iou_corners`) of every track and box of one camera
    (boxes of different cameras never overlap). Of the allowed pairs (IoU >= ``threshold``)
    those whose track and box have no other allowed partner are matched directly; the rest
    (the tracks and boxes of conflicting components) are left to the caller's assignment as a
    sub-matrix, ``-IoU`` where allowed and 0 elsewhere (``assign``'s cost).

    Returns (tbox', tcam', tlast', tid', cb (5, N), rows, cols (the direct matches),
    conflict_rows (R,), conflict_cols (Q,), cost (R, Q), allowed (R, Q)).
    """
    T = tid.shape[0]
    keep = np.empty(T, np.int64)
    n_keep = 0
    for i in range(T):
        if frame - tlast[i] <= max_age + 1:
            keep[n_keep] = i
            n_keep += 1
    tb = np.empty((5, n_keep))
    tc = np.empty(n_keep, np.int64)
    tl = np.empty(n_keep, np.int64)
    ti = np.empty(n_keep, np.int64)
    for a in range(n_keep):
        i = keep[a]
        for r in range(5):
            tb[r, a] = tbox[r, i]
        tc[a] = tcam[i]
        tl[a] = tlast[i]
        ti[a] = tid[i]
    N = box.shape[0]
    cb = np.empty((5, N))
    for j in range(N):
        half_w, half_h = box[j, 2] * 0.5, box[j, 3] * 0.5
        shift = camera[j] * 1e6
        cb[0, j] = (box[j, 0] - half_w) + shift
        cb[1, j] = box[j, 1] - half_h
        cb[2, j] = (box[j, 0] + half_w) + shift
        cb[3, j] = box[j, 1] + half_h
        cb[4, j] = box[j, 2] * box[j, 3]
    iou = np.zeros((n_keep, N))
    allowed = np.zeros((n_keep, N), np.bool_)
    row_count = np.zeros(n_keep, np.int64)
    col_count = np.zeros(N, np.int64)
    for i in range(n_keep):
        for j in range(N):
            if tc[i] != camera[j]:
                continue
            iw = nan_max(nan_min(tb[2, i], cb[2, j]) - nan_max(tb[0, i], cb[0, j]), 0.0)
            ih = nan_max(nan_min(tb[3, i], cb[3, j]) - nan_max(tb[1, i], cb[1, j]), 0.0)
            inter = iw * ih
            v = inter / (tb[4, i] + cb[4, j] - inter)
            if v >= threshold:
                iou[i, j] = v
                allowed[i, j] = True
                row_count[i] += 1
                col_count[j] += 1
    rows, cols, conflict_rows, conflict_cols, cost, sub = split_conflicts(iou, allowed, row_count, col_count)
    return tb, tc, tl, ti, cb, rows, cols, conflict_rows, conflict_cols, cost, sub


@njit(cache=True)
def split_conflicts(score, allowed, row_count, col_count):
    """The allowed pairs (T, N) of one frame split: those whose track and box have no other
    allowed partner (``row_count``, ``col_count``: the allowed pairs per track and box) are
    matched directly; the tracks and boxes of the rest (the conflicting components) go to the
    caller's assignment as a sub-matrix, ``-score`` where allowed and 0 elsewhere (the cost of
    :func:`gymtrack.tracking.single_view.assign`). Returns (rows, cols, conflict_rows (R,),
    conflict_cols (Q,), cost (R, Q), allowed (R, Q))."""
    T, N = allowed.shape
    n_direct = 0
    in_row = np.zeros(T, np.bool_)  # a track / box in a conflicting component
    in_col = np.zeros(N, np.bool_)
    for i in range(T):
        for j in range(N):
            if allowed[i, j]:
                if row_count[i] == 1 and col_count[j] == 1:
                    n_direct += 1
                else:
                    in_row[i] = True
                    in_col[j] = True
    rows = np.empty(n_direct, np.int64)
    cols = np.empty(n_direct, np.int64)
    k = 0
    for i in range(T):
        for j in range(N):
            if allowed[i, j] and row_count[i] == 1 and col_count[j] == 1:
                rows[k] = i
                cols[k] = j
                k += 1
    conflict_rows = np.flatnonzero(in_row)
    conflict_cols = np.flatnonzero(in_col)
    R, Q = conflict_rows.shape[0], conflict_cols.shape[0]
    cost = np.zeros((R, Q))
    sub = np.zeros((R, Q), np.bool_)
    for a in range(R):
        for b in range(Q):
            i, j = conflict_rows[a], conflict_cols[b]
            if allowed[i, j]:
                cost[a, b] = -score[i, j]
                sub[a, b] = True
    return rows, cols, conflict_rows, conflict_cols, cost, sub


@njit(cache=True)
def iou_commit(tbox, tcam, tlast, tid, next_id, frame, camera, cb, rows, cols):
    """The rest of one :class:`gymtrack.tracking.single_view.IoUTracker` frame: matched tracks take their box,
    unmatched boxes start tracks (ids ``next_id, next_id + 1, ...`` in box order).

    tbox (5, T), tcam, tlast, tid (T,): the live tracks; camera (N,), cb (5, N): the frame's
    cameras and corners; rows, cols: matched (track, box) pairs.
    Returns (tbox', tcam', tlast', tid', ids (N,), next_id').
    """
    N = cb.shape[1]
    T = tid.shape[0]
    ids = np.full(N, -1, np.int64)
    n_new = N
    for k in range(rows.shape[0]):
        ids[cols[k]] = tid[rows[k]]
        n_new -= 1
    out_b = np.empty((5, T + n_new))
    out_c = np.empty(T + n_new, np.int64)
    out_l = np.empty(T + n_new, np.int64)
    out_i = np.empty(T + n_new, np.int64)
    out_b[:, :T] = tbox
    out_c[:T] = tcam
    out_l[:T] = tlast
    out_i[:T] = tid
    for k in range(rows.shape[0]):
        r, c = rows[k], cols[k]
        for q in range(5):
            out_b[q, r] = cb[q, c]
        out_l[r] = frame
    a = T
    for j in range(N):
        if ids[j] < 0:
            ids[j] = next_id
            for q in range(5):
                out_b[q, a] = cb[q, j]
            out_c[a] = camera[j]
            out_l[a] = frame
            out_i[a] = next_id
            next_id += 1
            a += 1
    return out_b, out_c, out_l, out_i, ids, next_id


@njit(cache=True)
def frame_rows_check(frame_col, camera, frame, n_cameras):
    """The input test of one :meth:`gymtrack.tracking.tracker.Tracker.update`: frame_col,
    camera (N,) int64. Returns 0 when every row is of ``frame`` with a camera index in
    ``0 .. n_cameras - 1``; else 1 when a row is of another frame, else 2 (a camera index outside).
    (Five numpy calls per streamed frame before; numpy reference in the tests.)
    """
    code = 0
    for i in range(frame_col.shape[0]):
        if frame_col[i] != frame:
            return 1
        if camera[i] < 0 or camera[i] >= n_cameras:
            code = 2
    return code


def warm_up() -> None:
    """Compile (or load) the kernels on two frames of the sample scene's boxes."""
    s = sample()
    tracks = (np.zeros((5, 0)), np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64))
    next_id = 0
    frame_rows_check(np.zeros(1, np.int64), np.zeros(1, np.int64), 0, 1)
    for frame in (0, 1):
        box = np.ascontiguousarray(s.box[:, frame])
        tb, tc, tl, ti, cb, r, c = iou_frame(*tracks, frame, 2, s.camera, box, 0.1)[:7]
        *tracks, _, next_id = iou_commit(tb, tc, tl, ti, next_id, frame, s.camera, cb, r, c)
