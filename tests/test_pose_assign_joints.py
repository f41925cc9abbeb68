"""Joint-level assignment of bottom-up poses (no crop box) to tracks, against the simulator's truth.

The simulated pose model runs on every track's boxes of a tracked uneven-bars routine; the crop
boxes are dropped (as OpenPose gives its poses) and so are the track ids. Whose pose each one
really is: the person whose projected true joints it lies on. Whose track each track is: the
person its 3D centre follows. The joint-level pass must give more poses to their own person's
track, and fewer to another's, than box overlap alone.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from gymtrack.detections import Detections
from gymtrack.pose.assign import assign_poses
from gymtrack.pose.stage import pose_model_boxes
from gymtrack.simulate import simulate_routine
from gymtrack.simulate.pose_model import simulate_pose_model
from gymtrack.tracking import track_detections


@pytest.fixture(scope="module")
def case():
    sim = simulate_routine("uneven_bars", n_cam=4, seed=2, seconds=10)
    res = track_detections(sim.rig, sim.scene, sim.detections, mode="cascade")
    poses = simulate_pose_model(sim.rig, sim.keypoints, sim.person_id, sim.frames, pose_model_boxes(res, True), seed=2)
    poses.track_id[:] = -1
    poses.bbox[:] = np.nan
    return sim, res, poses


def _pose_person(sim, poses) -> np.ndarray:
    """(N,) the person index each pose lies on (nearest projected true joints, median pixel distance)."""
    fi = np.searchsorted(sim.frames, poses.frame)
    out = np.full(len(poses), -1)
    best = np.full(len(poses), np.inf)
    found = poses.keypoints[..., 2] >= 0.3
    for k in range(len(sim.person_id)):
        for c, cam in enumerate(sim.rig):
            rows = np.flatnonzero(poses.camera == c)
            X = sim.keypoints[k, fi[rows], :, :3].reshape(-1, 3)
            uv = cam.project(X).reshape(rows.size, -1, 2)
            d = np.linalg.norm(uv - poses.keypoints[rows, :, :2], axis=-1)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # a pose without a found joint
                d = np.nanmedian(np.where(found[rows], d, np.nan), axis=1)
            better = np.nan_to_num(d, nan=np.inf) < best[rows]
            best[rows[better]], out[rows[better]] = d[better], k
    return out


def _track_person(sim, res) -> dict:
    """track id -> the person index whose centre it follows most."""
    t = res.tracks
    fi = np.searchsorted(sim.frames, t.frame)
    d = np.linalg.norm(sim.centre[:, fi] - t.xyz[None], axis=-1)  # (P, M)
    who = np.argmin(np.nan_to_num(d, nan=np.inf), axis=0)
    return {int(k): int(np.bincount(who[t.track_id == k]).argmax()) for k in np.unique(t.track_id)}


def test_joints_give_more_poses_to_their_own_person(case):
    sim, res, poses = case
    boxes = Detections.concat([res.boxes, res.target_boxes])
    person = _pose_person(sim, poses)
    owner = _track_person(sim, res)
    scores = {}
    for name, rig in (("boxes", None), ("joints", sim.rig)):
        a = assign_poses(poses, boxes, rig=rig)
        tid = a.poses.track_id
        got = np.array([owner.get(int(t), -2) if t >= 0 else -1 for t in tid])
        scores[name] = ((got == person).sum(), ((got >= 0) & (got != person)).sum())
    (right_b, wrong_b), (right_j, wrong_j) = scores["boxes"], scores["joints"]
    assert right_j > right_b and wrong_j < wrong_b, scores  # 3343 -> 3388 right, 81 -> 56 wrong when written
