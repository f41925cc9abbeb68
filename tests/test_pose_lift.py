"""3D lifting of one track's 2D poses: DLT against OpenCV and truth, and the
robust lifting's parts (swaps, outlier views, plane anchoring, bones, smoothing) on synthetic
bodies seen by random rigs."""

from __future__ import annotations

from dataclasses import replace

import cv2
import numpy as np
import pytest

from gymtrack.errors import InputError
from gymtrack.geometry import Camera, Plane, Rig, intersect_rays_plane
from gymtrack.geometry.camera import look_at
from gymtrack.pose import LiftOptions, lift_track
from gymtrack.pose.identity import TorsoIdentity
from gymtrack.pose.dlt import fuse_rays_plane, rays
from gymtrack.pose.snapshots import measure_noise
from gymtrack.pose.smooth import smooth_track
from gymtrack.poses import HOW_FUSED, HOW_NONE, HOW_PLANE, HOW_TRIANGULATED
from gymtrack.simulate.body import BodyModel, gait_angles
from gymtrack.skeletons import COCO17, custom_skeleton

from conftest import random_rig

FLIP = COCO17.flip
NO_SMOOTH = LiftOptions(smooth_half_window=0)


def body_track(T: int, centre0=(0.0, 0.0, 1.2), pitch_rate: float = np.pi) -> tuple[np.ndarray, np.ndarray]:
    """(T, 17, 3) COCO joints of a walking body that turns over (salto-like pitch), and its (T, 3) centre."""
    t = np.arange(T) / 30.0
    rel, _ = BodyModel(1.65).oriented(gait_angles(2 * np.pi * t), np.full(T, 0.3), pitch_rate * t, np.zeros(T))
    centre = np.asarray(centre0) + np.stack([np.sin(t), 0.2 * np.cos(t), 0.3 * np.sin(2 * t)], axis=1)
    return rel[:, :17] + centre[:, None], centre


def observe(rig: Rig, X: np.ndarray, noise: float = 0.0, rng=None, score: float = 0.9) -> np.ndarray:
    """(T, C, J, 3) raw pixels [x, y, score] of joints X (T, J, 3) in every camera."""
    kp = np.zeros(X.shape[:1] + (len(rig),) + X.shape[1:2] + (3,))
    for c, cam in enumerate(rig):
        kp[:, c, :, :2] = cam.project(X)
    if noise:
        kp[..., :2] += rng.normal(0.0, noise, kp[..., :2].shape)
    kp[..., 2] = score
    return kp


def mpjpe(L, X, sel=None) -> float:
    err = np.linalg.norm(L.xyz - X, axis=2)
    return float(np.nanmean(err if sel is None else err[sel]))


# --------------------------------------------------------------------------- DLT (paper Eq. 3)
def test_dlt_two_views_match_opencv(rng):
    rig = random_rig(rng, 2)
    X, _ = body_track(30)
    kp = observe(rig, X)
    L = lift_track(rig, kp, COCO17, "dlt", options=LiftOptions(dlt_refine=0))
    Xcv = cv2.triangulatePoints(rig[0].P, rig[1].P, kp[:, 0, :, :2].reshape(-1, 2).T.copy(),
                                kp[:, 1, :, :2].reshape(-1, 2).T.copy())
    Xcv = (Xcv[:3] / Xcv[3]).T.reshape(X.shape)
    np.testing.assert_allclose(L.xyz, Xcv, atol=1e-6)
    np.testing.assert_allclose(L.xyz, X, atol=1e-7)
    assert np.all(L.how == HOW_TRIANGULATED) and np.all(L.n_views == 2)
    # with noise the linear estimates differ only by the rows' normalisation; refinement lowers the error
    noisy = observe(rig, X, 1.5, rng)
    lin = lift_track(rig, noisy, COCO17, "dlt", options=LiftOptions(dlt_refine=0))
    Xcv = cv2.triangulatePoints(rig[0].P, rig[1].P, noisy[:, 0, :, :2].reshape(-1, 2).T.copy(),
                                noisy[:, 1, :, :2].reshape(-1, 2).T.copy())
    Xcv = (Xcv[:3] / Xcv[3]).T.reshape(X.shape)
    assert np.median(np.linalg.norm(lin.xyz - Xcv, axis=2)) < 0.01
    ref = lift_track(rig, noisy, COCO17, "dlt")
    assert np.mean(ref.reproj_px) <= np.mean(lin.reproj_px) + 1e-9


