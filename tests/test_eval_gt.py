"""Ground-truth reading (gymtrack.formats.ground_truth) and the oracle matching of detections to GT persons (gymtrack.eval.gt)."""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.detections import Detections
from gymtrack.errors import InputError, RoutineError
from gymtrack.eval.gt import box_iou, match_detections_to_gt, with_gt_ids
from gymtrack.formats.ground_truth import GroundTruth, load_ground_truth


def _gt(boxes):
    """A GroundTruth with only boxes (frame, camera, person, box, visible) that matter here."""
    b = list(zip(*boxes))
    return GroundTruth(
        camera_names=("a", "b"),
        frame=np.array([1]), person_id=np.array([1]), role=np.array(["target"]), xyz=np.zeros((1, 3)),
        top_z=np.ones(1), bottom_z=np.zeros(1),
        box_frame=np.array(b[0]), box_camera=np.array(b[1], np.int16), box_person=np.array(b[2]),
        box=np.array(b[3], float), box_visible=np.array(b[4], bool),
    )


def test_box_iou_by_hand():
    a = np.array([100.0, 100.0, 40.0, 100.0])
    b = np.array([110.0, 100.0, 40.0, 100.0])
    # overlap 30 x 100 = 3000; union 4000 + 4000 - 3000 = 5000
    assert box_iou(a, b) == pytest.approx(0.6)
    assert box_iou(a, a + [1000, 0, 0, 0]) == 0.0


def test_oracle_matching_hungarian_false_positives_views_and_visibility():
    A = [100.0, 100.0, 40.0, 100.0]
    B = [110.0, 100.0, 40.0, 100.0]
    gt = _gt([
        (1, 0, 7, A, 1),
        (1, 0, 8, B, 1),
        (1, 1, 9, [500.0, 500.0, 40.0, 100.0], 1),
        (2, 0, 7, A, 0),  # hidden at frame 2
        (3, 1, 9, A, 1),
    ])
    det = Detections.from_arrays(
        frame=[1, 1, 1, 1, 2, 3],
        camera=[0, 0, 0, 1, 0, 1],
        box=[
            [109.0, 100, 40, 100],  # IoU 0.63 with A, 0.95 with B
            [101.0, 100, 40, 100],  # IoU 0.95 with A, 0.63 with B: both are candidates of both
            [900.0, 900, 40, 100],  # a false positive
            A,                       # view 1 has no box there (person 9 is at 500,500)
            A,                       # frame 2: person 7 is hidden
            [104.0, 100, 40, 100],   # frame 3 view 1: IoU 36/44 = 0.82 with person 9
        ],
        camera_names=("a", "b"),
    )
    m = match_detections_to_gt(det, gt)
    assert m.person_id.tolist() == [8, 7, -1, -1, -1, 9]
    assert (m.matched, m.unmatched, m.conflicts_resolved) == (3, 3, 1)
    # counting hidden boxes too, frame 2 matches person 7
    assert match_detections_to_gt(det, gt, visible_only=False).person_id[4] == 7
    # a stricter threshold drops the 0.82 match
    assert match_detections_to_gt(det, gt, iou_min=0.9).person_id.tolist() == [8, 7, -1, -1, -1, -1]
    det2, _ = with_gt_ids(det, gt)
    assert det2.track_id.tolist() == [8, 7, -1, -1, -1, 9] and det.track_id.tolist() == [-1] * 6


def test_load_ground_truth(tmp_path):
    gt_dir = tmp_path / "gt"
    (gt_dir / "boxes_2d").mkdir(parents=True)
    (gt_dir / "persons_3d.csv").write_text(
        "frame,person_id,role,x,y,z,top_z,bottom_z\n"
        "1,1,target,0,0,1,2,0\n"
        "1,2,coach,3,0,1,1.8,0\n"
        "2,1,target,0.1,0,1.2,2.2,0.2\n"
    )
    (gt_dir / "boxes_2d" / "c0.txt").write_text("1,1,10,20,40,100,1,-1,-1,-1\n2,1,12,20,40,100,0,-1,-1,-1\n")
    (gt_dir / "boxes_2d" / "c1.txt").write_text("1,2,5,5,10,10,1,-1,-1,-1\n")
    gt = load_ground_truth(tmp_path, ["c0", "c1"])
    assert gt.target_id == 1
    t = gt.target()
    assert t.frame.tolist() == [1, 2] and t.box_frame.tolist() == [1, 2]
    np.testing.assert_allclose(gt.box[0], [30, 70, 40, 100])  # centre form
    assert gt.box_visible.tolist() == [True, False, True] and gt.box_camera.tolist() == [0, 0, 1]
    assert gt.performing(np.array([-1, -1, 0, 1, 1, 3])).tolist() == [True, False, True]
    sub = gt.subset_cameras(["c1"])
    assert sub.box_camera.tolist() == [0] and sub.box_person.tolist() == [2]


def test_load_ground_truth_errors_name_file_and_line(tmp_path):
    gt_dir = tmp_path / "gt"
    (gt_dir / "boxes_2d").mkdir(parents=True)
    (gt_dir / "persons_3d.csv").write_text("frame,person_id,role,x,y,z,top_z,bottom_z\n1,1,target,0,0,1,2,0\n2,1,dancer,0,0,1,2,0\n")
    with pytest.raises(RoutineError, match=r"persons_3d.csv: line 3: field 'role'"):
        load_ground_truth(tmp_path, ["c0"])
    (gt_dir / "persons_3d.csv").write_text("frame,person_id,role,x,y,z,top_z,bottom_z\n1,1,target,0,zero,1,2,0\n")
    with pytest.raises(RoutineError, match=r"line 2: field 'y'"):
        load_ground_truth(tmp_path, ["c0"])
    (gt_dir / "persons_3d.csv").write_text("1,1,target,0,0,1,2,0\n")
    with pytest.raises(InputError, match=r"c0.txt: file not found"):
        load_ground_truth(tmp_path, ["c0"])
