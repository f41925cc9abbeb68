"""The floor hypothesis of cascade+ (tracking.floor): ground positions and heights from box
bottoms and tops (checked against points projected with OpenCV), matching across views, the
place and the air deciding between floor and apparatus plane, the ghost test, the tracker mode."""

from __future__ import annotations

import cv2
import numpy as np

from conftest import make_detections, ring_rig, simple_scene
from gymtrack.tracking.floor import drop_floor_ghosts, floor_candidates, floor_stage
from gymtrack.tracking.offline import track_detections
from gymtrack.modes import MODES
from gymtrack.tracking.types import WindowTracklets, WindowTracklets3D

W = 6


def _project(cam, X):
    rvec, _ = cv2.Rodrigues(cam.R)
    uv, _ = cv2.projectPoints(np.asarray(X, float).reshape(-1, 1, 3), rvec, cam.t.astype(float), cam.K, None)
    return uv.reshape(-1, 2)


def _segments(rig, people):
    """One segment per (person, camera): boxes whose bottom/top centres are the projections of
    the person's feet point (x, y, z_bottom) and head point (x, y, z_top), constant over W frames."""
    box, cam = [], []
    for x, y, zb, zt in people:
        for c, camera in enumerate(rig):
            b, t = _project(camera, [[x, y, zb], [x, y, zt]])
            h = b[1] - t[1]
            box.append(np.tile([b[0], (b[1] + t[1]) / 2, 0.4 * h, h], (W, 1)))
            cam.append(c)
    K = len(cam)
    ok = np.ones((K, W), bool)
    return WindowTracklets(0, np.array(cam), np.arange(K, dtype=np.int64), np.array(box), ok, ok,
                           np.arange(K * W).reshape(K, W))


def test_floor_candidates_recover_ground_position_and_height():
    rig = ring_rig([0, 90, 200], radius=10.0, height=3.0)
    segs = _segments(rig, [(1.5, -2.0, 0.0, 1.8), (-4.0, 3.0, 0.0, 1.2)])
    foot, height, ok = floor_candidates(segs, rig.arrays)
    assert ok.all()
    assert np.allclose(foot[:3], [1.5, -2.0], atol=1e-6) and np.allclose(foot[3:], [-4.0, 3.0], atol=1e-6)
    # the box's top-centre is not exactly the head's projection (a vertical line projects tilted)
    assert np.allclose(height[:3], 1.8, atol=0.01) and np.allclose(height[3:], 1.2, atol=0.02)
    assert not np.allclose(height[:3], 1.7, atol=0.05)


def test_floor_stage_takes_people_on_the_floor_not_in_the_air():
    rig = ring_rig([0, 90, 200], radius=10.0, height=3.0)
    space = np.array([-3.0, -3.0, 0.0, 3.0, 3.0, 4.5])
    # a coach on the floor inside the space, a gymnast whose feet are 1.2 m up inside it
    segs = _segments(rig, [(1.0, 1.0, 0.0, 1.8), (0.0, -1.0, 1.2, 2.6)])
    fl, used = floor_stage(segs, rig.arrays, 0.5, space)
    assert used.tolist() == [True] * 3 + [False] * 3
    assert len(fl) == 1 and sorted(fl.members[0].tolist()) == [0, 1, 2]
    assert np.allclose(fl.xyz[0, :, :2], [1.0, 1.0], atol=1e-6) and np.allclose(fl.xyz[0, :, 2], 0.9, atol=0.02)
    assert np.allclose(fl.bottom_z[0], 0.0) and np.allclose(fl.top_z[0], 1.8, atol=0.02)


def test_lone_segment_on_the_floor_only_outside_the_performance_space():
    rig = ring_rig([0], radius=10.0, height=3.0)
    space = np.array([-3.0, -3.0, 0.0, 3.0, 3.0, 4.5])
    inside, outside = _segments(rig, [(1.0, 1.0, 0.0, 1.8)]), _segments(rig, [(5.0, 1.0, 0.0, 1.8)])
    assert not floor_stage(inside, rig.arrays, 0.5, space)[1].any()  # could be in the air: left to the plane
    fl, used = floor_stage(outside, rig.arrays, 0.5, space)
    assert used.all() and np.allclose(fl.xyz[0, 0], [5.0, 1.0, 0.9], atol=0.02)


def test_apart_pairs_are_not_fused_on_the_floor():
    rig = ring_rig([0, 90], radius=10.0, height=3.0)
    segs = _segments(rig, [(1.0, 1.0, 0.0, 1.8)])
    apart = np.array([[False, True], [True, False]])
    fl, used = floor_stage(segs, rig.arrays, 0.5, np.array([-3.0, -3.0, 0.0, 3.0, 3.0, 4.5]), apart=apart)
    assert len(fl) == 0 and not used.any()


