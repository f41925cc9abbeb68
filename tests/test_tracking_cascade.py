"""The cascade: triangulation of multi-view clusters, the plane fallback for opposite pairs and
single tracklets, the outlier test, and cross-window linking (Eq. 3-12)."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import as_raw, make_detections, ring_rig, simple_scene

from gymtrack.geometry.plane import Plane
from gymtrack.geometry.views import line_of_sight_angle
from gymtrack.tracking import INTERPOLATED, PLANE, TRIANGULATION, track_detections
from gymtrack.tracking.linking import link, link_distances, merge_overlaps
from gymtrack.tracking.plane_fallback import plane_stage
from gymtrack.tracking.reconstruct import outliers
from gymtrack.tracking.types import WindowTracklets

T = 40


def on_plane_walk(x=0.0):
    """(1, T, 3) a person walking along y in the plane x = ``x`` (the scene's plane is x = 0)."""
    t = np.arange(T)
    return np.stack([np.full(T, x), -1.0 + 0.05 * t, 1.0 + 0.2 * np.sin(t / 6)], axis=1)[None]


def test_opposite_pair_goes_to_the_plane_in_cascade_and_is_triangulated_otherwise():
    rig = ring_rig([0, 180])  # cameras on +x and -x, facing each other through the plane x = 0
    traj = on_plane_walk()
    assert line_of_sight_angle(rig[0].centre, rig[1].centre, traj[0, 0]) > 150  # opposite_angle_deg
    det, _ = make_detections(rig, traj, noise=1.0, seed=2)
    scene = simple_scene()
    res = track_detections(rig, scene, as_raw(det), mode="cascade")
    tr = res.tracks
    assert len(tr) > 0.8 * T
    assert set(np.unique(tr.source)) <= {PLANE, INTERPOLATED} and np.any(tr.source == PLANE)
    np.testing.assert_allclose(tr.xyz[:, 0], 0.0, atol=1e-9)  # fused candidates lie on the plane
    err = np.linalg.norm(tr.xyz - traj[0, tr.frame], axis=1)
    assert np.median(err) < 0.05
    assert res.summary["clusters_triangulated"] == 0 and res.summary["plane_tracklets"] > 0

    tri = track_detections(rig, scene, as_raw(det), mode="triangulation")
    assert len(tri.tracks) > 0.8 * T
    assert set(np.unique(tri.tracks.source)) <= {TRIANGULATION, INTERPOLATED}
    assert np.any(np.abs(tri.tracks.xyz[:, 0]) > 1e-3)  # triangulation is not tied to the plane


def test_three_view_cluster_is_triangulated_even_off_the_plane():
    rig = ring_rig([0, 120, 240])
    traj = on_plane_walk(x=0.8)  # 0.8 m off the plane: the plane would be wrong here
    det, _ = make_detections(rig, traj, noise=0.5, seed=1)
    res = track_detections(rig, simple_scene(), as_raw(det), mode="cascade")
    tr = res.tracks
    assert len(np.unique(tr.track_id)) == 1
    assert np.all(tr.source == TRIANGULATION)
    assert np.all(tr.n_views == 3)
    err = np.linalg.norm(tr.xyz - traj[0, tr.frame], axis=1)
    assert np.median(err) < 0.03
    # the box tops and bottoms triangulate to the body's top and bottom (1.7 m tall box)
    np.testing.assert_allclose(tr.top_z, traj[0, tr.frame, 2] + 0.85, atol=0.1)  # box edges: nearest corners
    np.testing.assert_allclose(tr.bottom_z, traj[0, tr.frame, 2] - 0.85, atol=0.1)


def test_plane_mode_sends_everything_to_the_plane():
    rig = ring_rig([0, 120, 240])
    traj = on_plane_walk()
    det, _ = make_detections(rig, traj, noise=0.5, seed=1)
    res = track_detections(rig, simple_scene(), as_raw(det), mode="plane")
    assert np.all(res.tracks.source == PLANE)
    np.testing.assert_allclose(res.tracks.xyz[:, 0], 0.0, atol=1e-9)


def test_single_tracklet_without_partner_is_discarded_and_counted():
    rig = ring_rig([0, 90])
    traj = on_plane_walk()
    det, _ = make_detections(rig, traj, visible=np.array([[True, False]]))
    res = track_detections(rig, simple_scene(), as_raw(det), mode="cascade")
    assert len(res.tracks) == 0
    # its lone plane candidates (a new 2D track may continue a 3D track) continue nothing: dropped, counted
    s = res.summary
    assert s["segments_to_plane"] > 0 and s["plane_single_view"] == 0
    assert s["plane_tracklets"] == s["plane_single_view_unlinked"]
    tri = track_detections(rig, simple_scene(), as_raw(det), mode="triangulation")
    assert len(tri.tracks) == 0 and tri.summary["segments_dropped_single"] > 0


def test_off_plane_person_seen_by_opposite_views_is_discarded():
    # 2.5 m in front of the plane x = 0, seen by the cameras on +x and -x: the two rays cross
    # the plane about 0.9 m apart (more than cluster_plane = 0.5), so nothing is fused.
    rig = ring_rig([0, 180])
    off = on_plane_walk(x=2.5)
    det, _ = make_detections(rig, off, seed=3)
    res = track_detections(rig, simple_scene(), as_raw(det), mode="cascade")
    assert len(res.tracks) == 0
    assert res.summary["segments_to_plane"] > 0
    on = on_plane_walk(x=0.0)  # the same walk on the plane is kept
    det, _ = make_detections(rig, on, seed=3)
    assert len(track_detections(rig, simple_scene(), as_raw(det), mode="cascade").tracks) > 0.8 * T


def _segs_on(rig, X, cams, W=10):
    """Segments of one person (X (W, 3)) in the given cameras, all observed."""
    from conftest import person_boxes

    boxes = np.stack([person_boxes(rig[c], X) for c in cams])
    K = len(cams)
    obs = np.ones((K, W), bool)
    return WindowTracklets(0, np.array(cams), np.arange(K), boxes, obs, obs, np.full((K, W), -1))


def test_several_planes_each_candidate_goes_to_the_plane_that_explains_it():
    rig = ring_rig([0, 90, 180, 270])
    W = 10
    planes = [Plane(np.zeros(3), np.array([1.0, 0, 0])), Plane(np.array([0, 2.0, 0]), np.array([0, 1.0, 0]))]
    X = np.stack([np.linspace(-1, 1, W), np.full(W, 2.0), np.full(W, 1.2)], axis=1)  # on plane y = 2 only
    segs = _segs_on(rig, X, [1, 3])  # the cameras on +y and -y see it square-on to plane y = 2
    out = plane_stage(segs, rig, planes, threshold=0.5)
    assert len(out) == 1
    np.testing.assert_allclose(out.xyz[0, :, 1], 2.0, atol=1e-9)
    assert np.median(np.linalg.norm(out.xyz[0] - X, axis=1)) < 0.05


def test_outliers_eq4():
    space = np.array([-1.0, -1, 0, 1, 1, 3])
    W = 6
    xyz = np.zeros((4, W, 3)) + [0, 0, 1.0]
    xyz[1, 3] = [0, 0, 5.0]  # leaves the tracking space once
    xyz[2, 3:] += [0.9, 0, 0]  # jumps 0.9 m in one frame: allowed at max_speed 1
    xyz[3, 3:] += [0.9, 0, 0]
    valid = np.ones((4, W), bool)
    valid[3, 1:3] = False  # gap of 2 frames before frame 3: the allowance is 3 x ...
    assert outliers(xyz, valid, space, max_speed=1.0).tolist() == [False, True, False, False]
    assert outliers(xyz, valid, space, max_speed=0.5).tolist() == [False, True, True, False]
    assert outliers(xyz, valid, space, max_speed=0.25).tolist() == [False, True, True, True]


# ---------------------------------------------------------------------- linking (Eq. 10-12)
def test_link_distances_over_the_overlap_only():
    W, step = 10, 5
    prev = np.zeros((2, W, 3))
    prev[1] += [3.0, 0, 0]
    new = np.zeros((2, W, 3)) + [3.2, 0, 0]
    new[1] = 0.1
    new[1, 5:] = 50.0  # beyond the overlap: must not matter
    pv = np.ones((2, W), bool)
    nv = np.ones((2, W), bool)
    nv[0, :5] = False  # new[0] has nothing in the overlap
    D = link_distances(prev, pv, new, nv, step)
    assert np.isnan(D[0, 0]) and np.isnan(D[1, 0])
    assert D[0, 1] == pytest.approx(np.sqrt(3 * 0.01))
    r, c = link(D, gate=0.6)
    assert r.tolist() == [0] and c.tolist() == [1]


def test_link_is_a_global_assignment_with_a_gate():
    D = np.array([[0.1, 0.2], [0.15, 0.9]])
    r, c = link(D, gate=0.6)
    assert sorted(zip(r.tolist(), c.tolist())) == [(0, 1), (1, 0)]  # 0.35 beats 0.1 + nothing
    r, c = link(np.array([[0.7]]), gate=0.6)
    assert len(r) == 0


def test_link_matches_a_brute_force_optimum():
    """Lone pairs are linked directly, conflicts go to the assignment: the result must still be a
    largest set of gated links with the smallest total distance (checked by enumeration)."""
    from itertools import permutations

    rng = np.random.default_rng(3)
    for _ in range(400):
        m, n = (int(v) for v in rng.integers(0, 5, 2))
        D = rng.uniform(0, 1.5, (m, n))
        D[rng.random((m, n)) < 0.25] = np.nan
        r, c = link(D, gate=0.6)
        assert len(set(r.tolist())) == len(r) and len(set(c.tolist())) == len(c)
        assert np.all(D[r, c] <= 0.6)
        best = (0, 0.0)  # (links, -cost) over every injective map of rows to columns or none
        for cols in permutations(list(range(n)) + [-1] * m, m):
            pairs = [(i, j) for i, j in enumerate(cols) if j >= 0 and np.isfinite(D[i, j]) and D[i, j] <= 0.6]
            best = max(best, (len(pairs), -sum(D[i, j] for i, j in pairs)))
        assert len(r) == best[0] and D[r, c].sum() == pytest.approx(-best[1])


def test_merge_overlaps_averages_the_two_windows():
    # track 4: frame 10 from window k only, frame 11 from both windows (overlap), frame 12 from k+1
    frame = np.array([10, 11, 11, 12])
    tid = np.array([4, 4, 4, 4])
    xyz = np.array([[0.0, 0, 1], [1.0, 0, 1], [1.2, 0.2, 1], [2.0, 0, 1]])
    top = np.array([2.0, 2.0, np.nan, 2.2])
    bot = np.array([0.1, 0.3, 0.5, 0.2])
    src = np.array([PLANE, PLANE, TRIANGULATION, TRIANGULATION], np.int8)
    nv = np.array([2, 2, 3, 3], np.int8)
    out = merge_overlaps(frame, tid, xyz, top, bot, src, nv)
    assert out.frame.tolist() == [10, 11, 12]
    np.testing.assert_allclose(out.xyz[1], [1.1, 0.1, 1.0])
    assert out.top_z[1] == 2.0 and out.bottom_z[1] == pytest.approx(0.4)
    assert out.source.tolist() == [PLANE, TRIANGULATION, TRIANGULATION] and out.n_views[1] == 3


def test_a_person_keeps_one_track_id_across_windows():
    rig = ring_rig([0, 120, 240])
    traj = on_plane_walk(x=0.3)
    det, _ = make_detections(rig, traj, noise=1.0, seed=4)
    res = track_detections(rig, simple_scene(), as_raw(det), mode="cascade")
    assert len(np.unique(res.tracks.track_id)) == 1
    assert res.summary["links"] == res.summary["windows"] - 1  # every window continues the track
    # its boxes in each view carry the 3D track id: every detection is used
    assert len(res.boxes) == len(det)
    assert np.all(res.boxes.track_id == res.tracks.track_id[0])
