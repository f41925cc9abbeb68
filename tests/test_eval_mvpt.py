"""The MvPT-like baseline (gymtrack.eval.mvpt) on a tiny synthetic scene: two people, three views."""

from __future__ import annotations

import numpy as np

from conftest import look_at
from gymtrack.detections import Detections
from gymtrack.eval.mvpt import associate, link_frames, track_mvpt
from gymtrack.formats.scene import scene_from_dict
from gymtrack.geometry import Camera, Rig, epipolar_distance, fundamental_matrices

N_FRAMES = 60


def _rig():
    """Three cameras 12 m from the origin, 3 m high, at azimuths 30, 150, 270 degrees."""
    cams = []
    for i, az in enumerate(np.radians([30.0, 150.0, 270.0])):
        R, t = look_at(np.array([12 * np.cos(az), 12 * np.sin(az), 3.0]), np.array([0.0, 0.0, 1.2]))
        cams.append(Camera(f"cam{i}", (1920, 1080), np.array([[1400.0, 0, 960], [0, 1400, 540], [0, 0, 1]]), R, t))
    return Rig(cams)


def _people():
    """(F, 2, 3) centres: A swings high along x (centre 1.8 m: the target), B walks at 0.9 m."""
    t = np.arange(N_FRAMES)
    a = np.c_[-1.5 + 0.05 * t, np.zeros_like(t, float), 1.8 + 0.2 * np.sin(t / 5)]
    b = np.c_[np.full(N_FRAMES, 1.0), -1.5 + 0.02 * t, np.full(N_FRAMES, 0.9)]
    return np.stack([a, b], axis=1)


def _detections(rig, centres, rng, noise_px=1.0):
    """Boxes of each person in each view: top/bottom 0.9 m above/below the centre, width 0.4 x height."""
    frames, cams, boxes, who = [], [], [], []
    for c, cam in enumerate(rig):
        top = cam.project(centres + [0, 0, 0.9])
        bot = cam.project(centres - [0, 0, 0.9])
        mid = cam.project(centres)
        h = np.abs(bot[..., 1] - top[..., 1])
        box = np.stack([mid[..., 0], mid[..., 1], 0.4 * h, h], axis=-1)  # (F, 2, 4)
        box[..., :2] += rng.normal(0, noise_px, box[..., :2].shape)
        F, P = centres.shape[:2]
        frames.append(np.repeat(np.arange(1, F + 1), P))
        cams.append(np.full(F * P, c))
        boxes.append(box.reshape(-1, 4))
        who.append(np.tile(np.arange(P), F))
    order = np.lexsort((np.concatenate(cams), np.concatenate(frames)))
    det = Detections.from_arrays(np.concatenate(frames)[order], np.concatenate(cams)[order], np.concatenate(boxes)[order], rig.names)
    return det, np.concatenate(who)[order]


def test_mvpt_recovers_the_ground_truth_association(rng):
    rig = _rig()
    centres = _people()
    det, who = _detections(rig, centres, rng)
    # precondition: the scene is not ambiguous for box centres (no two people's boxes closer than
    # the threshold in Eq. 1 in any frame), so the right association is recoverable
    F = fundamental_matrices(rig)
    cam = det.camera.astype(int)
    for f in np.unique(det.frame):
        m = det.frame == f
        D = epipolar_distance(det.box[m][:, None], det.box[m][None], F[cam[m][:, None], cam[m][None]])
        cross = (who[m][:, None] != who[m][None]) & (cam[m][:, None] != cam[m][None])
        assert D[cross].min() > 0.3
    label, _ = associate(rig, det, threshold=0.3)
    # per frame: the boxes of one person share a label, the two people never do
    for f in np.unique(det.frame):
        m = det.frame == f
        lab, w = label[m], who[m]
        assert len(np.unique(lab[w == 0])) == 1 and len(np.unique(lab[w == 1])) == 1
        assert lab[w == 0][0] != lab[w == 1][0]

    scene = scene_from_dict({"performance_space": [-4, -3, 0, 4, 3, 4], "planes": [{"point": [0, 0, 0], "normal": [0, 1, 0]}]})
    res = track_mvpt(rig, scene, det)
    assert res.mode == "mvpt"
    tr = res.tracks
    assert len(np.unique(tr.track_id)) == 2  # one track per person, no fragments
    # each track stays on one person, within a few centimetres
    gt = centres[tr.frame - 1]  # (N, 2, 3)
    d = np.linalg.norm(gt - tr.xyz[:, None], axis=-1)
    person = np.argmin(d, axis=1)
    for t in np.unique(tr.track_id):
        assert len(np.unique(person[tr.track_id == t])) == 1
    assert np.max(np.min(d, axis=1)) < 0.1
    assert np.all(tr.n_views == 3)
    # the 2D boxes carry the 3D ids: 2 people x 3 views per frame
    assert len(res.boxes) == len(det)
    # the target rule (Eq. 13) picks person A, whose body is high; one id, no switch
    assert len(res.target) > 0 and len(np.unique(res.target.track_id)) == 1
    ta = res.target
    np.testing.assert_allclose(ta.xyz, centres[ta.frame - 1, 0], atol=0.1)
    assert res.summary["target_switches"] == 0
    # its expanded boxes: one per view per target frame, square, 1.3 x max(w, h) of the true box
    assert len(res.target_boxes) == 3 * len(ta)
    assert np.allclose(res.target_boxes.box[:, 2], res.target_boxes.box[:, 3])


def test_link_frames_gate_max_age_and_new_ids():
    frame = np.array([1, 1, 2, 2, 3, 6])
    xyz = np.array([[0, 0, 0], [5, 0, 0], [5.3, 0, 0], [0.2, 0, 0], [0.4, 0, 0], [0.5, 0, 0]], float)
    ids = link_frames(frame, xyz, gate=0.6, max_age=2)
    # frame 2: both continue (0.3 and 0.2 m); frame 3: the first continues; frame 6: 3 frames
    # after its last point, beyond max_age: a new id
    assert ids.tolist() == [0, 1, 1, 0, 0, 2]
    ids = link_frames(np.array([1, 2]), np.array([[0, 0, 0], [0.7, 0, 0]], float), gate=0.6)
    assert ids.tolist() == [0, 1]  # 0.7 m > gate
