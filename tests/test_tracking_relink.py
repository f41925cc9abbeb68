"""Beyond the paper: re-linking a lost 3D track across a short gap, and the epipolar veto on
fusing plane candidates (two segments Eq. 2 calls different people are never fused)."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import as_raw, make_detections, ring_rig, simple_scene

from gymtrack.formats.scene import preset_scene
from gymtrack.tracking import track_detections
from gymtrack.tracking.linking import link, relink_distances, tracklet_ends

T = 60


def walk_with_gap(gap):
    """(1, T, 3): a person walking along y on the plane x = 0, absent in the frames ``gap``."""
    t = np.arange(T)
    traj = np.stack([np.zeros(T), -1.5 + 0.05 * t, np.full(T, 1.0)], axis=1)[None].copy()
    traj[0, gap] = np.nan
    return traj


def test_tracklet_ends_hand_worked():
    xyz = np.zeros((2, 6, 3))
    xyz[0, :, 0] = np.arange(6) * 0.1  # moving 0.1 m per frame along x, valid everywhere
    xyz[1, :3, 1] = [0.0, 0.5, 1.0]  # 0.5 m per frame, last valid at index 2
    valid = np.array([[1, 1, 1, 1, 1, 1], [1, 1, 1, 0, 0, 0]], bool)
    last, X, v = tracklet_ends(xyz, valid, start=100, max_speed=0.3)
    np.testing.assert_array_equal(last, [105, 102])
    np.testing.assert_allclose(X, [[0.5, 0, 0], [0, 1.0, 0]])
    np.testing.assert_allclose(v[0], [0.1, 0, 0])
    np.testing.assert_allclose(v[1], [0, 0.3, 0])  # clipped to max_speed


def test_relink_distances_predict_across_the_gap():
    lost_frame = np.array([10])
    lost_xyz = np.array([[0.0, 0.0, 1.0]])
    lost_v = np.array([[0.1, 0.0, 0.0]])
    new = np.full((3, 10, 3), np.nan)
    valid = np.zeros((3, 10), bool)
    new[0, 4] = [0.5, 0.0, 1.0]; valid[0, 4] = True  # frame 14: predicted 0.4 -> 0.1 m away
    new[1, 2] = [2.0, 0.0, 1.0]; valid[1, 2] = True  # frame 12: predicted 0.2 -> 1.8 m away
    new[2, 9] = [1.9, 0.0, 1.0]; valid[2, 9] = True  # frame 19 = gap of 8 > max_gap 7: refused
    D = relink_distances(lost_frame, lost_xyz, lost_v, new, valid, start=10, max_gap=7)
    np.testing.assert_allclose(D[0, :2], [0.1, 1.8])
    assert np.isnan(D[0, 2])
    r, c = link(D, 0.6)
    assert list(zip(r, c)) == [(0, 0)]
    # a new tracklet overlapping the lost track's last frame is plain linking's business
    valid2 = np.zeros((1, 10), bool); valid2[0, 0] = True
    assert np.isnan(relink_distances(lost_frame, lost_xyz, lost_v, new[:1], valid2, start=10, max_gap=7)[0, 0])


@pytest.mark.parametrize("relink_frames, n_tracks", [(0, 2), (10, 1)])
def test_a_person_missing_for_a_window_keeps_the_track_id_when_relinking(relink_frames, n_tracks):
    rig = ring_rig([0, 120, 240])
    traj = walk_with_gap(slice(24, 31))  # 7 frames: no window's tracklet spans the gap
    det, _ = make_detections(rig, traj, noise=0.5, seed=1)
    res = track_detections(rig, simple_scene(relink_frames=relink_frames), as_raw(det), mode="cascade")
    assert len(np.unique(res.tracks.track_id)) == n_tracks
    assert res.summary["relinks"] == (n_tracks == 1)
    # the gap itself is not invented (segment ends are held for at most max_age = 2 frames)
    assert not np.isin(np.arange(26, 29), res.tracks.frame).any()


def test_relinking_needs_the_new_tracklet_near_the_prediction():
    rig = ring_rig([0, 120, 240])
    traj = walk_with_gap(slice(24, 31))
    traj[0, 31:, 1] += 1.5  # comes back 1.5 m away from where it was heading: someone else
    det, _ = make_detections(rig, traj, noise=0.5, seed=1)
    res = track_detections(rig, simple_scene(relink_frames=10), as_raw(det), mode="cascade")
    assert len(np.unique(res.tracks.track_id)) == 2 and res.summary["relinks"] == 0


def test_plane_candidates_of_different_people_are_not_fused():
    """Two people, each seen by one view of a non-opposite pair, placed on those views' rays
    through two points of the plane less than ``cluster_plane`` apart: Eq. 8 alone would fuse
    them into a phantom on the plane, but Eq. 2 says they are different people (their rays pass
    far from each other), so the plane stage must not fuse them."""
    from gymtrack.geometry.epipolar import epipolar_distance, fundamental_matrix

    rig = ring_rig([20, 110], radius=10.0)  # 90 degrees apart, on both sides of the plane x = 0
    scene = simple_scene()
    c0, c1 = rig[0].centre, rig[1].centre
    p0 = np.array([0.0, 0.0, 1.2])
    F = fundamental_matrix(rig[0], rig[1])
    for dz in np.linspace(0.05, 0.49, 45):  # the two plane points: p0 and p0 + dz up the plane
        p1 = p0 + [0.0, 0.0, dz]
        a = c0 + 0.9 * (p0 - c0)  # a stands on cam0's ray through p0 ...
        b = c1 + 0.9 * (p1 - c1)  # ... b on cam1's ray through p1
        traj = np.stack([np.tile(a, (30, 1)), np.tile(b, (30, 1))])
        det, _ = make_detections(rig, traj, visible=np.array([[True, False], [False, True]]), seed=2)
        b0, b1 = det.box[det.camera == 0][0], det.box[det.camera == 1][0]
        if epipolar_distance(b0, b1, F) >= scene.params.cluster_2d:
            break
    else:
        pytest.fail("no placement makes the two people epipolar-inconsistent")
    assert dz < scene.params.cluster_plane  # Eq. 8 alone would fuse their candidates
    res = track_detections(rig, scene, as_raw(det), mode="cascade")
    assert len(res.tracks) == 0, "a phantom was fused on the plane"
    # what the plane stage made are lone candidates (new 2D tracks), none continued a track
    assert res.summary["plane_tracklets"] == res.summary["plane_single_view_unlinked"]


def test_scene_focus_defaults_to_the_performance_space_centre_and_presets_use_the_apparatus():
    s = simple_scene()
    np.testing.assert_allclose(s.focus_point, [0, 0, 2.25])
    v = preset_scene("vault")
    assert v.performance_space[0] < -20  # the runway ...
    np.testing.assert_allclose(v.focus_point[:2], [0, 0])  # ... but the action is at the table


def test_a_view_left_alone_continues_the_track_on_the_plane():
    """A person on the plane seen by an opposite pair; for 15 frames one view loses them. The
    remaining view's 2D track already belongs to the 3D track, so its ray-plane intersection
    continues that track (the paper would drop the lone candidate); a bystander only ever seen
    by one view makes no track at all."""
    rig = ring_rig([0, 180])  # opposite pair through the plane x = 0
    traj = walk_with_gap(slice(0, 0))  # on the plane, always present
    bystander = traj.copy()
    bystander[0, :, 0] = 1.0  # 1 m off the plane
    bystander[0, :, 1] *= -1
    both = np.concatenate([traj, bystander])
    det, pid = make_detections(rig, both, visible=np.array([[True, True], [True, False]]), noise=0.5, seed=3)
    lost = (pid == 0) & (det.camera == 1) & (det.frame >= 25) & (det.frame < 40)
    det = det.select(~lost)
    res = track_detections(rig, simple_scene(), as_raw(det), mode="cascade")
    assert len(np.unique(res.tracks.track_id)) == 1  # one person, one track; no bystander track
    alone = (res.tracks.frame >= 28) & (res.tracks.frame < 37)
    assert alone.sum() == 9 and np.all(res.tracks.n_views[alone] == 1)
    truth = traj[0, res.tracks.frame[alone]]
    assert np.abs(res.tracks.xyz[alone, 0]).max() < 1e-6  # on the plane ...
    assert np.linalg.norm(res.tracks.xyz[alone] - truth, axis=1).max() < 0.15  # ... where the person is
    assert res.summary["plane_single_view"] > 0


def test_a_broken_2d_track_continues_the_3d_track_while_its_view_is_alone():
    """As above, but while cam1 has lost the person, cam0's 2D track also breaks (3 frames
    without a box, longer than max_age): its new 2D track belongs to no 3D track yet. Being new,
    its lone plane candidates may continue (link or re-link) the 3D track, so the person keeps one id;
    with only members of earlier 3D tracks allowed to stand alone (the previous rule) the track
    would be lost until cam1 sees the person again."""
    rig = ring_rig([0, 180])
    traj = walk_with_gap(slice(0, 0))
    det, pid = make_detections(rig, traj, visible=np.array([[True, True]]), noise=0.5, seed=4)
    lost = ((det.camera == 1) & (det.frame >= 20) & (det.frame < 50)) | (
        (det.camera == 0) & (det.frame >= 30) & (det.frame < 33))
    det = det.select(~lost)
    res = track_detections(rig, simple_scene(), as_raw(det), mode="cascade")
    assert len(np.unique(res.tracks.track_id)) == 1
    alone = (res.tracks.frame >= 36) & (res.tracks.frame < 48)  # only cam0's new 2D track sees them
    assert alone.sum() == 12 and np.all(res.tracks.n_views[alone] == 1)
    truth = traj[0, res.tracks.frame[alone]]
    assert np.linalg.norm(res.tracks.xyz[alone] - truth, axis=1).max() < 0.15
    assert res.summary["plane_single_view"] > 0


def test_member_is_isin():
    from gymtrack.tracking.linking import member

    rng = np.random.default_rng(0)
    for n, m in ((0, 0), (0, 3), (4, 0), (1, 1), (30, 20), (400, 300)):
        a, b = rng.integers(0, 50, n), rng.integers(0, 50, m)
        np.testing.assert_array_equal(member(a, b), np.isin(a, b))
