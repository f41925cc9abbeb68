"""Compiled kernel of ``cascade+``'s motion-predicting single-view tracker (beyond the paper).

:class:`gymtrack.tracking.single_view_motion.MotionIoUTracker` at a low frame rate, where it is
used: in WILDTRACK's crowd (7 views, ~14 boxes per view and frame) its numpy version compared
every track with every box of all views (T x N, ~100 x 100) and solved one assignment over them,
which made it cascade+'s costliest stage (1.2 ms a frame against 0.2 for the paper's IoU tracker).
Here a frame is two calls (:func:`motion_frame`, :func:`motion_commit`; :func:`keep_live` too
when a track ages out): only the tracks and boxes of one view are compared (the work grows with
the people per view), the pairs without a rival are matched directly, and the caller's
assignment gets only the tracks and boxes of the pairs in conflict. The numpy reference is
``tests/reference/single_view_motion.py``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .sample import sample
from .single_view import split_conflicts


@njit(cache=True)
def keep_live(tbox, tvel, has_vel, tcam, tlast, tid, frame, max_age):
    """The tracks whose last box is at most ``max_age + 1`` frames old (state as
    :func:`motion_frame`'s, with tlast, tid (T,) int64). Returns the kept state, same order."""
    keep = np.flatnonzero(frame - tlast <= max_age + 1)
    return tbox[keep], tvel[keep], has_vel[keep], tcam[keep], tlast[keep], tid[keep]


@njit(cache=True, error_model="numpy")
def motion_frame(tbox, tvel, has_vel, tcam, dt, camera, box, speed_per_frame, noise, size_gate, iou_threshold):
    """One frame of :class:`gymtrack.tracking.single_view_motion.MotionIoUTracker` up to the assignment.

    tbox: (T, 4) the live tracks' last centre-form boxes; tvel: (T, 2) their centre velocities
    (pixels per frame); has_vel, tcam, dt: (T,) whether they have one, their camera, frames since
    their last box; camera: (N,) int64 and box: (N, 4) the frame's boxes.

    A track and a box of one camera may be linked when the box centre lies within the gate of
    :mod:`gymtrack.tracking.single_view_motion` around the track's predicted centre, and the box
    heights differ by at most ``exp(size_gate)``; cost: the centre's offset from the prediction in
    box heights (over the geometric mean of both heights) plus the |log| height ratio; the pair's
    score is ``1 / (1 + cost)``. Of the allowed pairs those whose track and box have no other allowed
    partner are matched directly; the rest are left to the caller's assignment as a sub-matrix,
    ``-score`` where allowed and 0 elsewhere (:func:`gymtrack.tracking.single_view.assign`'s cost).

    Returns (rows, cols (the direct matches), conflict_rows (R,), conflict_cols (Q,), cost (R, Q),
    allowed (R, Q), overlap (T, N) bool: allowed pairs whose boxes' IoU >= ``iou_threshold``, the
    links the paper's tracker could have made).
    """
    T, N = tcam.shape[0], camera.shape[0]
    score = np.zeros((T, N))
    allowed = np.zeros((T, N), np.bool_)
    overlap = np.zeros((T, N), np.bool_)
    row_count = np.zeros(T, np.int64)
    col_count = np.zeros(N, np.int64)
    for i in range(T):
        px, py = tbox[i, 0], tbox[i, 1]
        if has_vel[i]:
            px += tvel[i, 0] * dt[i]
            py += tvel[i, 1] * dt[i]
        reach = noise + (0.5 if has_vel[i] else 1.0) * speed_per_frame * dt[i]
        for j in range(N):
            if tcam[i] != camera[j]:
                continue
            off = np.hypot(px - box[j, 0], py - box[j, 1]) / np.sqrt(tbox[i, 3] * box[j, 3])
            size = abs(np.log(box[j, 3] / tbox[i, 3]))
            if not (off <= reach and size <= size_gate):
                continue
            score[i, j] = 1.0 / (1.0 + (off + size))
            allowed[i, j] = True
            row_count[i] += 1
            col_count[j] += 1
            iw = min(tbox[i, 0] + 0.5 * tbox[i, 2], box[j, 0] + 0.5 * box[j, 2]) - max(tbox[i, 0] - 0.5 * tbox[i, 2], box[j, 0] - 0.5 * box[j, 2])
            ih = min(tbox[i, 1] + 0.5 * tbox[i, 3], box[j, 1] + 0.5 * box[j, 3]) - max(tbox[i, 1] - 0.5 * tbox[i, 3], box[j, 1] - 0.5 * box[j, 3])
            inter = max(iw, 0.0) * max(ih, 0.0)
            overlap[i, j] = inter / (tbox[i, 2] * tbox[i, 3] + box[j, 2] * box[j, 3] - inter) >= iou_threshold
    rows, cols, conflict_rows, conflict_cols, cost, sub = split_conflicts(score, allowed, row_count, col_count)
    return rows, cols, conflict_rows, conflict_cols, cost, sub, overlap


@njit(cache=True)
def motion_commit(tbox, tvel, has_vel, tcam, tlast, tid, next_id, frame, camera, box, rows, cols, smoothing):
    """The rest of one frame: a matched track takes its box, its velocity the smoothed step
    (``smoothing``: the newest step's weight; the first step as it is); unmatched boxes start
    tracks (ids ``next_id, next_id + 1, ...`` in box order). rows, cols: matched (track, box)
    pairs. Returns (tbox', tvel', has_vel', tcam', tlast', tid', ids (N,), next_id')."""
    N, T = camera.shape[0], tid.shape[0]
    ids = np.full(N, -1, np.int64)
    for k in range(rows.shape[0]):
        ids[cols[k]] = tid[rows[k]]
    n_new = 0
    for j in range(N):
        if ids[j] < 0:
            n_new += 1
    ob = np.empty((T + n_new, 4))
    ov = np.zeros((T + n_new, 2))
    oh = np.zeros(T + n_new, np.bool_)
    oc = np.empty(T + n_new, np.int64)
    ol = np.empty(T + n_new, np.int64)
    oi = np.empty(T + n_new, np.int64)
    ob[:T], ov[:T], oh[:T], oc[:T], ol[:T], oi[:T] = tbox, tvel, has_vel, tcam, tlast, tid
    for k in range(rows.shape[0]):
        r, c = rows[k], cols[k]
        step = float(frame - tlast[r])
        a = smoothing if has_vel[r] else 1.0
        for q in range(2):
            ov[r, q] = a * ((box[c, q] - tbox[r, q]) / step) + (1.0 - a) * tvel[r, q]
        oh[r] = True
        ob[r] = box[c]
        ol[r] = frame
    at = T
    for j in range(N):
        if ids[j] < 0:
            ids[j] = next_id
            ob[at] = box[j]
            oc[at] = camera[j]
            ol[at] = frame
            oi[at] = next_id
            next_id += 1
            at += 1
    return ob, ov, oh, oc, ol, oi, ids, next_id


def warm_up() -> None:
    """Compile (or load) the kernels on two frames of the sample scene's boxes."""
    s = sample()
    state = (np.zeros((0, 4)), np.zeros((0, 2)), np.zeros(0, np.bool_), np.zeros(0, np.int64), np.zeros(0, np.int64),
             np.zeros(0, np.int64))
    next_id = 0
    for frame in (0, 1):
        box = np.ascontiguousarray(s.box[:, frame])
        state = keep_live(*state, frame, 2)
        r, c = motion_frame(state[0], state[1], state[2], state[3], (frame - state[4]).astype(np.float64), s.camera, box,
                            0.5, 0.1, 0.3, 0.1)[:2]
        *state, _, next_id = motion_commit(*state, next_id, frame, s.camera, box, r, c, 0.5)
