"""The temporal prior of the lifting (pose.temporal), against simulated ground truth: a neighbour's
forearm in one of the two views that see it, and a joint one view alone sees."""

from __future__ import annotations

import numpy as np

from gymtrack.pose.lift import LiftOptions, lift_track
from gymtrack.pose.temporal import nan_median_window, ray_foot
from gymtrack.poses import HOW_FUSED, HOW_NONE
from gymtrack.skeletons import COCO17

from conftest import random_rig
from test_pose_lift import body_track, observe

LE, LW = COCO17.index(["left_elbow", "left_wrist"])
NO_PRIOR = LiftOptions(temporal=None)


def _crowd_of_two(rng, T=40):
    """A person and a neighbour 0.6 m beside them, 4 views, the person's left forearm seen by
    views 0 and 1 only (2 and 3 occluded), small pixel noise."""
    rig = random_rig(rng, 4)
    X, _ = body_track(T, pitch_rate=0.0)
    Y = X + np.array([0.45, 0.4, 0.0])
    kp = observe(rig, X, noise=0.5, rng=rng)
    kp[:, 2:, [LE, LW], 2] = 0.0
    return rig, X, Y, kp


def test_a_neighbours_forearm_in_one_of_two_views_gives_way_to_the_view_the_track_agrees_with(rng):
    rig, X, Y, kp = _crowd_of_two(rng)
    # two frames: the smoother's outlier test alone does not catch them (a neighbour's joint that lies
    # on the other view's epipolar line agrees with it, and no rule on two views can tell)
    bad = np.array([25, 26])
    for j in (LE, LW):  # view 0's crop takes the neighbour's forearm in these frames
        kp[bad, 0, j, :2] = rig[0].project(Y[bad, j])
    before = lift_track(rig, kp, COCO17, options=NO_PRIOR)
    after = lift_track(rig, kp, COCO17)
    e0 = np.linalg.norm(before.xyz[bad][:, [LE, LW]] - X[bad][:, [LE, LW]], axis=-1)
    e1 = np.linalg.norm(after.xyz[bad][:, [LE, LW]] - X[bad][:, [LE, LW]], axis=-1)
    L = np.linalg.norm(X[:, LE] - X[:, LW], axis=-1)[0]
    assert (e0 > L / 2).any(), e0  # two views that disagree: the mixed forearm is off
    assert (e1 < L / 4).all(), e1  # the prior chose view 1: its ray, at the neighbouring frames' depth
    assert after.counts["joints_prior_ray"] >= bad.size
    assert (after.how[bad][:, [LE, LW]] == HOW_FUSED).all() and (after.n_views[bad][:, [LE, LW]] == 1).all()
    good = np.setdiff1d(np.arange(len(X)), np.r_[bad - 2, bad - 1, bad, bad + 1, bad + 2])
    np.testing.assert_allclose(after.xyz[good][:, [LE, LW]], before.xyz[good][:, [LE, LW]], atol=1e-9)


def test_a_joint_one_view_alone_sees_takes_its_depth_from_the_neighbouring_frames(rng):
    rig, X, _, kp = _crowd_of_two(rng)
    lone = np.arange(15, 17)
    kp[lone, 0, LW, 2] = 0.0  # only view 1 sees the wrist there: no depth without a prior (no plane)
    before = lift_track(rig, kp, COCO17, options=NO_PRIOR)
    after = lift_track(rig, kp, COCO17)
    assert (before.how[lone, LW] == HOW_NONE).all() and np.isnan(before.xyz[lone, LW]).all()
    err = np.linalg.norm(after.xyz[lone, LW] - X[lone, LW], axis=-1)
    assert (after.how[lone, LW] == HOW_FUSED).all() and (err < 0.5 * 0.146 * 1.65).all(), err  # within half a forearm


def test_prior_is_the_median_of_the_neighbouring_frames_without_the_frame_itself(rng):
    T, J, h = 12, 3, 2
    X = rng.normal(size=(T, J, 3))
    valid = rng.random((T, J)) > 0.3
    med = nan_median_window(X, valid, h, 2)
    for t in range(T):
        for j in range(J):
            ks = [k for k in range(max(0, t - h), min(T, t + h + 1)) if k != t and valid[k, j]]
            if len(ks) < 2:
                assert np.isnan(med[t, j]).all()
            else:
                np.testing.assert_allclose(med[t, j], np.median(X[ks, j], axis=0))


def test_ray_foot_is_the_nearest_point_in_front_of_the_camera():
    o, d = np.zeros(3), np.array([0.0, 0.0, 1.0])
    foot, dist = ray_foot(o, d, np.array([0.3, 0.4, 2.0]))
    np.testing.assert_allclose(foot, [0, 0, 2]) and np.testing.assert_allclose(dist, 0.5)
    foot, dist = ray_foot(o, d, np.array([0.0, 1.0, -3.0]))  # behind the camera: its centre
    np.testing.assert_allclose(foot, 0) and np.testing.assert_allclose(dist, np.sqrt(10))
