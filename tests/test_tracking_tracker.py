"""The streaming Tracker: streaming equals offline, bounded memory, latency, oracle association,
input errors, and the output files."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import as_raw, make_detections, ring_rig, simple_scene

from gymtrack.detections import Detections
from gymtrack.errors import InputError
from gymtrack.formats.outputs import read_target_3d, read_tracks_3d, write_outputs
from gymtrack.tracking import INTERPOLATED, Tracker, TrackerOutput, track_detections


def gym_scene_detections(T=150, seed=0, noise=2.0, drop=0.05, dist=None):
    """A gymnast swinging in the plane x = 0 (rising above 2 m), a coach and a judge; 4 views."""
    rig = ring_rig([0, 80, 180, 260], dist=dist)
    t = np.arange(T)
    target = np.stack([0.05 * np.sin(t / 7), 1.5 * np.sin(t / 15), 1.7 + 0.8 * np.sin(t / 10)], axis=1)
    coach = np.stack([np.full(T, 1.5), np.full(T, -1.0), np.full(T, 0.9)], axis=1)
    judge = np.stack([np.full(T, -2.5), 0.5 + 0.01 * t, np.full(T, 0.9)], axis=1)
    traj = np.stack([target, coach, judge])
    det, pid = make_detections(rig, traj, noise=noise, drop=drop, seed=seed)
    return rig, simple_scene(), det, pid, traj


def stream(rig, scene, det, mode="cascade", association="iou"):
    trk = Tracker(rig, scene, mode=mode, association=association)
    outs, latency = [], []
    frames = np.unique(det.frame)
    for f in range(int(frames[0]), int(frames[-1]) + 1):
        out = trk.update(f, det.select(det.frame == f))
        if len(out.tracks):
            latency.append(f - out.tracks.frame.max())
        outs.append(out)
    outs.append(trk.finish())
    return TrackerOutput.concat(outs, rig.names), latency, trk


def test_streaming_equals_offline():
    rig, scene, det, _, _ = gym_scene_detections(T=120, dist=(-0.04, 0.01, 0, 0, 0))
    raw = as_raw(det)
    offline = track_detections(rig, scene, raw)
    online, latency, trk = stream(rig, scene, raw)
    for name in ("frame", "track_id", "xyz", "top_z", "bottom_z", "source", "n_views"):
        np.testing.assert_array_equal(getattr(online.tracks, name), getattr(offline.tracks, name))
    for name in ("frame", "camera", "box", "track_id"):
        np.testing.assert_array_equal(getattr(online.boxes, name), getattr(offline.boxes, name))
        np.testing.assert_array_equal(getattr(online.target_boxes, name), getattr(offline.target_boxes, name))
    np.testing.assert_array_equal(online.target.xyz, offline.target.xyz)
    assert len(offline.target) > 60
    # a frame is final about one window after it arrives: window - 1 = 9 frames with the defaults
    assert max(latency) <= scene.params.window - 1


def test_memory_stays_bounded_on_a_long_stream():
    rng = np.random.default_rng(5)
    rig = ring_rig([0, 120, 240])
    T = 1500
    t = np.arange(T)
    # people come and go: each lives 60-200 frames, so ids keep growing while the crowd does not
    trajs = []
    for _ in range(40):
        a, life = rng.integers(0, T - 60), rng.integers(60, 200)
        p = np.full((T, 3), np.nan)
        s = slice(a, min(a + life, T))
        ang = rng.uniform(0, 2 * np.pi) + 0.01 * t[s]
        p[s] = np.stack([2.5 * np.cos(ang), 2.5 * np.sin(ang), np.full(len(ang), 0.9)], axis=1)
        trajs.append(p)
    det, _ = make_detections(rig, np.stack(trajs), noise=1.0, seed=1)
    trk = Tracker(rig, simple_scene())
    sizes = []
    raw = as_raw(det)
    bounds = np.searchsorted(raw.frame, np.arange(T + 1))
    for f in range(T):
        trk.update(f, raw.select(slice(bounds[f], bounds[f + 1])))
        sizes.append(trk.state_size())
    trk.finish()
    sizes = np.array(sizes)
    assert trk.linker.next_track_id > 30  # many tracks came and went
    assert sizes[1000:].max() <= 1.5 * sizes[200:700].max()  # no growth with stream length
    assert sizes.max() < 3000


def test_oracle_association_drops_and_counts_false_positives():
    rig, scene, det, pid, traj = gym_scene_detections(T=90, noise=1.0, drop=0.0)
    fp = Detections.from_arrays(np.arange(30) + 10, np.zeros(30), np.tile([900.0, 500, 60, 150], (30, 1)),
                                rig.names, track_id=np.full(30, -1))
    res = track_detections(rig, scene, Detections.concat([det, fp]), association="oracle")
    assert res.summary["detections_dropped_false_positive"]["cam0"] == 30
    assert res.summary["detections_read"]["cam0"] == int(np.sum(det.camera == 0)) + 30
    assert len(np.unique(res.tracks.track_id)) == 3  # the three people, one track each
    err = np.linalg.norm(res.target.xyz - traj[0, res.target.frame], axis=1)
    assert np.median(err) < 0.05


def test_modes_and_bad_input():
    rig, scene, det, _, _ = gym_scene_detections(T=30)
    with pytest.raises(InputError, match="unknown mode"):
        Tracker(rig, scene, mode="magic")
    trk = Tracker(rig, scene)
    trk.update(5, det.select(det.frame == 5))
    with pytest.raises(InputError, match="frames must increase"):
        trk.update(5, det.select(det.frame == 5))
    with pytest.raises(InputError, match="got a box of frame"):
        trk.update(6, det.select(det.frame == 7))
    other = Detections.empty(["a", "b"])
    with pytest.raises(InputError, match="cameras"):
        trk.update(8, other)


def test_gaps_in_the_frame_numbers_are_bridged():
    rig, scene, det, _, _ = gym_scene_detections(T=100, drop=0.0)
    keep = (det.frame < 40) | (det.frame >= 60)  # 20 frames without any box
    res = track_detections(rig, scene, as_raw(det.select(keep)))
    gap = (res.tracks.frame >= 40) & (res.tracks.frame < 60)
    # only the extrapolated edges (max_age = 2 frames held) fall in the gap, marked as such
    assert set(res.tracks.frame[gap].tolist()) <= {40, 41, 58, 59}
    assert np.all(res.tracks.source[gap] == INTERPOLATED) and np.all(res.tracks.n_views[gap] == 0)
    assert np.any(res.tracks.frame >= 60) and np.any(res.tracks.frame < 40)
    assert res.summary["frames"] == 100


def test_outputs_written_and_read_back(tmp_path):
    rig, scene, det, _, traj = gym_scene_detections(T=100)
    res = track_detections(rig, scene, as_raw(det))
    paths = write_outputs(res, tmp_path / "out")
    back = read_tracks_3d(paths["tracks_3d"])
    np.testing.assert_array_equal(back["frame"], res.tracks.frame)
    np.testing.assert_allclose(back["xyz"], res.tracks.xyz, atol=5e-5)
    assert set(back["source"]) <= {"triangulation", "plane", "interpolated"}
    tgt = read_target_3d(paths["target_3d"])
    np.testing.assert_array_equal(tgt["frame"], res.target.frame)
    for name in rig.names:
        lines = (tmp_path / "out" / "tracks_2d" / f"{name}.txt").read_text().splitlines()
        assert len(lines) == int(np.sum(res.boxes.camera == rig.index(name)))
        assert (tmp_path / "out" / "target_2d" / f"{name}.txt").exists()
    summary = json.loads(paths["summary"].read_text())
    assert summary["frames"] == 100 and summary["fps"] > 0 and set(summary["seconds"]) >= {"clustering", "plane"}
    # every target frame has a b_buf box in every view that sees the gymnast
    tb = res.target_boxes
    assert len(tb) >= 3 * len(res.target)
    assert np.all(tb.box[:, 2] == tb.box[:, 3])


def test_a_long_pause_in_the_stream_is_skipped_quickly():
    rig, scene, det, _, _ = gym_scene_detections(T=60, drop=0.0)
    late = Detections.from_arrays(det.frame + 10_000_000, det.camera, det.box, rig.names)
    both = Detections.concat([as_raw(det), late])
    res = track_detections(rig, scene, both)  # would take hours window by window
    assert np.any(res.tracks.frame < 60) and np.any(res.tracks.frame >= 10_000_000)
    assert res.summary["windows"] < 100
