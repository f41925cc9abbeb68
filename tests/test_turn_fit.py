"""A knocked camera's turn and start re-estimated from its own points (tracking.turn_fit): against
a known turn on synthetic points, and on simulated knocks against the simulator's turn."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gymtrack.eval.faults import knock_camera, knock_rotation
from gymtrack.simulate.routine import simulate_routine
from gymtrack.tracking import offline
from gymtrack.tracking.turn_fit import fit_turn, own_jacobian


def _angle(R, truth):
    return float(np.degrees(Rotation.from_matrix(R @ truth.T).magnitude()))


def test_pan_and_tilt_fitted_through_a_pose_that_shifts_some_points_one_way():
    """Points seen by a camera turned 0.4 deg (pan and tilt): each pair's bias known, scatter
    0.1 deg, and a quarter of the points (a gymnast the views frame differently) 0.8 deg lower.
    The fit recovers the turn within 0.05 deg (0.03 here); least squares on the same points is
    off by 0.2 deg, pulled by the skewed quarter."""
    rng = np.random.default_rng(0)
    n = 800
    P = np.c_[np.eye(3), [0.2, -0.1, 0.5]]
    X = np.c_[rng.uniform(-2, 2, (n, 2)) + [1.0, 0.5], rng.uniform(8, 12, n)]
    q = X @ P[:, :3].T + P[:, 3]
    bias = np.where(rng.random(n)[:, None] < 0.5, [0.002, -0.004], [-0.003, 0.001])
    unturned = q[:, :2] / q[:, 2:] + bias + rng.normal(scale=np.radians(0.1), size=(n, 2))
    unturned[: n // 4, 1] += np.radians(0.8)
    truth = Rotation.from_rotvec(np.radians([0.3, -0.25, 0.0])).as_matrix()
    ray = np.c_[unturned, np.ones(n)] @ truth.T
    seen = ray[:, :2] / ray[:, 2:]
    R = fit_turn(P, X, seen, bias)
    assert _angle(R, truth) < 0.05
    J = own_jacobian(seen)[:, :, :2].reshape(-1, 2)  # least squares, same model: pulled by the skewed quarter
    w = np.linalg.lstsq(J, (seen - q[:, :2] / q[:, 2:] - bias).reshape(-1), rcond=None)[0]
    assert np.degrees(np.linalg.norm(w - np.radians([0.3, -0.25]))) > 0.15
    assert fit_turn(P, X[:10], seen[:10], bias[:10]) is None  # too few points


@pytest.fixture(scope="module")
def bars():
    return simulate_routine("parallel_bars", n_cam=3, seed=2, seconds=20)


def _applied(monkeypatch, sim, det):
    """The turns the offline second pass applied from the start: {camera: (from frame, rotation)}."""
    seen = {}
    orig = offline._track

    def record(*args):
        if len(args) > 8 and args[8]:
            seen.update(args[8])
        return orig(*args)

    monkeypatch.setattr(offline, "_track", record)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = offline.track_detections(sim.rig, sim.scene, det, mode="cascade+")
    return seen, res


def test_half_degree_knock_at_three_cameras_refitted_from_every_point_after_it(bars, monkeypatch):
    """Parallel bars seed 2, n_cam 3 (bench_faults' case): cam2 turned 0.5 deg at frame 300. The
    turn applied offline from the move on is within 0.15 deg of the simulator's (0.05 here; the
    keys' turn fitted over the first seconds after the move, as before: 0.38 deg off)."""
    truth = knock_rotation(0.5, seed=4)
    applied, res = _applied(monkeypatch, bars, knock_camera(bars.detections, bars.rig[2], 2, 300, truth))
    assert list(applied) == [2]
    assert _angle(applied[2][1], truth) <= 0.15
    ev = res.summary["camera_moved"]
    assert [e["camera"] for e in ev] == ["cam2"] and abs(ev[0]["rotation_degrees"] - 0.5) <= 0.15  # (as the turn's own bound)


def test_knock_start_found_to_the_frame(bars, monkeypatch):
    """The same routine, cam2 turned 1 deg at frame 300: the move's start is found within 2
    frames of it (300 here; the first moved sample's first frame, as before: 287)."""
    truth = knock_rotation(1.0, seed=4)
    applied, res = _applied(monkeypatch, bars, knock_camera(bars.detections, bars.rig[2], 2, 300, truth))
    assert abs(applied[2][0] - 300) <= 2
    assert res.summary["camera_moved"][0]["start_frame"] == applied[2][0]