@pytest.mark.parametrize("n_cam,distortion", [(3, None), (4, 5), (4, 8)])
def test_noise_free_exact_recovery(rng, n_cam, distortion):
    rig = random_rig(rng, n_cam, distortion)
    X, centre = body_track(60)
    kp = observe(rig, X)
    for method in ("dlt", "robust"):
        L = lift_track(rig, kp, COCO17, method, centre=centre, plane_normal=[0, 1, 0], options=NO_SMOOTH)
        np.testing.assert_allclose(L.xyz, X, atol=1e-6, err_msg=method)
        assert np.all(L.how == HOW_TRIANGULATED)
        assert np.all(L.n_views == n_cam)
        assert np.nanmax(L.reproj_px) < 1e-4
        np.testing.assert_allclose(L.score, 0.9, atol=1e-6)  # the 2D score, nothing lost to reprojection


def test_missing_views_and_low_scores_are_not_used(rng):
    rig = random_rig(rng, 4)
    X, _ = body_track(20)
    kp = observe(rig, X)
    kp[:, 0, :5, :2] = np.nan  # not found in view 0
    kp[:, 1, :5, 2] = 0.1  # below min_score in view 1: a wrong position must not matter
    kp[:, 1, :5, :2] += 300.0
    for method in ("dlt", "robust"):
        L = lift_track(rig, kp, COCO17, method, options=NO_SMOOTH)
        np.testing.assert_allclose(L.xyz, X, atol=1e-6)
        assert np.all(L.n_views[:, :5] == 2) and np.all(L.n_views[:, 5:] == 4)


# --------------------------------------------------------------------------- robust lifting
def test_a_swapped_view_is_corrected(rng):
    rig = random_rig(rng, 4)
    X, _ = body_track(120)
    kp = observe(rig, X, 1.0, rng)
    # the gate scales with the noise measured on the track, which the swapped view inflates: fix
    # it to the clean keypoints' level, so that both runs have the same gate
    opt = LiftOptions(smooth_half_window=0, noise_frac=measure_noise(rig, kp, COCO17))
    clean = lift_track(rig, kp, COCO17, options=opt)
    kp[40:100, 2] = kp[40:100, 2][:, FLIP]  # the pose model swapped left and right in view 2
    dlt = lift_track(rig, kp, COCO17, "dlt")
    rob = lift_track(rig, kp, COCO17, options=opt)
    assert rob.counts["views_swapped"] == 60
    np.testing.assert_allclose(rob.xyz, clean.xyz, atol=1e-9)  # exactly the unswapped answer
    assert mpjpe(dlt, X, slice(40, 100)) > 2 * mpjpe(rob, X, slice(40, 100))


def test_a_legs_only_swap_is_corrected(rng):
    """A pose model also swaps the legs alone; reading the whole view mirrored cannot fix that."""
    rig = random_rig(rng, 4)
    X, _ = body_track(80)
    kp = observe(rig, X, 1.0, rng)
    opt = LiftOptions(smooth_half_window=0, noise_frac=measure_noise(rig, kp, COCO17))
    clean = lift_track(rig, kp, COCO17, options=opt)
    legs = np.arange(11, 17)
    kp[20:60, 1, legs] = kp[20:60, 1][:, FLIP[legs]]  # view 1: hips, knees and ankles read left <-> right
    rob = lift_track(rig, kp, COCO17, options=opt)
    unnamed = custom_skeleton(COCO17.joints[:11] + tuple(
        n.replace("hip", "hp").replace("knee", "kn").replace("ankle", "ak") for n in COCO17.joints[11:]))
    whole = lift_track(rig, kp, unnamed, options=opt)
    # a frame whose legs pass each other reads alike both ways: the view is then dropped instead
    assert rob.counts["views_legs_swapped"] >= 36 and rob.counts["views_swapped"] == 0
    same = np.all(np.abs(rob.xyz - clean.xyz) < 1e-9, axis=(1, 2))
    assert same.sum() >= 76
    assert mpjpe(rob, X, (slice(20, 60), legs)) < mpjpe(clean, X, (slice(20, 60), legs)) + 0.002
    # without named legs (whole-body readings only) only the per-joint drop of the worst view helps
    assert mpjpe(whole, X, (slice(20, 60), legs)) > 1.3 * mpjpe(rob, X, (slice(20, 60), legs))


