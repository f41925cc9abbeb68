"""cascade+ against ground truth on small simulated scenes: Eq. 4's tracking-space test
on a tracklet's mean position (a person at the boundary of S_track is kept), one view alone
never starting a track on the floor (a clutter box) while it may continue one, and Eq. 12 keeping
an over-determined triangulation rather than averaging it with a weaker estimate."""

from __future__ import annotations

import numpy as np

from conftest import as_raw, make_detections, ring_rig, simple_scene
from gymtrack.tracking.linking import merge_overlaps
from gymtrack.tracking.offline import track_detections
from gymtrack.tracking.reconstruct import outliers, outliers_at_mean

SPACE = np.array([-4.0, -4.0, 0.0, 4.0, 4.0, 4.5])  # simple_scene's tracking space


def test_outliers_at_mean_judges_the_mean_position_and_keeps_eq4_speed():
    W = 8
    xyz = np.zeros((4, W, 3))
    xyz[..., 2] = 0.9
    xyz[0, :, 1] = 3.98 + 0.03 * np.array([1, -1] * (W // 2))  # jitters across y = 4, mean inside
    xyz[1, :, 1] = 4.05 + 0.03 * np.array([1, -1] * (W // 2))  # mean outside
    xyz[2, :, 0] = np.r_[np.zeros(W // 2), np.full(W // 2, 1.5)]  # a 1.5 m jump in one frame
    valid = np.ones((4, W), bool)
    valid[3] = False  # nothing valid: an outlier, as in Eq. 4
    mean = xyz[:, :, 1].mean(axis=1)
    assert mean[0] <= 4.0 < mean[1]  # the independent check of what the rule sees
    assert outliers_at_mean(xyz, valid, SPACE, 1.0).tolist() == [False, True, True, True]
    assert outliers(xyz, valid, SPACE, 1.0).tolist() == [True, True, True, True]  # the paper's: any point
    # invalid points do not count in the mean
    xyz[0, 0, 1], valid[0, 0] = 50.0, False
    assert not outliers_at_mean(xyz, valid, SPACE, 1.0)[0]


def test_a_person_at_the_tracking_space_boundary_is_tracked_by_cascade_plus():
    rig = ring_rig([0, 120, 240])
    n = 60
    traj = np.tile([1.0, 3.97, 0.85], (n, 1))[None]  # a coach standing 3 cm inside S_track
    det, _ = make_detections(rig, traj, noise=2.0, seed=3)
    det = as_raw(det)
    plus = track_detections(rig, simple_scene(), det, mode="cascade+").tracks
    paper = track_detections(rig, simple_scene(), det, mode="cascade").tracks
    # against ground truth: cascade+ has the coach in nearly every frame, within 0.3 m, one id
    assert len(plus) >= n - 10
    assert np.abs(plus.xyz - traj[0, plus.frame]).max() < 0.3
    assert np.unique(plus.track_id).size == 1
    assert len(paper) < len(plus)  # Eq. 4 on every point loses windows to the estimate's noise


def test_one_view_alone_never_starts_a_track_on_the_floor_but_continues_one():
    rig = ring_rig([0, 120, 240])
    n = 40
    # both outside the performance space (x > 3), inside the tracking space, on the floor
    alone = np.tile([3.5, -1.0, 0.85], (n, 1))  # only cam0 ever sees this one (a clutter box alike)
    walker = np.stack([np.full(n, 3.5), np.linspace(1.0, 2.0, n), np.full(n, 0.85)], axis=1)
    det, pid = make_detections(rig, np.stack([alone, walker]), visible=np.array([[True, False, False], [True] * 3]))
    late = (det.frame >= 20) & (det.camera > 0) & (pid == 1)  # the walker: two views lose it at frame 20
    det = as_raw(det.select(~late))
    res = track_detections(rig, simple_scene(), det, mode="cascade+")
    tr = res.tracks
    near_alone = np.linalg.norm(tr.xyz - alone[tr.frame], axis=1) < 1.0
    assert not near_alone.any()  # one view never confirmed that person
    on_walker = np.linalg.norm(tr.xyz - walker[tr.frame], axis=1) < 0.5
    assert on_walker.all() and np.unique(tr.track_id).size == 1
    assert tr.frame.max() >= n - 5  # continued by cam0 alone on the floor after frame 20
    assert res.summary["floor_single_view"] > 0 and res.summary["plane_single_view_unlinked"] > 0


def test_merge_keeps_an_over_determined_triangulation():
    # (frame, track) groups: A = a 3-view triangulation and a 2-view plane estimate; B = two 2-view
    # triangulations; C = a 3-view and a 4-view triangulation; D = one plane estimate
    frame = np.array([1, 1, 1, 1, 2, 2, 3])
    track = np.array([0, 0, 1, 1, 0, 0, 0])
    x = np.array([1.0, 1.4, 2.0, 2.2, 3.0, 3.4, 5.0])
    xyz = np.stack([x, np.zeros(7), np.full(7, 0.9)], axis=1)
    source = np.array([0, 1, 0, 0, 0, 0, 1], np.int8)
    views = np.array([3, 2, 2, 2, 3, 4, 1], np.int8)
    top, bottom = np.full(7, 1.8), np.zeros(7)
    plain = merge_overlaps(frame, track, xyz, top, bottom, source, views)
    best = merge_overlaps(frame, track, xyz, top, bottom, source, views, best_only=True)
    assert np.allclose(plain.xyz[:, 0], [1.2, 2.1, 3.2, 5.0])  # Eq. 12: the plain average
    assert np.allclose(best.xyz[:, 0], [1.0, 2.1, 3.2, 5.0])  # only A changes: the 3-view estimate alone
    assert best.n_views.tolist() == [3, 2, 4, 1] and best.source.tolist() == [0, 0, 0, 1]
    assert np.array_equal(best.frame, plain.frame) and np.array_equal(best.track_id, plain.track_id)


def test_a_duplicate_continued_instead_of_the_older_track_hands_back_the_older_id():
    from collections import defaultdict

    from gymtrack.tracking.linking import WindowLinker
    from gymtrack.tracking.types import WindowTracklets3D

    def window(start, xs):
        M = len(xs)
        xyz = np.zeros((M, 10, 3))
        xyz[..., 0] = np.asarray(xs, float)[:, None]
        v = np.ones((M, 10), bool)
        members = np.arange(2 * M).reshape(M, 2)
        return WindowTracklets3D(start, xyz, np.full((M, 10), 1.8), np.zeros((M, 10)), v, np.zeros((M, 10), np.int8),
                                 np.full((M, 10), 2, np.int8), members, np.full(M, -1))

    for older, expect in ((True, 0), (False, 1)):
        counts = defaultdict(int)
        linker = WindowLinker(5, 0.6, 0, 1.0, counts, keep_older=older)
        none = np.zeros(1, bool)
        a = linker.step(window(0, [0.0]), np.array([10, 11]), none, none)
        # window 5: the person's views split into two clusters, 0.2 m apart: a duplicate track is born
        b = linker.step(window(5, [0.0, 0.2]), np.array([10, 11, 20, 21]), np.zeros(2, bool), np.zeros(2, bool))
        assert a.track_id.tolist() == [0] and b.track_id.tolist() == [0, 1]
        # window 10: one cluster, nearer the duplicate (Eq. 10 links it to track 1, track 0 is not continued)
        c = linker.step(window(10, [0.25]), np.array([10, 21]), none, none)
        assert c.track_id.tolist() == [expect]  # cascade+ keeps the older identity
        assert counts["links_older"] == int(older)
    # a young track far from the lost one is not a duplicate: no hand-back
    counts = defaultdict(int)
    linker = WindowLinker(5, 0.6, 0, 1.0, counts, keep_older=True)
    linker.step(window(0, [0.0]), np.array([10, 11]), none, none)
    linker.step(window(5, [0.0, 2.0]), np.array([10, 11, 20, 21]), np.zeros(2, bool), np.zeros(2, bool))
    c = linker.step(window(10, [2.05]), np.array([20, 21]), none, none)
    assert c.track_id.tolist() == [1] and counts["links_older"] == 0
