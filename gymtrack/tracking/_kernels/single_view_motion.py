"""Compiled kernel of ``cascade+``'s motion-predicting single-view tracker (beyond the paper).

:class:`gymtrack.tracking.single_view_motion.MotionIoUTracker` at a low frame rate, where it is
used: in WILDTRACK's crowd (7 views, ~14 boxes per view and frame) its numpy version compared
every track with every box of all views (T x N, ~100 x 100) and solved one assignment over them,
which made it cascade+'s costliest stage (1.2 ms a frame against 0.2 for the paper's IoU tracker).
Here a frame is one call: only the tracks and boxes of one view are compared (the work grows
with the people per view), the pairs without a rival are matched directly, and the caller's
assignment gets only the tracks and boxes of the pairs in conflict (:func:`motion_frame`). The
numpy reference is ``tests/reference/single_view_motion.py``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .sample import sample


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
    return rows, cols, conflict_rows, conflict_cols, cost, sub, overlap


def warm_up() -> None:
    """Compile (or load) the kernel on two frames of the sample scene's boxes."""
    s = sample()
    box = np.ascontiguousarray(s.box[:, 1])
    n = len(s.camera)
    motion_frame(np.ascontiguousarray(s.box[:, 0]), np.zeros((n, 2)), np.zeros(n, np.bool_), s.camera, np.ones(n),
                 s.camera, box, 0.5, 0.1, 0.3, 0.1)