@pytest.mark.parametrize("swapped_view", [0, 1])
def test_two_views_one_swapped_follows_the_neighbouring_frames(rng, swapped_view):
    """Two views, one swapped: geometry alone cannot say which; the neighbouring frames can."""
    rig = random_rig(rng, 2)
    X, _ = body_track(90)
    kp = observe(rig, X, 0.5, rng)
    kp[30:50, swapped_view] = kp[30:50, swapped_view][:, FLIP]
    rob = lift_track(rig, kp, COCO17, options=NO_SMOOTH)
    dlt = lift_track(rig, kp, COCO17, "dlt")
    err = np.linalg.norm(rob.xyz - X, axis=2)[30:50]
    assert np.nanmax(err) < 0.1  # every joint on the right side
    assert mpjpe(dlt, X, slice(30, 50)) > 3 * float(np.nanmean(err))


def test_an_outlier_view_is_dropped(rng):
    rig = random_rig(rng, 4)
    X, _ = body_track(100)
    kp = observe(rig, X, 1.0, rng)
    without = kp.copy()
    without[20:70, 1, :, 2] = 0.0
    clean = lift_track(rig, without, COCO17, options=NO_SMOOTH)  # what the three good views give
    other = observe(rig, X + np.array([0.7, 0.4, 0.0]), 1.0, rng)  # another person in view 1's crop
    kp[20:70, 1] = other[20:70, 1]
    dlt = lift_track(rig, kp, COCO17, "dlt")
    assert lift_track(rig, kp, COCO17, options=NO_SMOOTH).counts["views_dropped"] == 50  # the consensus drops it
    rob = lift_track(rig, kp, COCO17, options=replace(NO_SMOOTH, identity=TorsoIdentity()))
    assert rob.counts["views_foreign"] == 50 and rob.foreign[20:70, 1].all()  # its torso: another body (.identity)
    assert rob.counts["views_dropped"] <= 2  # so the consensus has (nearly) nothing left to drop
    assert np.all(rob.n_views[20:70] == 3)
    np.testing.assert_allclose(rob.xyz[20:70], clean.xyz[20:70], atol=1e-9)
    assert mpjpe(dlt, X, slice(20, 70)) > 3 * mpjpe(rob, X, slice(20, 70))


def test_two_views_of_different_bodies_still_give_every_joint_dlt_gives(rng):
    """No two views agree (each sees another body): robust keeps them all, flagged, low score --
    it must never estimate fewer joints than dlt only because its consensus failed. (With the
    identity rule on, the track's other frames tell the foreign view, which is set aside.)"""
    rig = random_rig(rng, 2)
    X, centre = body_track(40)
    kp = observe(rig, X, 1.0, rng)
    other = observe(rig, X + np.array([0.9, 0.5, 0.0]), 1.0, rng)
    kp[10:20, 1] = other[10:20, 1]  # view 1's crop holds another body for 10 frames
    dlt = lift_track(rig, kp, COCO17, "dlt")
    ruled = lift_track(rig, kp, COCO17, centre=centre, plane_normal=np.array([0.0, 0.0, 1.0]),
                       options=replace(NO_SMOOTH, identity=TorsoIdentity()))
    assert ruled.foreign[10:20, 1].all() and ruled.counts["views_foreign"] <= 12  # (a body's own view, rarely)
    assert np.isfinite(ruled.xyz[10:20]).all(-1).mean() > 0.8  # view 0 alone, on the plane through the centre
    e_rule, e_dlt = (np.nanmedian(np.linalg.norm(L.xyz[10:20] - X[10:20], axis=-1)) for L in (ruled, dlt))
    assert e_rule < 0.5 * e_dlt  # nearer the truth than the mixed two-body triangulation
    rob = lift_track(rig, kp, COCO17, options=NO_SMOOTH)
    assert rob.counts["frames_fallback"] == 10 and rob.counts["views_dropped"] == 0
    np.testing.assert_array_equal(np.isfinite(rob.xyz), np.isfinite(dlt.xyz))
    assert np.all(rob.score[10:20] <= 0.3 * 0.9 + 1e-9)  # flagged by its score
    assert rob.score[:10].min() > 0.3 and rob.score[20:].min() > 0.3


