"""Assign 2D poses to the tracker's 3D tracks by their boxes in each view.

Paper: Section III-D, last paragraph ("Identify Target Gymnast for Pose Estimation"): the
expanded boxes ``b_buf`` are the crops a top-down pose model runs on, so a 2D pose belongs to the
3D track whose box it came from. Poses that arrive without a ``track_id`` (a pose model run on
its own, OpenPose's bottom-up output) are matched here: per (frame, camera), a Hungarian
assignment (``scipy.optimize.linear_sum_assignment``) of poses to tracks on the cost
``1 - IoU``, where a track's IoU is the best over its boxes in that view (its per-view box from
the tracker and, for the target, ``b_buf``), and pairs below ``min_iou`` are gated out.

The pose's box is its ``bbox`` (the crop the model ran on) when given, else the bounding box of
its found keypoints grown by ``keypoint_margin`` on each side (keypoints stop at the wrists,
ankles and nose; a person box reaches past them).

Every input row is accounted for by a status (:data:`STATUS_NAMES`): ``given`` (it had a track
id), ``assigned``, ``unassigned`` (no track box overlapped enough, or another pose won it),
``rejected_no_joints`` (no joint found and no bbox), ``rejected_frame`` (its frame is outside the
tracker output's frame range). Nothing is dropped: the returned Poses2D has every row.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..detections import Detections
from ..poses import Poses2D
from .assign_joints import JOINT_GATE, JOINT_WEIGHT, MIN_OVERLAP, joint_costs

__all__ = ["GIVEN", "ASSIGNED", "UNASSIGNED", "REJECTED_NO_JOINTS", "REJECTED_FRAME", "STATUS_NAMES",
           "Assignment", "pose_boxes", "box_iou_pairs", "assign_poses"]

GIVEN, ASSIGNED, UNASSIGNED, REJECTED_NO_JOINTS, REJECTED_FRAME = 0, 1, 2, 3, 4
STATUS_NAMES: tuple[str, ...] = ("given", "assigned", "unassigned", "rejected_no_joints", "rejected_frame")


@dataclass(frozen=True, eq=False)
class Assignment:
    """The result of :func:`assign_poses`.

    poses: every input row (same order), ``track_id`` filled where assigned (-1 otherwise).
    status: (N,) int8 code per row (:data:`STATUS_NAMES`).
    iou: (N,) float64 overlap of the chosen track's box (NaN where not matched here).
    """

    poses: Poses2D
    status: np.ndarray
    iou: np.ndarray

    @property
    def counts(self) -> dict[str, int]:
        """Rows per status, plus ``rejected`` (both kinds) and ``total``; the parts sum to ``total``."""
        c = np.bincount(self.status.astype(np.int64), minlength=len(STATUS_NAMES))
        out = {name: int(c[k]) for k, name in enumerate(STATUS_NAMES)}
        out["rejected"] = out["rejected_no_joints"] + out["rejected_frame"]
        out["total"] = int(len(self.status))
        return out

    def assigned(self) -> Poses2D:
        """The rows that belong to a track (given or assigned here)."""
        return self.poses.subset(np.flatnonzero(self.poses.track_id >= 0))


def pose_boxes(poses: Poses2D, keypoint_margin: float = 0.1) -> np.ndarray:
    """(N, 4) ``[left, top, w, h]`` of each pose: its bbox, else its found keypoints' box.

    The keypoints' box is grown by ``keypoint_margin`` x its size on each side; NaN rows where a
    pose has neither a bbox nor a found keypoint.
    """
    kp = poses.keypoints
    found = (kp[..., 2] > 0) & np.isfinite(kp[..., 0]) & np.isfinite(kp[..., 1])
    x = np.where(found, kp[..., 0], np.nan)
    y = np.where(found, kp[..., 1], np.nan)
    any_found = found.any(axis=1)
    with np.errstate(invalid="ignore"):
        lo_x, hi_x = np.nanmin(np.where(any_found[:, None], x, 0.0), axis=1), np.nanmax(np.where(any_found[:, None], x, 0.0), axis=1)
        lo_y, hi_y = np.nanmin(np.where(any_found[:, None], y, 0.0), axis=1), np.nanmax(np.where(any_found[:, None], y, 0.0), axis=1)
    w, h = hi_x - lo_x, hi_y - lo_y
    # a single joint gives a zero-size box: give it a pixel so IoU stays defined
    kb = np.column_stack([lo_x - keypoint_margin * w, lo_y - keypoint_margin * h,
                          np.maximum(w * (1 + 2 * keypoint_margin), 1.0), np.maximum(h * (1 + 2 * keypoint_margin), 1.0)])
    kb[~any_found] = np.nan
    bb = np.asarray(poses.bbox, dtype=np.float64).reshape(-1, 4)
    has_bb = np.all(np.isfinite(bb), axis=1) & (bb[:, 2] > 0) & (bb[:, 3] > 0)
    return np.where(has_bb[:, None], bb, kb)


def box_iou_pairs(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise IoU of two (M, 4) ``[left, top, w, h]`` arrays -> (M,)."""
    ix = np.clip(np.minimum(a[:, 0] + a[:, 2], b[:, 0] + b[:, 2]) - np.maximum(a[:, 0], b[:, 0]), 0, None)
    iy = np.clip(np.minimum(a[:, 1] + a[:, 3], b[:, 1] + b[:, 3]) - np.maximum(a[:, 1], b[:, 1]), 0, None)
    inter = ix * iy
    union = a[:, 2] * a[:, 3] + b[:, 2] * b[:, 3] - inter
    return np.where(union > 0, inter / np.where(union > 0, union, 1.0), 0.0)


