"""cascade+'s link of a view's 2D tracks by 3D motion (tracking.motion_link): the projected
prediction checked against OpenCV, and a two-view scene at a low frame rate where the IoU
tracker breaks one view's track every frame, but the 3D track keeps one id."""

from __future__ import annotations

import cv2
import numpy as np

from conftest import make_detections, ring_rig, simple_scene
from gymtrack.tracking._kernels import motion_link as kernels
from reference.motion_link import (first_boxes, link_costs_numpy, motion_distances, new_tracks_numpy,
                                   keep_views_numpy, old_entries_numpy, window_ends_numpy)
from gymtrack.tracking.offline import track_detections


def _project(cam, X):
    rvec, _ = cv2.Rodrigues(cam.R)
    uv, _ = cv2.projectPoints(np.asarray(X, float).reshape(-1, 1, 3), rvec, cam.t.astype(float), cam.K, None)
    return uv.reshape(-1, 2)


def test_motion_distances_against_opencv():
    rig = ring_rig([0, 90])
    x0, v = np.array([0.5, -1.0, 1.0]), np.array([0.3, 0.0, 0.0])  # last point (frame 10), m per frame (across view 1)
    frames = np.array([[12, 13, 0]])
    ok = np.array([[True, True, False]])
    uv = _project(rig[1], x0 + v * np.array([2, 3])[:, None])  # the prediction at frames 12, 13
    boxes = np.zeros((1, 3, 4))
    boxes[0, :2] = np.c_[uv + [[10.0, 0.0], [0.0, 0.0]], np.full((2, 2), [40.0, 100.0])]  # frame 12: 10 px = 0.25 w off
    D = motion_distances(rig.projections, np.array([1, 1]), np.array([10, 10]), np.stack([x0, x0]),
                         np.stack([v, -v]), frames, boxes, ok)
    assert np.isclose(D[0, 0], 0.25 / 2, atol=1e-6)  # mean of 0.25 and 0 over the two boxes
    assert D[1, 0] > 1.0  # moving the other way: far from the boxes


def test_first_boxes_takes_each_tracks_earliest():
    frame = np.array([5, 3, 4, 9, 2, 7])
    track = np.array([1, 1, 1, 1, 8, 8])
    box = np.arange(24.0).reshape(6, 4)
    f, b, ok = first_boxes(frame, track, box, np.array([1, 8]), 3)
    assert f.tolist() == [[3, 4, 5], [2, 7, 0]] and ok.tolist() == [[True] * 3, [True, True, False]]
    assert np.array_equal(b[0, 0], box[1]) and np.array_equal(b[1, 1], box[5])


def _fast_walker():
    """Two views at 90 degrees; a person stands, speeds up along y over 10 frames and walks on
    at 0.15 m a frame. The IoU threshold is 0.7, so in view 0, where the walk crosses the image,
    consecutive boxes (0.4 m wide) overlap too little once the person moves (IoU 0.45): the
    per-frame shift against the box is what a low frame rate does to a walker. Along view 1's
    axis the boxes keep overlapping."""
    rig = ring_rig([0, 90])
    y = -3.0 + np.cumsum(np.r_[np.zeros(10), np.linspace(0.0, 0.15, 10), np.full(20, 0.15)])
    traj = np.stack([np.full(y.size, 1.5), y, np.full(y.size, 0.85)], axis=1)[None]
    det, _ = make_detections(rig, traj)
    det = det.__class__(det.frame, det.camera, det.box, det.score, np.full(len(det), -1), det.camera_names)
    return rig, traj, det


def test_low_frame_rate_walker_keeps_one_id_by_3d_motion():
    rig, traj, det = _fast_walker()
    scene = simple_scene(relink_frames=0, iou_threshold=0.7)
    res = track_detections(rig, scene, det, mode="cascade+")
    s = res.summary
    assert s["links_3d_motion"] >= 5  # view 0's one-box tracks continued the walker's
    fast = res.tracks.frame >= 22
    assert np.unique(res.tracks.track_id).size == 1
    assert fast.sum() >= 15  # the walk is tracked to the end ...
    err = np.linalg.norm(res.tracks.xyz[fast] - traj[0, res.tracks.frame[fast]], axis=1)
    assert err.max() < 0.2  # ... from both views (the plane x = 0 is 1.5 m away)
    # without it (the paper's cascade) view 0's pieces are too short: the walk is lost or on the plane
    base = track_detections(rig, scene, det, mode="cascade")
    bf = base.tracks.frame >= 22
    assert "links_3d_motion" not in base.summary
    assert bf.sum() == 0 or np.linalg.norm(base.tracks.xyz[bf] - traj[0, base.tracks.frame[bf]], axis=1).max() > 1.0