def test_one_wrong_joint_in_one_view_is_dropped(rng):
    rig = random_rig(rng, 4)
    X, _ = body_track(40)
    kp = observe(rig, X)
    kp[:, 3, 9, :2] += 80.0  # a wrist 80 px off in view 3
    rob = lift_track(rig, kp, COCO17, options=NO_SMOOTH)
    assert rob.counts["joint_views_dropped"] == 40
    np.testing.assert_allclose(rob.xyz, X, atol=1e-6)
    assert np.all(rob.n_views[:, 9] == 3)


def opposite_rig() -> Rig:
    """Two cameras facing each other across the plane y = 0 (lines of sight ~178 degrees), one
    at the side: the joints only the opposite pair sees are the degenerate case."""
    K = np.array([[1500.0, 0, 960], [0, 1500.0, 540], [0, 0, 1]])
    cams = []
    for name, pos in (("a", (0.3, -13.0, 1.3)), ("b", (-0.3, 13.0, 1.1)), ("side", (12.0, 2.0, 4.0))):
        R, t = look_at(np.array(pos), np.array([0.0, 0.0, 1.2]))
        cams.append(Camera(name, (1920, 1080), K, R, t))
    return Rig(cams)


def test_opposite_pair_only_joints_are_anchored_on_the_plane(rng):
    rig = opposite_rig()
    T = 60
    X, centre = body_track(T, pitch_rate=0.0)
    X[..., 1] = centre[:, None, 1] + 0.15 * (X[..., 1] - centre[:, None, 1])  # joints within ~0.1 m of the plane
    kp = observe(rig, X, 1.5, rng)
    kp[:, 2, 5:, 2] = 0.0  # the side view finds only the head: the body is an opposite pair's
    normal = np.array([0.0, 1.0, 0.0])
    dlt = lift_track(rig, kp, COCO17, "dlt")
    plain = lift_track(rig, kp, COCO17, options=NO_SMOOTH)  # robust without the plane: the ablation
    anchored = lift_track(rig, kp, COCO17, centre=centre, plane_normal=normal, options=NO_SMOOTH)
    body = np.s_[:, 5:]
    assert np.all(anchored.how[body] == HOW_FUSED)
    assert np.all(plain.how[body] == HOW_TRIANGULATED)
    assert anchored.counts["joints_fused"] == T * 12
    e_dlt, e_anchor = mpjpe(dlt, X, body), mpjpe(anchored, X, body)
    assert e_dlt > 0.15  # the degenerate depth: decimetres from a pixel and a half
    assert e_anchor < 0.4 * e_dlt
    assert mpjpe(plain, X, body) > 2 * e_anchor
    # the head, seen by all three, is triangulated and untouched by the plane
    assert np.all(anchored.how[:, :5] == HOW_TRIANGULATED)
    assert np.all(anchored.score[body] < anchored.score[:, :5].min())  # a prior, not a measurement


