"""The tracker's stateful stages on their own: cross-window linking (:class:`WindowLinker`, the
two-pass cascade, lost and ended tracks, re-linking) and the target stage (:class:`TargetStage`:
fed in runs of frames or frame by frame, the same trajectory and boxes)."""

from __future__ import annotations

from collections import defaultdict

import numpy as np
import pytest

from gymtrack.detections import Detections
from gymtrack.simulate import simulate_routine
from gymtrack.tracking import track_detections
from gymtrack.tracking.linking import WindowLinker
from gymtrack.tracking.target import TargetStage
from gymtrack.tracking.types import PLANE, Target, WindowTracklets3D

W, STEP = 10, 5


def tracklets(start, centres, n_members):
    """A window's 3D tracklets standing still at ``centres`` (M, 3), valid in every frame;
    tracklet m has ``n_members[m]`` member segments, numbered in order."""
    M = len(centres)
    xyz = np.repeat(np.asarray(centres, float)[:, None, :], W, axis=1)
    members = np.full((M, 2), -1, np.int64)
    k = 0
    for m, n in enumerate(n_members):
        members[m, :n] = np.arange(k, k + n)
        k += n
    ones = np.ones((M, W))
    return WindowTracklets3D(start, xyz, ones * 2.0, ones * 0.5, ones > 0, np.full((M, W), PLANE, np.int8),
                             np.ones((M, W), np.int8), members, np.full(M, -1, np.int64)), k


def test_window_linker_two_passes_lost_and_ended_tracks():
    counts = defaultdict(int)
    linker = WindowLinker(STEP, 0.6, 0, 0.5, counts)
    cur, k = tracklets(0, [[0, 0, 1], [3, 0, 1]], [2, 2])
    assert linker.step(cur, np.arange(100, 100 + k), np.zeros(2, bool)).track_id.tolist() == [0, 1]
    # the next window: A continues (several views), a one-view plane tracklet continues B in the
    # second pass, one far away may not start a track (dropped), C is new
    cur, k = tracklets(5, [[0, 0, 1], [3, 0.1, 1], [9, 0, 1], [-3, 0, 1]], [2, 1, 1, 2])
    track2d = np.array([100, 101, 102, 200, 201, 202])  # segment 3 (track 200) belongs to the dropped one
    out = linker.step(cur, track2d, np.array([False, True, True, False]))
    assert out.track_id.tolist() == [0, 1, 2]
    np.testing.assert_array_equal(out.xyz[:, 0, 0], [0, 3, -3])
    assert (counts["links"], counts["plane_single_view"], counts["plane_single_view_unlinked"]) == (2, 1, 1)
    # members may continue alone, so may 2D tracks new in the window; a seen non-member may not
    assert linker.may_continue_alone(np.array([100, 102, 200, 999])).tolist() == [True, True, False, True]
    # B and C are not continued: lost (last frame 14) ...
    linker.step(tracklets(10, [[0, 0, 1]], [2])[0], np.array([100, 101]), np.zeros(1, bool))
    assert sorted(linker.lost) == [1, 2] and linker.ended == {} and sorted(linker.track_last) == [0]
    # ... and ended once beyond re-linking reach (relink_frames = 0: the next window)
    linker.step(WindowTracklets3D.empty(15, W, 2), np.zeros(0, np.int64), np.zeros(0, bool))
    assert linker.ended == {1: 14, 2: 14} and sorted(linker.lost) == [0] and linker.idle
    assert linker.next_track_id == 3


def test_window_linker_relinks_across_a_gap():
    counts = defaultdict(int)
    linker = WindowLinker(STEP, 0.6, 10, 0.5, counts)
    linker.step(tracklets(0, [[0, 0, 1]], [2])[0], np.arange(2), np.zeros(1, bool))
    linker.step(WindowTracklets3D.empty(5, W, 2), np.zeros(0, np.int64), np.zeros(0, bool))  # nobody
    assert list(linker.lost) == [0]
    out = linker.step(tracklets(10, [[0.1, 0, 1], [5, 0, 1]], [2, 2])[0], np.arange(4), np.zeros(2, bool))
    assert out.track_id.tolist() == [0, 1]  # the lost track is back, the far one is new
    assert counts["relinks"] == 1 and counts["links"] == 0 and linker.lost == {}


@pytest.fixture(scope="module")
def tracked():
    sim = simulate_routine("uneven_bars", n_cam=3, seed=2, seconds=12)
    return sim.rig, sim.scene, track_detections(sim.rig, sim.scene, sim.detections)


def run_stage(rig, scene, tracks, boxes, cuts):
    """Feed a TargetStage the runs of frames between ``cuts`` (frame numbers, increasing)."""
    stage = TargetStage(rig, scene)
    tb, bb = np.searchsorted(tracks.frame, cuts), np.searchsorted(boxes.frame, cuts)
    out = [stage.update(a, b - 1, tracks.select(slice(tb[i], tb[i + 1])), boxes.select(slice(bb[i], bb[i + 1])), {})
           for i, (a, b) in enumerate(zip(cuts[:-1], cuts[1:]))]
    out.append(stage.finish())
    assert len(stage.backfill) == 0 and len(stage.smoother) == 0  # every target point released
    return Target.concat([t for t, _ in out]), Detections.concat([b for _, b in out]), stage


def test_target_stage_in_runs_equals_frame_by_frame(tracked):
    rig, scene, res = tracked
    f0, f1 = int(res.tracks.frame.min()), int(res.tracks.frame.max())
    by_frame = run_stage(rig, scene, res.tracks, res.boxes, np.arange(f0, f1 + 2))
    rng = np.random.default_rng(0)
    cuts = np.r_[f0, np.sort(rng.choice(np.arange(f0 + 1, f1 + 1), 25, replace=False)), f1 + 1]
    in_runs = run_stage(rig, scene, res.tracks, res.boxes, cuts)
    assert len(by_frame[0]) > 150 and by_frame[2].frames == len(by_frame[0])
    for name in ("frame", "track_id", "xyz"):
        np.testing.assert_array_equal(getattr(by_frame[0], name), getattr(in_runs[0], name))
    for name in ("frame", "camera", "box", "track_id"):
        np.testing.assert_array_equal(getattr(by_frame[1], name), getattr(in_runs[1], name))
    assert by_frame[2].switches == in_runs[2].switches
    # the tracker's own target (its tracks' ends known online) covers the same frames here
    assert len(np.setxor1d(res.target.frame, by_frame[0].frame)) < 0.05 * len(res.target)


@pytest.mark.parametrize("camera", [-1, 4])
def test_offline_runner_checks_input_as_update_does(tracked, camera):
    """track_detections feeds Tracker.update(): a bad camera index is an InputError either way."""
    rig, scene, res = tracked
    assert len(rig) == 4
    det = res.boxes.select(slice(0, 50))
    bad = Detections(det.frame, np.where(np.arange(len(det)) == 7, camera, det.camera).astype(np.int16), det.box,
                     det.score, det.track_id, det.camera_names)
    from gymtrack.errors import InputError
    from gymtrack.tracking import Tracker

    with pytest.raises(InputError, match="camera index outside 0..3"):
        track_detections(rig, scene, bad)
    f = int(bad.frame[7])
    with pytest.raises(InputError, match="camera index outside 0..3"):
        Tracker(rig, scene).update(f, bad.select(bad.frame == f))
    track_detections(rig, scene, det)  # the same boxes with good indices: fine
