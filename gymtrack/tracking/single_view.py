"""Single-view processing: one IoU tracker per camera (paper Section III-A, Bochinski et al.).

Each camera's boxes are linked frame to frame into 2D tracks by their intersection over union
(IoU) with the track's last box, no motion model, no appearance. The paper's settings favour
cut-offs over mix-ups (later stages repair cut-offs): IoU threshold 0.1 and a track survives
at most ``max_age = 2`` frames without a box.

Unlike the original greedy IoU tracker, each frame is solved as one global assignment
(``scipy.optimize.linear_sum_assignment`` maximising the summed IoU of pairs above the
threshold); a pair whose track and box have no other candidate is matched directly, and the
solver only sees the tracks and boxes of conflicting components. The per-frame loops are
compiled (:mod:`._kernels.single_view`): a frame costs two kernel calls, plus the solver on a small matrix
when some track or box has two candidates. All cameras are tracked by one object (2D track ids
unique over all cameras); only pairs of one camera are compared, and :func:`corners` shifts
boxes far apart in x per camera so that :func:`iou_matrix`-style matrices over all cameras
never see overlaps across cameras either.

Boxes are matched in the pixels they come in (raw image): between consecutive frames lens
distortion changes a box's shape too little to matter for IoU. The geometric stages use
undistorted boxes (see :mod:`.windows`).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from ._kernels.single_view import iou_commit, iou_frame


def iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU of every pair of centre-form boxes.

    a: (N, 4) ``[x, y, w, h]``; b: (M, 4). Returns (N, M) in [0, 1].
    """
    return iou_corners(corners(np.asarray(a, dtype=np.float64)), corners(np.asarray(b, dtype=np.float64)))


def with_conflicts(r: np.ndarray, c: np.ndarray, crow: np.ndarray, ccol: np.ndarray, cost: np.ndarray,
                   allowed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The direct matches (r, c) of a frame kernel and the assignment of its conflicting tracks
    ``crow`` (R,) and boxes ``ccol`` (Q,) (cost (R, Q), ``allowed`` (R, Q)): ``linear_sum_assignment``
    on the conflicts only, its disallowed pairs dropped. Returns all matched (tracks, boxes)."""
    if not len(crow):
        return r, c
    rr, cc = linear_sum_assignment(cost)
    keep = allowed[rr, cc]
    return np.concatenate([r, crow[rr[keep]]]), np.concatenate([c, ccol[cc[keep]]])


def assign(score: np.ndarray, allowed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Maximum-total-score one-to-one assignment restricted to ``allowed`` pairs.

    score: (N, M) similarity (higher is better); allowed: (N, M) bool.
    Returns (rows, cols) of the matched pairs, every pair allowed.

    When no row and no column has more than one allowed partner the answer is the allowed
    pairs themselves and the solver is skipped. Otherwise ``linear_sum_assignment`` maximises
    the summed score; a disallowed pair adds nothing, so dropping the disallowed pairs it returns
    leaves an optimal matching of allowed pairs.
    """
    if allowed.size == 0 or (allowed.sum(axis=0).max() <= 1 and allowed.sum(axis=1).max() <= 1):
        return np.nonzero(allowed)
    r, c = linear_sum_assignment(np.where(allowed, -score, 0.0))
    keep = allowed[r, c]
    return r[keep], c[keep]


#: boxes of camera c are shifted by c * _CAMERA_OFFSET pixels in x, so that boxes of different
#: cameras never overlap: one IoU matrix serves all cameras without a camera mask
_CAMERA_OFFSET = 1e6


def corners(box: np.ndarray, camera: np.ndarray | None = None) -> np.ndarray:
    """(N, 4) centre-form boxes -> (5, N) rows ``x1, y1, x2, y2, area`` (x shifted per camera).

    Rows rather than columns: every IoU operation then reads contiguous memory."""
    out = np.empty((5, len(box)))
    b = box.T
    half_w, half_h = b[2] * 0.5, b[3] * 0.5
    out[0] = b[0] - half_w
    out[1] = b[1] - half_h
    out[2] = b[0] + half_w
    out[3] = b[1] + half_h
    out[4] = b[2] * b[3]
    if camera is not None:
        shift = camera * _CAMERA_OFFSET
        out[0] += shift
        out[2] += shift
    return out


def iou_corners(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU of every pair from :func:`corners` forms: a (5, N), b (5, M) -> (N, M)."""
    iw = np.minimum(a[2][:, None], b[2]) - np.maximum(a[0][:, None], b[0])
    ih = np.minimum(a[3][:, None], b[3]) - np.maximum(a[1][:, None], b[1])
    np.maximum(iw, 0.0, out=iw)
    np.maximum(ih, 0.0, out=ih)
    iw *= ih  # the intersection
    with np.errstate(divide="ignore", invalid="ignore"):
        return iw / (a[4][:, None] + b[4] - iw)


class IoUTracker:
    """IoU trackers of all cameras at once; 2D track ids are unique over all cameras.

    Parameters
    ----------
    iou_threshold: a box continues a track only with IoU >= this (paper: 0.1; lower links
        faster motion, higher cuts more tracks).
    max_age: frames a track may go without a box and still be continued (paper: 2; more
        bridges missed detections but risks mix-ups).

    State (bounded by the number of people in view): per live track its last box (as corners
    and area, shifted per camera), camera, last frame and id.

    The kernels compile on first use; the :class:`~.tracker.Tracker` compiles them all in its
    constructor (:func:`gymtrack.tracking.warm_up`), so compilation never counts as tracking time.
    """

    def __init__(self, iou_threshold: float = 0.1, max_age: int = 2):
        self.iou_threshold = float(iou_threshold)
        self.max_age = int(max_age)
        self.box = np.zeros((5, 0))
        self.camera = np.zeros(0, np.int64)
        self.last = np.zeros(0, np.int64)
        self.track_id = np.zeros(0, np.int64)
        self.next_id = 0

    def __len__(self) -> int:
        return len(self.track_id)

    def update(self, frame: int, camera: np.ndarray, box: np.ndarray) -> np.ndarray:
        """Link one frame's boxes to tracks.

        frame: frame number (increasing between calls); camera: (N,) camera index;
        box: (N, 4) centre-form boxes. Returns (N,) int64 2D track ids.

        The per-frame loops (old tracks dropped, corners, IoU of the pairs of one camera, the
        pairs without a rival, new tracks) are compiled (:func:`._kernels.single_view.iou_frame` and
        :func:`~._kernels.single_view.iou_commit`, the arithmetic of :func:`iou_corners`). The assignment
        (:func:`assign`) falls apart into the connected components of the allowed pairs; a
        component of one pair is that pair, and ``linear_sum_assignment`` gets only the tracks and
        boxes of the components with a conflict (the same optimum; only exact ties in summed
        IoU could be broken differently).
        """
        camera = np.ascontiguousarray(camera, dtype=np.int64)
        box = np.ascontiguousarray(box, dtype=np.float64)
        tb, tc, tl, ti, cb, r, c, crow, ccol, cost, allowed = iou_frame(
            self.box, self.camera, self.last, self.track_id, int(frame), self.max_age, camera, box, self.iou_threshold)
        r, c = with_conflicts(r, c, crow, ccol, cost, allowed)  # the assignment on the conflicts only
        self.box, self.camera, self.last, self.track_id, ids, self.next_id = iou_commit(
            tb, tc, tl, ti, self.next_id, int(frame), camera, cb, r, c)
        return ids