def test_single_view_joints_need_the_plane(rng):
    rig = random_rig(rng, 4)
    X, centre = body_track(30, pitch_rate=0.0)
    kp = observe(rig, X)
    kp[10:, 1:, 9, 2] = 0.0  # the left wrist only in view 0 after frame 10
    normal = np.array([0.0, 1.0, 0.0])
    lone_view = np.s_[10:, 9]
    plane_only = replace(NO_SMOOTH, temporal=None)  # the plane's own rule (the temporal prior: test_pose_temporal)
    bare = lift_track(rig, kp, COCO17, options=plane_only)
    assert np.all(bare.how[lone_view] == HOW_NONE) and np.all(np.isnan(bare.xyz[lone_view]))
    assert bare.counts["joints_unobservable"] == 20
    assert np.all(bare.score[lone_view] == 0)
    lone = lift_track(rig, kp, COCO17, centre=centre, plane_normal=normal,
                      options=LiftOptions(smooth_half_window=0, bone_iterations=0, temporal=None))
    assert np.all(lone.how[lone_view] == HOW_PLANE) and np.all(lone.how[:10, 9] == HOW_TRIANGULATED)
    # one ray and the plane: exactly the paper's ray-plane intersection (Eq. 7)
    cam = rig[0]
    ray = cam.rays(kp[10:, 0, 9, :2])
    Xp = np.stack([intersect_rays_plane(cam.centre, ray[t - 10], Plane(centre[t], normal))[0] for t in range(10, 30)])
    np.testing.assert_allclose(lone.xyz[lone_view], Xp, atol=1e-6)
    # the forearm's length from the first 10 frames then pulls the wrist along its ray
    pulled = lift_track(rig, kp, COCO17, centre=centre, plane_normal=normal, options=plane_only)
    assert pulled.counts["joints_bone_pulled"] == 20
    assert mpjpe(pulled, X, lone_view) < 0.5 * mpjpe(lone, X, lone_view)
    forearm = np.linalg.norm(X[0, 9] - X[0, 7])
    gap = np.linalg.norm(lone.xyz[10:, 9] - lone.xyz[10:, 7], axis=1) - forearm
    gap_pulled = np.linalg.norm(pulled.xyz[10:, 9] - pulled.xyz[10:, 7], axis=1) - forearm
    assert np.all(np.abs(gap_pulled) <= 0.3 * np.abs(gap) + 1e-6)  # 70 % of the way per pass


def test_fusion_of_one_ray_is_the_ray_plane_intersection_and_two_rays_triangulate(rng):
    rig = random_rig(rng, 2)
    P = rng.uniform(-1, 1, size=(50, 3)) + [0, 0, 1.2]
    uv = np.stack([cam.project(P, distort=False) for cam in rig])  # (2, 50, 2)
    K = np.stack([c.K for c in rig])
    R = np.stack([c.R for c in rig])
    d = rays(K, R, uv[..., 0], uv[..., 1])
    o = rig.centres
    n = np.array([0.3, 0.9, 0.1]) / np.linalg.norm([0.3, 0.9, 0.1])
    point = np.zeros((3, 50))
    one = fuse_rays_plane(o, d, np.array([[1e4] * 50, [0.0] * 50]), point, n, 0.25)
    ref, _ = intersect_rays_plane(o[0], d[0].T, Plane(np.zeros(3), n))
    np.testing.assert_allclose(one.T, ref, atol=1e-6)
    # two well-spread exact rays outweigh a loose plane prior
    two = fuse_rays_plane(o, d, np.full((2, 50), 1e6), point, n, 10.0)
    np.testing.assert_allclose(two.T, P, atol=1e-4)


# --------------------------------------------------------------------------- smoothing
def test_smoothing_keeps_a_flight_exact_and_replaces_an_outlier(rng):
    T = 60
    t = np.arange(T) / 30.0
    flight = np.stack([2.0 * t, 0.1 * t, 1.0 + 4.0 * t - 4.905 * t**2], axis=1)[:, None]  # (T, 1, 3) ballistic
    out, outl = smooth_track(flight, np.ones((T, 1)), 3, 0.15)
    np.testing.assert_allclose(out, flight, atol=1e-9)  # constant acceleration: not blurred at all
    assert not outl.any()
    noisy = flight + rng.normal(0, 0.02, flight.shape)
    noisy[30, 0] += [0.0, 0.0, 0.5]  # a wrong joint
    noisy[10, 0] = np.nan  # missing stays missing
    w = np.ones((T, 1))
    out, outl = smooth_track(noisy, w, 3, 0.15)
    assert outl[30, 0] and outl.sum() == 1
    assert np.isnan(out[10, 0]).all()
    err_in = np.nanmean(np.linalg.norm(noisy - flight, axis=2)[np.arange(T) != 30])
    err_out = np.nanmean(np.linalg.norm(out - flight, axis=2))
    assert err_out < 0.75 * err_in
    assert np.linalg.norm(out[30, 0] - flight[30, 0]) < 0.06