def test_ghost_test_drops_a_pair_standing_apart_on_the_floor():
    rig = ring_rig([0, 90], radius=10.0, height=3.0)
    segs = _segments(rig, [(1.0, 1.0, 0.0, 1.8), (-1.0, -1.0, 0.0, 1.8)])  # segments 0, 1 and 2, 3
    cam_of = segs.camera

    def cluster(a, b, bottom):
        m = np.full((1, 2), -1)
        m[0, cam_of[a]], m[0, cam_of[b]] = a, b
        v = np.ones((1, W), bool)
        xyz = np.zeros((1, W, 3))
        return WindowTracklets3D(0, xyz, np.full((1, W), 1.9), np.full((1, W), bottom), v, np.zeros((1, W), np.int8),
                                 np.full((1, W), 2, np.int8), m, np.full(1, -1))

    class P:
        cluster_plane = 0.5

    scene = simple_scene()
    counts = {"floor_ghosts": 0}
    ghost = cluster(0, 3, 0.7)  # view 0 of person 1 with view 1 of person 2, floating
    kept, segs_out = drop_floor_ghosts(ghost, segs, rig.arrays, [], P, scene, counts)
    assert len(kept) == 0 and segs_out.tolist() == [0, 3] and counts["floor_ghosts"] == 1
    real = cluster(0, 1, 0.7)  # the same person's views agree on the floor: kept
    assert len(drop_floor_ghosts(real, segs, rig.arrays, [], P, scene, counts)[0]) == 1
    on_floor = cluster(0, 3, 0.0)  # bottom on the floor: not judged
    assert len(drop_floor_ghosts(on_floor, segs, rig.arrays, [], P, scene, counts)[0]) == 1
    # cascade+: a pair whose two 2D tracks were one 3D track's in the last window is confirmed
    counts = {"floor_ghosts": 0, "floor_ghosts_confirmed": 0}
    same = np.array([7, 5, 5, 7])  # segments 0 and 3 both belonged to track 7
    kept, segs_out = drop_floor_ghosts(ghost, segs, rig.arrays, [], P, scene, counts, same)
    assert len(kept) == 1 and not len(segs_out) and counts == {"floor_ghosts": 0, "floor_ghosts_confirmed": 1}
    for owner in (np.array([7, 5, 5, 5]), np.array([-1, 5, 5, -1])):  # two tracks, or none: judged
        kept, segs_out = drop_floor_ghosts(ghost, segs, rig.arrays, [], P, scene, counts, owner)
        assert len(kept) == 0 and segs_out.tolist() == [0, 3]
    assert counts == {"floor_ghosts": 2, "floor_ghosts_confirmed": 1}


def test_cascade_plus_tracks_a_walker_off_the_plane():
    assert "cascade+" in MODES and "cascade" in MODES
    rig = ring_rig([0, 120, 240])
    n = 40
    traj = np.stack([np.full(n, 2.0), np.linspace(-1.0, 1.0, n), np.full(n, 0.85)], axis=1)[None]  # centre 0.85 m
    det, _ = make_detections(rig, traj)
    res = track_detections(rig, simple_scene(), det, mode="cascade+")
    assert len(res.tracks) >= n - 10
    assert np.unique(res.tracks.track_id).size == 1
    assert np.abs(res.tracks.xyz[:, :2] - traj[0, res.tracks.frame - res.tracks.frame.min(), :2]).max() < 0.3


def test_floor_tracklet_continues_the_track_of_its_views_2d_tracks():
    from collections import defaultdict

    from gymtrack.tracking.linking import WindowLinker

    def window(start, x):
        xyz = np.zeros((1, 10, 3))
        xyz[..., 0] = x
        v = np.ones((1, 10), bool)
        return WindowTracklets3D(start, xyz, np.full((1, 10), 1.8), np.zeros((1, 10)), v, np.ones((1, 10), np.int8),
                                 np.full((1, 10), 2, np.int8), np.array([[0, 1]]), np.full(1, -1))

    for by_2d, floor, same in ((True, True, True), (True, False, False), (False, True, False)):
        counts = defaultdict(int)
        linker = WindowLinker(5, 0.6, 0, 1.0, counts, floor_by_2d=by_2d)
        track2d = np.array([10, 11])
        a = linker.step(window(0, 0.0), track2d, np.zeros(1, bool), np.zeros(1, bool))
        b = linker.step(window(5, 3.0), track2d, np.zeros(1, bool), np.array([floor]))  # 3 m away: no 3D link
        assert (a.track_id[0] == b.track_id[0]) == same
        assert counts["links_2d"] == int(same)
