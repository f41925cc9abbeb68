"""Assigning 2D poses to 3D tracks by their boxes (hand-made boxes)."""

import numpy as np
import pytest

from gymtrack.detections import Detections
from gymtrack.pose.assign import (ASSIGNED, GIVEN, REJECTED_FRAME, REJECTED_NO_JOINTS, UNASSIGNED, assign_poses,
                                  box_iou_pairs, pose_boxes)
from gymtrack.poses import Poses2D
from gymtrack.skeletons import COCO17

CAMS = ("a", "b")


def _kp_in(left, top, w, h):
    """17 keypoints spread over a box (score 0.9)."""
    t = np.linspace(0, 1, 17)
    return np.column_stack([left + w * t, top + h * t, np.full(17, 0.9)])


def _poses(rows):
    """rows: (frame, camera, track_id, keypoints (17, 3), bbox [l, t, w, h] or None)."""
    f, c, tid, kp, bb = zip(*rows)
    bbox = np.array([b if b is not None else [np.nan] * 4 for b in bb], float)
    return Poses2D(np.array(f), np.array(c), np.array(tid), np.stack(kp), bbox, COCO17, CAMS)


def _boxes(rows):
    """rows: (frame, camera, track_id, [left, top, w, h])."""
    f, c, tid, tlwh = zip(*rows)
    tlwh = np.array(tlwh, float)
    xywh = np.column_stack([tlwh[:, 0] + tlwh[:, 2] / 2, tlwh[:, 1] + tlwh[:, 3] / 2, tlwh[:, 2:]])
    return Detections.from_arrays(np.array(f), np.array(c), xywh, CAMS, track_id=np.array(tid))


def test_iou_by_hand():
    a = np.array([[0, 0, 10, 10], [0, 0, 10, 10]], float)
    b = np.array([[5, 0, 10, 10], [20, 20, 5, 5]], float)
    assert box_iou_pairs(a, b) == pytest.approx([50 / 150, 0.0])


def test_keypoint_box_with_margin_and_bbox_preferred():
    kp = _kp_in(100, 200, 50, 100)
    p = _poses([(1, 0, -1, kp, None), (1, 0, -1, kp, [0, 0, 10, 10])])
    b = pose_boxes(p, keypoint_margin=0.1)
    assert b[0] == pytest.approx([95, 190, 60, 120])
    assert b[1] == pytest.approx([0, 0, 10, 10])


def test_hungarian_resolves_a_crossing_and_counts_every_row():
    # frame 5, camera 0: two people side by side, tracks 7 (left) and 8 (right).
    # Pose P0 overlaps both, 8 more (IoU 85/115) than 7 (75/125); P1 is exactly 8's box. Matching
    # each pose to its best track in turn would give 8 to P0; the assignment gives P0 -> 7, P1 -> 8.
    boxes = _boxes([(5, 0, 7, [0, 0, 100, 200]), (5, 0, 8, [40, 0, 100, 200]), (6, 1, 3, [0, 0, 50, 50])])
    no_joints = np.zeros((17, 3))
    p = _poses([
        (5, 0, -1, _kp_in(0, 0, 1, 1), [25, 0, 100, 200]),   # P0
        (5, 0, -1, _kp_in(0, 0, 1, 1), [40, 0, 100, 200]),   # P1: exactly track 8's box
        (5, 1, -1, _kp_in(0, 0, 1, 1), [0, 0, 100, 200]),    # camera 1 has no box at frame 5
        (6, 1, 9, _kp_in(0, 0, 1, 1), None),                 # given a track id: kept
        (6, 1, -1, no_joints, None),                         # nothing found, no bbox
        (99, 0, -1, _kp_in(0, 0, 100, 200), None),           # outside the output's frames
        (6, 1, -1, _kp_in(300, 300, 40, 40), None),          # far from track 3's box: gated
    ])
    a = assign_poses(p, boxes, min_iou=0.3)
    assert a.status.tolist() == [ASSIGNED, ASSIGNED, UNASSIGNED, GIVEN, REJECTED_NO_JOINTS, REJECTED_FRAME, UNASSIGNED]
    assert a.poses.track_id.tolist() == [7, 8, -1, 9, -1, -1, -1]
    assert a.iou[:2] == pytest.approx([75 / 125, 1.0])
    c = a.counts
    assert c == {"given": 1, "assigned": 2, "unassigned": 2, "rejected_no_joints": 1, "rejected_frame": 1,
                 "rejected": 2, "total": 7}
    assert len(a.assigned()) == 3


def test_a_track_scores_its_best_box_and_takes_one_pose():
    # track 4 has a body box and a larger b_buf; a pose run on the b_buf crop matches it exactly.
    boxes = _boxes([(1, 0, 4, [10, 10, 50, 100]), (1, 0, 4, [-20, 0, 110, 110])])
    p = _poses([(1, 0, -1, _kp_in(0, 0, 1, 1), [-20, 0, 110, 110]),
                (1, 0, -1, _kp_in(0, 0, 1, 1), [10, 10, 50, 100])])
    a = assign_poses(p, boxes)
    # both poses want track 4; only one gets it (the assignment is one-to-one)
    assert sorted(a.status.tolist()) == [ASSIGNED, UNASSIGNED]
    assert (a.poses.track_id == 4).sum() == 1


def test_no_boxes_leaves_everything_unassigned():
    p = _poses([(1, 0, -1, _kp_in(0, 0, 10, 10), None)])
    a = assign_poses(p, Detections.empty(CAMS))
    assert a.counts["unassigned"] == 1