def test_robust_smoothing_lowers_noise_on_a_moving_body(rng):
    rig = random_rig(rng, 4)
    X, _ = body_track(150)
    kp = observe(rig, X, 3.0, rng)
    raw = lift_track(rig, kp, COCO17, options=NO_SMOOTH)
    smooth = lift_track(rig, kp, COCO17)
    assert mpjpe(smooth, X) < 0.9 * mpjpe(raw, X)


# --------------------------------------------------------------------------- outputs and errors
def test_scores_how_and_poses3d_rows(rng):
    rig = random_rig(rng, 4)
    X, centre = body_track(20)
    kp = observe(rig, X, 2.0, rng)
    kp[5] = np.nan  # a frame without any pose
    L = lift_track(rig, kp, COCO17, centre=centre, plane_normal=[0, 1, 0])
    assert L.xyz.shape == (20, 17, 3) and L.score.shape == L.n_views.shape == L.how.shape == (20, 17)
    assert L.how.dtype == np.int8 and L.n_views.dtype == np.int64
    assert np.all((L.score >= 0) & (L.score <= 1))
    assert np.all(L.how[5] == HOW_NONE) and np.all(L.score[5] == 0) and np.isnan(L.reproj_px[5]).all()
    rows = L.to_poses3d(np.arange(100, 120), 7, COCO17)
    assert len(rows) == 19 and 105 not in rows.frame and np.all(rows.track_id == 7)


def test_invalid_arguments_raise_clear_errors(rng):
    rig = random_rig(rng, 3)
    kp = observe(rig, body_track(5)[0])
    with pytest.raises(InputError, match="unknown lifting method 'svd'"):
        lift_track(rig, kp, COCO17, "svd")
    with pytest.raises(InputError, match=r"keypoints must be \(T, C=3, J=17, 3\).*got shape \(5, 2, 17, 3\)"):
        lift_track(rig, kp[:, :2], COCO17)
    with pytest.raises(InputError, match="got shape"):
        lift_track(rig, kp[..., :2], COCO17)
    with pytest.raises(InputError, match="both centre and plane_normal"):
        lift_track(rig, kp, COCO17, centre=np.zeros((5, 3)))
    with pytest.raises(InputError, match=r"centre must be \(T=5, 3\)"):
        lift_track(rig, kp, COCO17, centre=np.zeros((4, 3)), plane_normal=[0, 1, 0])
    with pytest.raises(InputError, match="plane_normal"):
        lift_track(rig, kp, COCO17, centre=np.zeros((5, 3)), plane_normal=[0, 0, 0])
    bad = kp.copy()
    bad[2, 1, 4, 2] = -0.5
    with pytest.raises(InputError, match="scores must be >= 0.*camera cam1, joint right_ear"):
        lift_track(rig, bad, COCO17)
    # a score above 1 (OpenPose's heatmap peaks) is a weight of 1: the same result as 1
    hi, one = kp.copy(), kp.copy()
    hi[:, :, :, 2] = np.where(hi[:, :, :, 2] > 0, 1.04, 0)
    one[:, :, :, 2] = np.where(one[:, :, :, 2] > 0, 1.0, 0)
    assert np.allclose(lift_track(rig, hi, COCO17).xyz, lift_track(rig, one, COCO17).xyz, equal_nan=True)
    with pytest.raises(ValueError, match="flip_ratio"):
        LiftOptions(flip_ratio=2.0)
    with pytest.raises(InputError, match="min_score"):
        LiftOptions(min_score=-0.1)