def _join(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All pairs ``(ia, ib)`` with ``a[ia] == b[ib]`` (integer keys), vectorised."""
    order = np.argsort(b, kind="stable")
    bs = b[order]
    lo, hi = np.searchsorted(bs, a, "left"), np.searchsorted(bs, a, "right")
    n = hi - lo
    ia = np.repeat(np.arange(a.size), n)
    start = np.repeat(lo - np.cumsum(n) + n, n)
    ib = order[start + np.arange(ia.size)] if ia.size else np.zeros(0, np.int64)
    return ia, ib


def assign_poses(poses: Poses2D, boxes: Detections, min_iou: float = 0.3, keypoint_margin: float = 0.1,
                 frame_range: tuple[int, int] | None = None, rig=None) -> Assignment:
    """Assign the poses without a ``track_id`` to the 3D tracks whose boxes they overlap.

    poses: N poses (``camera`` indexes the same camera names as ``boxes``).
    boxes: the tracks' boxes in every view, centre form ``[x, y, w, h]`` raw pixels, ``track_id``
        = 3D track id (e.g. ``Detections.concat([result.boxes, result.target_boxes])``); boxes
        with ``track_id`` < 0 are ignored.
    min_iou: gate; a pose whose best IoU with every free track is below it stays unassigned.
    frame_range: (first, last) frames of the tracker output; poses outside are rejected
        (default: the range of ``boxes``' frames; with no boxes every pose is unassigned).
    rig: the cameras (same order); given, a second pass decides by the joints where boxes overlap
        (:mod:`gymtrack.pose.assign_joints`).
    """
    n = len(poses)
    if tuple(boxes.camera_names) != tuple(poses.camera_names):
        raise ValueError(f"poses have cameras {poses.camera_names}, boxes {boxes.camera_names}")
    status = np.full(n, UNASSIGNED, np.int8)
    iou_out = np.full(n, np.nan)
    track = np.asarray(poses.track_id, np.int64).copy()
    pb = pose_boxes(poses, keypoint_margin)
    given = track >= 0
    status[given] = GIVEN
    no_box = ~np.all(np.isfinite(pb), axis=1) & ~given
    status[no_box] = REJECTED_NO_JOINTS
    keep = boxes.track_id >= 0
    bf, bc, bt = boxes.frame[keep], boxes.camera[keep].astype(np.int64), boxes.track_id[keep]
    btlwh = boxes.box[keep].copy()
    btlwh[:, :2] -= btlwh[:, 2:] / 2
    if frame_range is None and bf.size:
        frame_range = (int(bf.min()), int(bf.max()))
    if frame_range is not None:
        outside = ((poses.frame < frame_range[0]) | (poses.frame > frame_range[1])) & ~given & ~no_box
        status[outside] = REJECTED_FRAME
    todo = np.flatnonzero(status == UNASSIGNED)
    if todo.size and bf.size:
        n_cam = max(len(poses.camera_names), 1)
        ia, ib = _join(poses.frame[todo] * n_cam + poses.camera[todo], bf * n_cam + bc)
        pi, iou = todo[ia], box_iou_pairs(pb[todo[ia]], btlwh[ib])
        ti = bt[ib]
        # best IoU per (pose, track) over that track's boxes (body box, b_buf)
        order = np.lexsort((-iou, ti, pi))
        pi, ti, iou = pi[order], ti[order], iou[order]
        first = np.r_[True, (pi[1:] != pi[:-1]) | (ti[1:] != ti[:-1])]
        keep_pairs = first & (iou >= (MIN_OVERLAP if rig is not None else min_iou))
        pi, ti, iou = pi[keep_pairs], ti[keep_pairs], iou[keep_pairs]
        ok = iou >= min_iou
        _hungarian(poses.frame * n_cam + poses.camera, pi[ok], ti[ok], iou[ok], track, status, iou_out)
        if rig is not None and pi.size:  # second pass: the joints decide where boxes overlap
            e = joint_costs(poses, rig, pi, ti, track)
            agree = np.isfinite(e) & (e <= JOINT_GATE)
            allowed = (ok & ~(np.isfinite(e) & (e > 4 * JOINT_GATE))) | agree
            score = 1.0 - ((1.0 - iou) + JOINT_WEIGHT * np.nan_to_num(e, nan=0.0)) / (1.0 + JOINT_WEIGHT)
            redo = np.unique(pi)
            track[redo], status[redo], iou_out[redo] = -1, UNASSIGNED, np.nan
            _hungarian(poses.frame * n_cam + poses.camera, pi[allowed], ti[allowed], score[allowed], track, status,
                       iou_out)
            won = np.flatnonzero(track[pi] == ti)
            iou_out[pi[won]] = iou[won]
    return Assignment(replace(poses, track_id=track), status, iou_out)


def _hungarian(key: np.ndarray, pi: np.ndarray, ti: np.ndarray, iou: np.ndarray, track: np.ndarray,
               status: np.ndarray, iou_out: np.ndarray) -> None:
    """Solve each (frame, camera) group's assignment in place; groups without a conflict directly."""
    if not pi.size:
        return
    g = key[pi]
    order = np.argsort(g, kind="stable")
    pi, ti, iou, g = pi[order], ti[order], iou[order], g[order]
    starts = np.flatnonzero(np.r_[True, g[1:] != g[:-1]])
    ends = np.r_[starts[1:], g.size]
    single = (ends - starts) == 1  # one (pose, track) candidate in the group: no conflict
    s = starts[single]
    track[pi[s]], status[pi[s]], iou_out[pi[s]] = ti[s], ASSIGNED, iou[s]
    for a, b in zip(starts[~single], ends[~single]):
        up, rows = np.unique(pi[a:b], return_inverse=True)
        ut, cols = np.unique(ti[a:b], return_inverse=True)
        cost = np.full((up.size, ut.size), 2.0)  # 2 = gated out (cost 1 - IoU is at most 1)
        cost[rows, cols] = 1.0 - iou[a:b]
        r, c = linear_sum_assignment(cost)
        good = cost[r, c] < 2.0
        track[up[r[good]]] = ut[c[good]]
        status[up[r[good]]] = ASSIGNED
        iou_out[up[r[good]]] = 1.0 - cost[r[good], c[good]]