def test_iou_tracker_rename_continues_the_old_id():
    from gymtrack.tracking.single_view import IoUTracker

    t = IoUTracker(0.5, max_age=2)
    a = t.update(0, np.array([0, 0]), np.array([[100.0, 100, 40, 100], [400, 100, 40, 100]]))
    b = t.update(1, np.array([0]), np.array([[160.0, 100, 40, 100]]))  # track a[0] jumped: a new id
    assert b[0] not in a
    t.rename(b, a[:1])  # 3D motion says it is a[0]; a[0]'s own entry ends
    assert sorted(t.track_id.tolist()) == sorted([a[0], a[1]])
    c = t.update(2, np.array([0, 0]), np.array([[165.0, 100, 40, 100], [400, 100, 40, 100]]))
    assert c.tolist() == [a[0], a[1]]


def _random_round(rng, N=60, L=14, T=4, C=4):
    """Rows of a window (frame order) with old entries and new tracks, some prediction behind a camera."""
    frame = np.sort(rng.integers(100, 112, N))
    track2d = rng.integers(0, 12, N)
    camera = track2d % C
    ubox = np.c_[rng.uniform(200, 1700, (N, 2)), rng.uniform(20, 200, (N, 2))]
    ubox[rng.random(N) < 0.05, 2] = 0.0  # a zero-width box: an infinite offset, as in numpy
    new = np.sort(rng.choice(np.arange(6, 14), T, replace=False))  # 12, 13: no rows
    t_o = rng.choice(np.r_[-1, np.arange(6)], L, replace=False) if L <= 7 else np.r_[np.arange(6), np.full(L - 6, -1)]
    cam_o = rng.integers(0, C, L)
    last_o = rng.integers(95, 108, L)
    lf = rng.integers(98, 106, L)
    lx = rng.uniform(-3, 3, (L, 3))
    lv = rng.normal(0, 0.2, (L, 3))
    P = rng.normal(0, 1, (C, 3, 4)) * 100
    return frame, track2d, camera, ubox, new, cam_o, t_o, last_o, lf, lx, lv, P


def test_link_costs_kernel_equals_numpy_reference_bitwise():
    rng = np.random.default_rng(3)
    finite = 0
    for _ in range(200):
        args = _random_round(rng)
        D = kernels.link_costs(*args, 3, 5)
        R = link_costs_numpy(*args, 3, 5)
        assert np.array_equal(D, R, equal_nan=True)  # same bits: the links can never differ
        finite += np.isfinite(D).sum()
    assert finite > 100  # the comparison saw real costs, not only gated pairs


def test_window_ends_kernels_equal_numpy_reference_bitwise():
    rng = np.random.default_rng(4)
    for _ in range(100):
        M, W, C, K = 7, 10, 4, 9
        valid = rng.random((M, W)) < 0.6
        valid[np.arange(M), rng.integers(0, W, M)] = True
        xyz = rng.normal(0, 2, (M, W, 3))
        members = np.where(rng.random((M, C)) < 0.7, rng.integers(0, K, (M, C)), -1)
        observed = rng.random((K, W)) < 0.5
        ref = window_ends_numpy(xyz, valid, 40, 0.25, members, observed, 40)
        got = kernels.tracklet_ends(xyz, valid, 40, 0.25) + (kernels.last_observed(members, observed, 40),)
        for a, b in zip(got, ref):
            assert a.dtype == b.dtype and np.array_equal(a, b)


def test_remember_kernel_equals_the_numpy_steps():
    """MotionLinker.remember's one call: the ends, last observed frames, the views' 2D tracks and
    what a view without a member keeps (the previous rows' or -1; no segments: zeros, never seen)."""
    rng = np.random.default_rng(5)
    for _ in range(100):
        M, W, C, K, P = 7, 10, 4, int(rng.choice([0, 9])), int(rng.integers(0, 6))
        valid = rng.random((M, W)) < 0.6
        valid[np.arange(M), rng.integers(0, W, M)] = True
        xyz = rng.normal(0, 2, (M, W, 3))
        members = np.where(rng.random((M, C)) < 0.7, rng.integers(0, max(K, 1), (M, C)), -1) if K else np.full((M, C), -1)
        observed = rng.random((K, W)) < 0.5
        track2d = rng.permutation(100)[:K].astype(np.int64)
        track_id = rng.permutation(12)[:M].astype(np.int64)
        prev_track_id, prev_ids = rng.integers(0, 12, P), rng.integers(-1, 50, (P, C))
        lf, lx, lv, last_obs = window_ends_numpy(xyz, valid, 40, 0.25, members, observed if K else np.zeros((1, W), bool),
                                                 40)
        ids = track2d[np.maximum(members, 0)] if K else np.zeros((M, C), np.int64)
        want = (lf, lx, lv, last_obs, keep_views_numpy(members, ids, track_id, prev_track_id, prev_ids), track_id)
        got = kernels.remember(xyz, valid, 40, 0.25, members, observed, 40, track2d, track_id, prev_track_id, prev_ids)
        for a, b in zip(got, want):
            assert a.dtype == b.dtype and np.array_equal(a, b)
        assert got[-1] is not track_id  # (a copy: kept across windows)


