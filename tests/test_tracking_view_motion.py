"""cascade+ at low frame rates: the per-view tracker that predicts image motion
(tracking.single_view_motion), the duplicate exclusion (tracking.exclusion) and the superseded
window estimates (tracking.records.superseded), each against ground truth or a brute-force count."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import make_detections, ring_rig
from gymtrack.errors import InputError
from gymtrack.formats.scene import scene_from_dict
from gymtrack.tracking.exclusion import too_close
from reference.exclusion import too_close_numpy
from reference.records import superseded_numpy
from gymtrack.tracking.offline import track_detections
from gymtrack.tracking.records import MemberRows, superseded
from gymtrack.tracking.single_view import IoUTracker, iou_matrix
from gymtrack.tracking.single_view_motion import MotionIoUTracker, needs_motion
from gymtrack.tracking.tracker import Tracker


def _run(tracker, frames, camera, boxes):
    return np.concatenate([tracker.update(int(f), camera[f], boxes[f]) for f in frames])


def test_walker_at_2fps_whose_boxes_never_overlap_keeps_one_2d_track():
    # a 60 x 160 px box moving 90 px a frame (1.5 widths): consecutive boxes never overlap
    T = 12
    box = np.c_[200.0 + 90.0 * np.arange(T), np.full(T, 500.0), np.full(T, 60.0), np.full(T, 160.0)]
    assert np.all(np.diag(iou_matrix(box[:-1], box[1:])) == 0.0)
    cam = [np.array([0])] * T
    boxes = [box[t:t + 1] for t in range(T)]
    paper = _run(IoUTracker(0.1, 2), range(T), cam, boxes)
    assert np.unique(paper).size == T  # the paper's tracker: a new 2D track every frame
    t = MotionIoUTracker(fps=2.0)
    ids = _run(t, range(T), cam, boxes)
    assert np.unique(ids).size == 1
    assert t.counts["links_2d_motion"] == T - 1 and t.counts["links_2d_overlap"] == 0
    assert t.counts["tracks_2d_started"] == 1


def test_two_walkers_crossing_keep_their_tracks_by_prediction():
    # two people walking towards each other along one image row (same size), 0.55 heights a
    # frame; they pass at frame 5. The nearest box is the other person's around the crossing;
    # the constant-velocity prediction keeps them apart
    T, h = 11, 160.0
    xa = 300.0 + 0.55 * h * np.arange(T)
    xb = xa[::-1].copy()
    truth = []
    cam, boxes = [], []
    for f in range(T):
        b = np.array([[xa[f], 500.0, 60.0, h], [xb[f], 505.0, 60.0, h]])
        if f == 5:  # at the crossing only one box is seen (the other hidden behind)
            b = b[:1]
        boxes.append(b)
        cam.append(np.zeros(len(b), np.int64))
        truth.append(np.arange(len(b)))
    t = MotionIoUTracker(fps=2.0)
    ids = _run(t, range(T), cam, boxes)
    person = np.concatenate(truth)
    frame = np.concatenate([np.full(len(b), f) for f, b in enumerate(boxes)])
    before, after = frame < 5, frame > 5
    for p in (0, 1):  # each person keeps one id on each side of the crossing, never the other's
        assert np.unique(ids[(person == p) & before]).size == 1
        assert np.unique(ids[(person == p) & after]).size == 1
    assert set(ids[(person == 0) & after]) == set(ids[(person == 0) & before])
    assert not set(ids[(person == 1) & after]) & set(ids[(person == 0) & before])


def test_lost_tracks_are_counted_and_views_never_mix():
    t = MotionIoUTracker(fps=2.0, max_age=1)
    a = t.update(0, np.array([0, 1]), np.array([[100.0, 100, 40, 100], [100.0, 100, 40, 100]]))
    assert a[0] != a[1]  # the same pixels in two views are two tracks
    b = t.update(1, np.array([1]), np.array([[110.0, 100, 40, 100]]))
    assert b[0] == a[1]
    assert len(t.update(2, np.zeros(0, np.int64), np.zeros((0, 4)))) == 0  # a frame without boxes
    t.update(4, np.array([0]), np.array([[100.0, 100, 40, 100]]))  # view 0's track aged out (gap 3 > max_age + 1)
    assert t.counts["tracks_2d_lost"] == 2 and t.counts["tracks_2d_started"] == 3 and len(t) == 1


@pytest.mark.parametrize("kw", [dict(fps=0.0), dict(fps=2.0, speed=-1.0), dict(fps=2.0, noise=0.0),
                                dict(fps=2.0, smoothing=0.0), dict(fps=2.0, iou_threshold=1.5),
                                dict(fps=2.0, max_age=-1), dict(fps=float("nan"))])
def test_invalid_parameters_raise(kw):
    with pytest.raises(InputError):
        MotionIoUTracker(**kw)


def _scene(fps):
    return scene_from_dict({"fps": fps, "performance_space": [-8.0, -8.0, 0.0, 8.0, 8.0, 2.5], "buffer": 0.5,
                            "planes": [{"point": [0, 0, 0.9], "normal": [0, 0, 1]}],
                            "target": {"h_top": 1.5, "h_bot": 0.0}}, source="test")


def test_motion_tracker_only_where_people_outrun_the_noise():
    assert needs_motion(2.0) and not needs_motion(30.0)
    rig = ring_rig([0, 120])
    assert isinstance(Tracker(rig, _scene(2.0), mode="cascade+").iou, MotionIoUTracker)
    assert isinstance(Tracker(rig, _scene(30.0), mode="cascade+").iou, IoUTracker)  # 30 fps: the paper's
    assert isinstance(Tracker(rig, _scene(2.0), mode="cascade").iou, IoUTracker)  # the paper's method untouched


def test_walker_at_2fps_is_one_3d_track_in_cascade_plus():
    # three views; a person walks 0.6 m a frame (a 2 fps video) across the space
    rig = ring_rig([0, 100, 220], radius=14.0)
    T = 24
    y = -6.9 + 0.6 * np.arange(T)
    traj = np.stack([np.full(T, 1.0), y, np.full(T, 0.9)], axis=1)[None]
    det, _ = make_detections(rig, traj)
    det = det.__class__(det.frame, det.camera, det.box, det.score, np.full(len(det), -1), det.camera_names)
    res = track_detections(rig, _scene(2.0), det, mode="cascade+")
    tr = res.tracks
    assert res.summary["links_2d_motion"] > 0
    assert np.unique(tr.track_id).size == 1 and len(tr) >= 0.8 * T
    err = np.linalg.norm(tr.xyz - traj[0, tr.frame], axis=1)
    assert err.max() < 0.1
    # the paper's IoU tracker breaks the views' tracks into pieces windows drop: the walk is cut
    # short or carried on the plane from one view
    base = track_detections(rig, _scene(2.0), det, mode="cascade")
    assert base.summary["segments_dropped_short"] > 10 * res.summary["segments_dropped_short"]
    b = base.tracks
    assert len(b) < 0.8 * T or np.linalg.norm(b.xyz - traj[0, b.frame], axis=1).max() > 0.5


def test_too_close_against_brute_force():
    rng = np.random.default_rng(3)
    n = 300
    frame = rng.integers(0, 20, n)
    tid = rng.permutation(n)
    xyz = rng.uniform(0, 3, (n, 3))
    xyz[5] = np.nan
    got = too_close(frame, tid, xyz, 0.5)
    want = np.array([any(frame[j] == frame[i] and tid[j] < tid[i] and np.linalg.norm(xyz[i] - xyz[j]) < 0.5
                         for j in range(n)) for i in range(n)])
    assert np.array_equal(got, want) and 0 < got.sum() < n
    with pytest.raises(InputError):
        too_close(frame, tid, xyz, 0.0)


def test_too_close_kernel_equals_numpy_reference():
    rng = np.random.default_rng(5)
    for n in (2, 50, 900):  # 900: the reference's frame-by-frame path
        frame = rng.integers(0, max(2, n // 15), n)
        tid = rng.integers(0, n // 3 + 2, n)  # repeated ids: a track is never close to itself
        xyz = rng.uniform(0, 2, (n, 3))
        xyz[rng.random(n) < 0.05] = np.nan
        assert np.array_equal(too_close(frame, tid, xyz, 0.5), too_close_numpy(frame, tid, xyz, 0.5))
        skip = rng.random(n) < 0.2  # left out points: as if they were not there
        rest = np.flatnonzero(~skip)
        want = np.zeros(n, bool)
        want[rest] = too_close_numpy(frame[rest], tid[rest], xyz[rest], 0.5)
        got = too_close(frame, tid, xyz, 0.5, skip=skip)
        assert np.array_equal(got, want) and (n < 50 or 0 < got.sum() < n)


def test_suppress_duplicates_drops_gone_and_close_points_and_their_boxes():
    """The reported tracks without the points already gone and those too close to an older
    track's (among the rest), and the boxes of exactly those (frame, track) points; only the
    close ones counted."""
    from gymtrack.detections import Detections
    from gymtrack.tracking.exclusion import suppress_duplicates
    from gymtrack.tracking.types import Tracks3D

    rng = np.random.default_rng(6)
    for n in (0, 1, 40, 300):
        frame = np.sort(rng.integers(0, max(2, n // 10), n))
        tid = rng.integers(0, n // 4 + 2, n)
        xyz = rng.uniform(0, 2, (n, 3))
        xyz[rng.random(n) < 0.05] = np.nan
        tracks = Tracks3D(frame, tid, xyz, xyz[:, 2] + 1, xyz[:, 2] - 1, np.zeros(n, np.int8), np.ones(n, np.int8))
        pick = rng.integers(0, max(n, 1), 2 * n)
        boxes = Detections.from_arrays(frame[pick] if n else [], rng.integers(0, 2, 2 * n), rng.uniform(0, 9, (2 * n, 4)),
                                       ("a", "b"), track_id=tid[pick] if n else [])
        for gone in (None, rng.random(n) < 0.2):
            skip = np.zeros(n, bool) if gone is None else gone
            rest = np.flatnonzero(~skip)
            close = np.zeros(n, bool)
            close[rest] = too_close_numpy(frame[rest], tid[rest], xyz[rest], 0.5) if len(rest) >= 2 else False
            drop = skip | close
            counts = {"points_suppressed": 0}
            kept, kept_boxes = suppress_duplicates(tracks, boxes, counts, gone)
            assert counts["points_suppressed"] == close.sum() and np.array_equal(kept.frame, frame[~drop])
            assert np.array_equal(kept.track_id, tid[~drop]) and np.array_equal(kept.xyz, xyz[~drop], equal_nan=True)
            lost = set(zip(frame[drop].tolist(), tid[drop].tolist()))
            keep_box = np.array([(f, t) not in lost for f, t in zip(boxes.frame.tolist(), boxes.track_id.tolist())], bool)
            assert np.array_equal(kept_boxes.frame, boxes.frame[keep_box])
            assert np.array_equal(kept_boxes.track_id, boxes.track_id[keep_box])
            if gone is None and n > 40:
                assert 0 < close.sum() < n and keep_box.sum() < len(boxes)


def test_superseded_when_a_later_window_took_every_box():
    # detections 1, 2 (frame 5) were track 7's in window 0; window 1 gave 1 to track 9 and 2 to
    # track 7 again; detection 3 (frame 6) went from track 7 (window 0) to track 9 (window 1)
    mem = MemberRows(det=np.array([1, 2, 1, 2, 3, 3]), frame=np.array([5, 5, 5, 5, 6, 6]),
                     camera=np.array([0, 1, 0, 1, 0, 0]), track_id=np.array([7, 7, 9, 7, 7, 9]),
                     window=np.array([0, 0, 1, 1, 0, 1]))
    frame = np.array([5, 6, 6, 4])
    track = np.array([7, 7, 9, 7])
    window = np.array([0, 0, 1, 0])
    # (5, 7, w0) keeps detection 2; (6, 7, w0) lost its only one; (6, 9, w1) won it; (4, 7, w0): no detections
    assert superseded(frame, track, window, mem).tolist() == [False, True, False, False]


def test_superseded_kernel_equals_numpy_reference():
    rng = np.random.default_rng(7)
    hits = 0
    for _ in range(200):
        m = int(rng.integers(0, 60))
        det = rng.integers(0, 25, m)  # a detection in one or more windows, one frame per detection
        mem = MemberRows(det=det, frame=100 + det % 5, camera=det % 3, track_id=rng.integers(0, 6, m),
                         window=rng.integers(0, 3, m))
        n = 40
        frame, track, window = rng.integers(99, 106, n), rng.integers(0, 7, n), rng.integers(0, 3, n)
        got = superseded(frame, track, window, mem)
        assert np.array_equal(got, superseded_numpy(frame, track, window, mem))
        hits += got.sum()
    assert hits > 20
