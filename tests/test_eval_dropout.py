"""The camera drop-out section (eval.dropout): silencing, cutting the ground truth, the table."""

from __future__ import annotations

import numpy as np

from gymtrack.detections import Detections
from gymtrack.eval.dropout import after_frame, dropout_markdown, dropout_table, silence_camera
from gymtrack.formats.ground_truth import GroundTruth


def test_silence_camera_removes_only_that_camera_from_the_frame_on():
    frame = np.repeat(np.arange(1, 6), 3)
    cam = np.tile([0, 1, 2], 5)
    det = Detections.from_arrays(frame, cam, np.ones((15, 4)), ("a", "b", "c"))
    out, removed = silence_camera(det, 1, 3)
    assert removed == 3  # frames 3, 4, 5 of camera 1
    assert len(out) == 12
    assert not ((out.camera == 1) & (out.frame >= 3)).any()
    assert ((out.camera == 1) & (out.frame < 3)).sum() == 2


def test_after_frame_cuts_points_and_boxes():
    P, B = 4, 6
    gt = GroundTruth(("a",), np.array([1, 2, 3, 4]), np.array([1, 1, 2, 2]), np.array(["target"] * P, dtype=object),
                     np.zeros((P, 3)), np.ones(P), np.zeros(P), np.array([1, 2, 2, 3, 4, 4]), np.zeros(B, np.int16),
                     np.ones(B, np.int64), np.ones((B, 4)), np.ones(B, bool))
    late = after_frame(gt, 3)
    assert late.frame.tolist() == [3, 4] and late.person_id.tolist() == [2, 2]
    assert late.box_frame.tolist() == [3, 4, 4] and len(late.box) == 3


def test_dropout_table_means_and_pools():
    base = {"aed_sum": 0.0, "aed_n": 0, "cov_covered": 0, "cov_frames": 0}
    rows = [{**base, "method": "m", "mota": 0.5, "idf1": 0.4, "aed_sum": 1.0, "aed_n": 10, "cov_covered": 9, "cov_frames": 10},
            {**base, "method": "m", "mota": 0.7, "idf1": 0.8, "aed_sum": 3.0, "aed_n": 10, "cov_covered": 10, "cov_frames": 10},
            {**base, "method": "t", "mota": 0.1, "idf1": 0.2}]
    t = {r["method"]: r for r in dropout_table(rows)}
    assert np.isclose(t["m"]["mota"], 0.6) and np.isclose(t["m"]["idf1"], 0.6)
    assert np.isclose(t["m"]["aed"], 0.2) and np.isclose(t["m"]["coverage"], 0.95)
    assert np.isnan(t["t"]["aed"]) and t["t"]["routines"] == 1
    md = dropout_markdown([{**r, "from_frame": 300} for r in rows])
    assert "## Camera drop-out" in md and "frame 300" in md and "| m | 2 |" in md
