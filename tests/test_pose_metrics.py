"""Pose metrics against hand-worked answers."""

import numpy as np
import pytest

from gymtrack.eval.pose_metrics import (CommonError, PoseError, common_error, joint_errors, joint_map, pose_error,
                                        procrustes_align, target_pose_error)


def _square():
    # 4 joints at the corners of a 1 m square in the x-y plane, plus one on the z axis
    return np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1]], float)


def test_mpjpe_and_pck_by_hand():
    gt = _square()[None]
    pred = gt.copy()
    pred[0, 0] += [0.1, 0, 0]      # 100 mm
    pred[0, 1] += [0, 0.3, 0.4]    # 500 mm
    pred[0, 2] = np.nan            # not estimated: no MPJPE pair, a PCK miss
    e = pose_error(pred, gt)
    assert e.mpjpe_n == 4
    assert e.mpjpe == pytest.approx((100 + 500 + 0 + 0) / 4)
    assert e.pck_joints == 5 and e.pck_hits == 3  # 100 mm, 0, 0 within 150 mm
    assert e.pck == pytest.approx(0.6)
    assert e.pose_frames == 1 and e.frames == 1


def test_pa_mpjpe_removes_a_similarity_transform():
    gt = _square()[None]
    a = np.deg2rad(30)
    r = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    pred = 2.0 * gt @ r.T + np.array([5.0, -1.0, 0.5])
    e = pose_error(pred, gt)
    assert e.mpjpe > 1000
    assert e.pa_mpjpe == pytest.approx(0.0, abs=1e-6)
    assert np.allclose(procrustes_align(pred, gt, np.ones((1, 5), bool)), gt, atol=1e-9)


def test_pa_mpjpe_of_a_saddle_by_hand():
    # GT: square corners (+-1, +-1, 0). Pred: corners (1,1), (-1,-1) raised by h, the others
    # lowered by h. Centroids agree; sum g e^T = 0 so the rotation is the identity; scale
    # s = trace(cov) / var(pred) = 2 / (2 + h^2); each joint's residual is
    # |(s - 1) g_xy, s h| = sqrt(2 (s - 1)^2 + s^2 h^2).
    h = 0.1
    gt = np.array([[[1, 1, 0], [-1, -1, 0], [1, -1, 0], [-1, 1, 0]]], float)
    pred = gt + np.array([[[0, 0, h], [0, 0, h], [0, 0, -h], [0, 0, -h]]])
    s = 2 / (2 + h * h)
    want = 1000 * np.sqrt(2 * (s - 1) ** 2 + s * s * h * h)
    e = pose_error(pred, gt)
    assert e.mpjpe == pytest.approx(100.0)
    assert e.pa_mpjpe == pytest.approx(want, rel=1e-9)
    # reflection is not allowed: a mirrored (non-symmetric) pose keeps an error
    g3 = np.array([[[-1, 0, 0], [1, 0, 0], [0.3, 1, 0], [0, 0, 1]]], float)
    assert pose_error(g3 * np.array([-1, 1, 1]), g3).pa_mpjpe > 100.0


def test_pa_needs_three_joints():
    gt = _square()[None]
    pred = gt.copy()
    pred[0, 2:] = np.nan
    e = pose_error(pred, gt)
    assert e.pa_n == 0 and np.isnan(e.pa_mpjpe) and e.mpjpe_n == 2


def test_pooling_is_additive():
    a = PoseError(100.0, 2, 50.0, 2, 1, 2, 1, 3)
    b = PoseError(300.0, 2, 50.0, 2, 2, 2, 1, 1)
    s = a + b
    assert s.mpjpe == pytest.approx(100.0) and s.pck == pytest.approx(0.75) and s.pose_share == pytest.approx(0.5)


def test_target_pose_error_maps_joints_by_name_and_restricts_to_performing_frames():
    gt_joints = ("nose", "left_hip", "right_hip", "left_knee")
    pose_joints = ("neck", "right_hip", "left_hip", "nose")  # another order, one extra, one missing
    gt_frames = np.array([10, 11, 12, 13])
    gt = np.zeros((4, 4, 3))
    gt[:, :, 0] = np.arange(4)[None]  # joint g at x = g
    pose = np.full((3, 4, 3), np.nan)
    pose_frames = np.array([11, 12, 20])
    for r in range(3):
        pose[r, 1] = [2, 0, 0]          # right_hip exact
        pose[r, 2] = [1, 0.2, 0]        # left_hip 200 mm off
        pose[r, 3] = [0, 0, 0.1]        # nose 100 mm off
        pose[r, 0] = [9, 9, 9]          # neck: not in GT, ignored
    e = target_pose_error(pose_frames, pose, pose_joints, gt_frames, gt, gt_joints, perf_frames=[11, 12, 13])
    assert e.frames == 3 and e.pose_frames == 2            # frame 13 has no pose; frame 20 not performing
    assert e.mpjpe_n == 6 and e.mpjpe == pytest.approx((0 + 200 + 100) / 3)
    assert e.pck_joints == 6 and e.pck_hits == 4          # left_knee not in the pose skeleton: not evaluated
    assert joint_map(pose_joints, gt_joints)[1].tolist() == [0, 1, 2]
    # PCK over every performing frame: frame 13 (no pose) counts its 3 evaluable joints as misses
    assert e.gt_joints_all == 9 and e.pck_all == pytest.approx(4 / 9)
    # per-frame, per-joint errors on the performing frames 11, 12, 13 (GT order), NaN where missing
    err = joint_errors(pose_frames, pose, pose_joints, gt_frames, gt, gt_joints, perf_frames=[11, 12, 13])
    want = np.array([[100, 200, 0, np.nan]] * 2 + [[np.nan] * 4])
    np.testing.assert_allclose(err, want, atol=1e-9)


def test_common_frame_mpjpe_by_hand():
    # a: a pose on frames 0 and 1; b: only on frame 1, and without joint 1 there
    a = np.array([[10.0, 20.0], [30.0, 40.0]])
    b = np.array([[np.nan, np.nan], [50.0, np.nan]])
    c = common_error(a, b)
    assert (c.n, c.frames) == (1, 1)  # only (frame 1, joint 0) is estimated by both
    assert c.a == pytest.approx(30.0) and c.b == pytest.approx(50.0)
    # a's own MPJPE (25 mm) averages over an easier frame b never had: not like for like
    assert np.nanmean(a) == pytest.approx(25.0)
    pooled = c + common_error(np.array([[10.0]]), np.array([[20.0]]))
    assert isinstance(pooled, CommonError) and pooled.a == pytest.approx(20.0) and pooled.b == pytest.approx(35.0)
    with pytest.raises(ValueError):
        common_error(a, b[:1])


def test_target_pose_error_rejects_duplicate_frames():
    with pytest.raises(ValueError):
        target_pose_error([1, 1], np.zeros((2, 1, 3)), ["nose"], [1], np.zeros((1, 1, 3)), ["nose"], [1])