def test_new_tracks_kernel_equals_numpy_reference():
    rng = np.random.default_rng(6)
    found = 0
    for _ in range(200):
        frame = np.sort(rng.integers(90, 115, 80))
        track2d = rng.integers(0, 30, 80)
        seen = rng.choice(30, rng.integers(0, 10), replace=False)
        for spread in (1, 100_003):  # small ids (a table over their range) and spread ones (sorted)
            got = kernels.new_tracks(frame, track2d * spread, 100, 110, 105, seen * spread)
            want = new_tracks_numpy(frame, track2d * spread, 100, 110, 105, seen * spread)
            assert got.dtype == want.dtype and np.array_equal(got, want)
            found += len(got)
    assert found > 200


def test_new_near_is_new_tracks_and_the_first_round_within_the_gate():
    """MotionLinker.step's one call: the new tracks, and whether the first round's costs (the
    reference's) have one within the gate; without ends that apply, never near."""
    rng = np.random.default_rng(11)
    near_seen = far_seen = 0
    for _ in range(200):
        M, C = int(rng.integers(1, 8)), 4
        ids = np.where(rng.random((M, C)) < 0.7, rng.integers(0, 6, (M, C)), -1)
        ends = (C, ids, rng.integers(95, 108, (M, C)), rng.permutation(50)[:M], rng.integers(98, 106, M),
                rng.uniform(-3, 3, (M, 3)), rng.normal(0, 0.2, (M, 3)))
        frame, track2d, camera, ubox, *_, P = _random_round(rng)
        seen = rng.choice(12, rng.integers(0, 6), replace=False)
        new_r = new_tracks_numpy(frame, track2d, 100, 110, 105, seen)
        cam_o, t_o, last_o, _, lf, lx, lv = old_entries_numpy(*ends)
        D = link_costs_numpy(frame, track2d, camera, ubox, new_r, cam_o, t_o, last_o, lf, lx, lv, P, 3, 5)
        finite = D[np.isfinite(D)]
        gate = float(rng.choice(finite)) * rng.choice([0.999, 1.0]) if len(finite) else 0.5  # at a cost and just below
        near_r = bool((D <= gate).any())
        for apply in (True, False):
            new, near = kernels.new_near(*ends, frame, track2d, camera, ubox, 100, 110, 105, seen, P, 3, 5, gate, apply)
            assert np.array_equal(new, new_r)
            assert near == (apply and near_r)
        near_seen += near_r
        far_seen += len(new_r) > 0 and not near_r
    assert near_seen > 10 and far_seen > 10


def test_old_entries_kernel_equals_numpy_reference():
    rng = np.random.default_rng(8)
    for _ in range(200):
        M, C = int(rng.integers(1, 12)), 4
        ids = np.where(rng.random((M, C)) < 0.7, rng.integers(0, 20, (M, C)), -1)  # shared ids: one entry each
        last_obs, tid, lf = rng.integers(0, 99, (M, C)), rng.permutation(50)[:M], rng.integers(0, 99, M)
        lx, lv = rng.normal(size=(M, 3)), rng.normal(size=(M, 3))
        got = kernels.old_entries(C, ids, last_obs, tid, lf, lx, lv)
        for a, b in zip(got, old_entries_numpy(C, ids, last_obs, tid, lf, lx, lv)):
            assert a.dtype == b.dtype and np.array_equal(a, b)


def test_keep_views_kernel_equals_numpy_reference():
    rng = np.random.default_rng(9)
    for _ in range(200):
        M, P, C = int(rng.integers(1, 10)), int(rng.integers(1, 10)), 4
        members = np.where(rng.random((M, C)) < 0.6, rng.integers(0, 30, (M, C)), -1)
        ids = rng.integers(0, 50, (M, C))
        track_id = rng.integers(0, 12, M)
        prev_track_id = rng.integers(0, 12, P)  # repeated ids: the last row counts, as in a dict
        prev_ids = rng.integers(-1, 50, (P, C))
        want = keep_views_numpy(members, ids, track_id, prev_track_id, prev_ids)
        got = kernels.keep_views(members, ids.copy(), track_id, prev_track_id, prev_ids)
        assert np.array_equal(got, want)
