"""Lifting single snapshots: bone lengths pooled over persons, and views that agree on no body declined."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from gymtrack.errors import InputError
from gymtrack.formats.mvor import MVOR_SKELETON
from gymtrack.pose import LiftOptions, lift_track
from gymtrack.pose.anchor import given_lengths
from gymtrack.pose.snapshots import measure_noise, pooled_bone_lengths
from gymtrack.poses import HOW_PLANE, HOW_TRIANGULATED
from gymtrack.skeletons import COCO17

from conftest import random_rig
from test_pose_lift import body_track, observe

SNAP = LiftOptions(smooth_half_window=0, temporal=None)


def test_a_snapshots_lone_wrist_takes_its_depth_from_its_elbow_and_a_given_forearm(rng):
    rig = random_rig(rng, 4)
    X, centre = body_track(1, pitch_rate=0.0)
    kp = observe(rig, X)
    kp[:, 1:, 9, 2] = 0.0  # the left wrist only in view 0
    normal = np.array([0.0, 1.0, 0.0])
    bones = np.asarray(COCO17.bones).reshape(-1, 2)
    true_len = tuple(np.linalg.norm(X[0, bones[:, 0]] - X[0, bones[:, 1]], axis=1))
    plane = lift_track(rig, kp, COCO17, centre=centre, plane_normal=normal, options=SNAP)
    assert plane.how[0, 9] == HOW_PLANE and plane.counts["joints_bone_pulled"] == 0  # one frame: no length of its own
    given = lift_track(rig, kp, COCO17, centre=centre, plane_normal=normal,
                       options=replace(SNAP, bone_lengths_m=true_len, bone_weight=1.0))
    assert given.counts["joints_bone_pulled"] == 1
    e_plane, e_given = (np.linalg.norm(L.xyz[0, 9] - X[0, 9]) for L in (plane, given))
    assert e_plane > 0.02
    # noise-free: the ray meets the forearm's sphere at the true wrist (the root nearer the plane's point)
    assert e_given < 1e-6
    np.testing.assert_allclose(given.xyz[0, :9], X[0, :9], atol=1e-6)  # the others are untouched


def test_a_tracks_own_bone_length_wins_over_the_given_one(rng):
    rig = random_rig(rng, 4)
    X, centre = body_track(30, pitch_rate=0.0)
    kp = observe(rig, X)
    kp[10:, 1:, 9, 2] = 0.0
    normal = np.array([0.0, 1.0, 0.0])
    own = lift_track(rig, kp, COCO17, centre=centre, plane_normal=normal, options=SNAP)
    wrong = replace(SNAP, bone_lengths_m=tuple(np.full(len(np.asarray(COCO17.bones).reshape(-1, 2)), 0.9)))
    np.testing.assert_array_equal(lift_track(rig, kp, COCO17, centre=centre, plane_normal=normal, options=wrong).xyz,
                                  own.xyz)


def test_pooled_bone_lengths_by_hand():
    K = 25
    bones = np.asarray(MVOR_SKELETON.bones).reshape(-1, 2)
    hn = int(np.flatnonzero((bones[:, 0] == 0) & (bones[:, 1] == 1))[0])  # head - neck
    xyz = np.zeros((K, 10, 3))
    xyz[:, 0, 2] = 0.10 + 0.01 * np.arange(K)  # person k's head 0.10 + 0.01 k above its neck
    how = np.full((K, 10), HOW_TRIANGULATED, np.int8)
    n_views = np.full((K, 10), 2)
    how[24, 0] = HOW_PLANE  # a plane joint's length is a prior, not a measurement
    n_views[23, 1] = 1
    L = pooled_bone_lengths(xyz, how, n_views, MVOR_SKELETON, min_persons=20)
    assert L[hn] == pytest.approx(np.median(0.10 + 0.01 * np.arange(23)))  # persons 0..22
    assert L[hn] == pytest.approx(0.21)
    assert len(L) == len(bones) and np.isnan(pooled_bone_lengths(xyz, how, n_views, MVOR_SKELETON, 24)[hn])


def test_given_bone_lengths_are_checked_against_the_skeleton():
    assert np.isnan(given_lengths(LiftOptions(), COCO17)).all()
    with pytest.raises(InputError, match="bone_lengths_m"):
        given_lengths(LiftOptions(bone_lengths_m=(0.3, 0.2)), COCO17)
    n = len(np.asarray(COCO17.bones).reshape(-1, 2))
    with pytest.raises(InputError, match="> 0"):
        given_lengths(LiftOptions(bone_lengths_m=(-0.3,) * n), COCO17)
    np.testing.assert_array_equal(given_lengths(LiftOptions(bone_lengths_m=(np.nan,) + (0.3,) * (n - 1)), COCO17)[1:], 0.3)


def test_views_of_different_bodies_are_declined_not_guessed(rng):
    """A snapshot (no neighbouring frames) whose two views hold different bodies gives no joint;
    in a track, the temporal prior still places what the view that fits the neighbours shows."""
    rig = random_rig(rng, 2)
    X, _ = body_track(40)
    kp = observe(rig, X, 1.0, rng)
    kp[10:20, 1] = observe(rig, X + np.array([0.9, 0.5, 0.0]), 1.0, rng)[10:20, 1]  # view 1 holds another body
    opt = LiftOptions(smooth_half_window=0, temporal=None)
    keep = lift_track(rig, kp, COCO17, options=opt)
    dec = lift_track(rig, kp, COCO17, options=replace(opt, decline_disagreeing=True))
    assert keep.counts["joints_declined"] == 0 and np.isfinite(keep.xyz[10:20]).all()
    assert dec.counts["frames_fallback"] == 10 and dec.counts["joints_declined"] == 10 * 17
    assert np.isnan(dec.xyz[10:20]).all() and (dec.score[10:20] == 0).all() and (dec.n_views[10:20] == 0).all()
    np.testing.assert_array_equal(dec.xyz[:10], keep.xyz[:10])
    np.testing.assert_array_equal(dec.xyz[20:], keep.xyz[20:])
    # one snapshot cannot measure its own noise: pooled over others (as on MVOR)
    snap_opt = replace(opt, decline_disagreeing=True, noise_frac=measure_noise(rig, kp[:10], COCO17))
    snap = lift_track(rig, kp[12:13], COCO17, options=snap_opt)
    assert np.isnan(snap.xyz).all() and snap.counts["joints_declined"] == 17
    # in a track the prior re-places joints from the view its neighbours agree with: near the truth
    prior = lift_track(rig, kp, COCO17, options=replace(opt, decline_disagreeing=True, temporal=LiftOptions().temporal))
    placed = np.isfinite(prior.xyz[10:20]).all(axis=-1)
    assert placed.any() and prior.counts["joints_prior_ray"] == placed.sum()
    err = np.linalg.norm(prior.xyz[10:20][placed] - X[10:20][placed], axis=-1)
    assert err.mean() < 0.25 * np.linalg.norm(keep.xyz[10:20] - X[10:20], axis=-1).mean()
