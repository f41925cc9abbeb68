"""Synchronisation from the data (tracking.sync, ``gymtrack sync``, scene.yaml ``frame_offsets``)
and the fault generators it is measured with (eval.faults), against the simulator's truth."""

from __future__ import annotations

import functools

import cv2
import numpy as np
import pytest
import yaml

from gymtrack.errors import GymtrackWarning, RoutineError
from gymtrack.eval.faults import desync_camera, drop_frames, knock_camera, knock_rotation
from gymtrack.formats.motchallenge import write_mot_detections
from gymtrack.formats.routine import load_routine
from gymtrack.simulate.routine import simulate_routine
from gymtrack.tracking.sync import estimate_offsets


@pytest.fixture(scope="module")
def sim():
    return simulate_routine("horizontal_bar", n_cam=4, seed=3, seconds=12)


@pytest.mark.parametrize("shifts", [{1: 3, 3: -5}, {2: 8}, {1: -1, 2: 1, 3: 2}])
def test_offsets_recovered_exactly(sim, shifts):
    det = sim.detections
    for cam, d in shifts.items():
        det = desync_camera(det, cam, d)
    res = estimate_offsets(det, sim.rig, search=10)
    want = [0] + [shifts.get(c, 0) for c in range(1, 4)]
    assert res.offsets.tolist() == want
    assert np.all(np.abs(res.offsets_subframe - want) < 0.5)
    assert not res.undecided()


def test_desync_moves_only_that_camera(sim):
    det = desync_camera(sim.detections, 2, 4)
    other = sim.detections.camera != 2
    assert np.array_equal(np.sort(det.frame[det.camera != 2]), np.sort(sim.detections.frame[other]))
    assert det.frame[det.camera == 2].min() == sim.detections.frame[~other].min() + 4


def test_frame_offsets_applied_when_read_and_unknown_camera_refused(sim, tmp_path):
    sim.write(tmp_path / "r")
    clean = load_routine(tmp_path / "r").detections
    scene = yaml.safe_load((tmp_path / "r" / "scene.yaml").read_text())
    (tmp_path / "r" / "scene.yaml").write_text(yaml.safe_dump({**scene, "frame_offsets": {"cam1": 2}}))
    with pytest.warns(GymtrackWarning, match="before frame 0"):
        r = load_routine(tmp_path / "r")
    shifted, want = r.detections, clean.frame[clean.camera == 1] - 2
    assert np.array_equal(np.sort(shifted.frame[shifted.camera == 1]), np.sort(want[want >= 0]))
    assert r.shifted_out == (want < 0).sum() > 0
    assert np.array_equal(shifted.frame[shifted.camera == 0], clean.frame[clean.camera == 0])
    (tmp_path / "r" / "scene.yaml").write_text(yaml.safe_dump({**scene, "frame_offsets": {"camX": 2}}))
    with pytest.raises(RoutineError, match="camX"):
        load_routine(tmp_path / "r")


def test_sync_command_writes_offsets_that_resynchronise(sim, tmp_path):
    from typer.testing import CliRunner

    from gymtrack.cli import app

    sim.write(tmp_path / "r")
    clean = load_routine(tmp_path / "r").detections
    late = desync_camera(sim.detections, 3, 6).for_camera(3)
    write_mot_detections(tmp_path / "r" / "detections" / "cam3.txt", late)
    out = CliRunner().invoke(app, ["sync", str(tmp_path / "r"), "--write"])
    assert out.exit_code == 0, out.output
    assert "cam3: +6 frames" in out.output
    assert yaml.safe_load((tmp_path / "r" / "scene.yaml").read_text())["frame_offsets"] == {"cam3": 6}
    back = load_routine(tmp_path / "r").detections
    assert np.array_equal(np.sort(back.frame[back.camera == 3]), np.sort(clean.frame[clean.camera == 3]))


def test_knock_matches_opencv_projection_of_the_turned_camera(sim):
    cam = sim.rig[1]
    R = knock_rotation(1.0, seed=2)
    X = np.array([[0.5, 0.2, 1.5], [-1.0, 0.8, 2.2], [1.2, -0.4, 0.3]])
    uv = cam.project(X)
    det = sim.detections.select(np.arange(3))
    det = type(det)(np.array([1, 5, 9]), np.array([1, 1, 1], np.int16), np.c_[uv, np.ones((3, 2))], det.score,
                    det.track_id, det.camera_names)
    moved = knock_camera(det, cam, 1, 5, R)
    want, _ = cv2.projectPoints(X, cv2.Rodrigues(R @ cam.R)[0], R @ cam.t, cam.K, cam.dist)
    assert np.allclose(moved.box[0, :2], uv[0])  # before the knock: unchanged
    assert np.allclose(moved.box[1:, :2], want[1:, 0], atol=1e-4)
    assert np.isclose(np.degrees(np.arccos((np.trace(R) - 1) / 2)), 1.0)


def test_drop_frames_drops_that_share_of_one_camera(sim):
    det, n = drop_frames(sim.detections, 2, 0.02, seed=1)
    frames = np.unique(sim.detections.frame[sim.detections.camera == 2])
    assert n == round(0.02 * len(frames))
    assert len(np.unique(det.frame[det.camera == 2])) == len(frames) - n
    assert (det.camera != 2).sum() == (sim.detections.camera != 2).sum()


def test_resynchronise_gives_back_the_synchronised_boxes(sim):
    from gymtrack.eval.fault_bench import resynchronise

    fixed, offs = resynchronise(desync_camera(sim.detections, 2, -4), sim.rig)
    assert offs.tolist() == [0, 0, -4, 0]
    back = fixed.for_camera(2)
    clean = sim.detections.for_camera(2)
    keep = clean.frame > 4  # (its first 4 frames were pushed before frame 1: left out)
    assert np.array_equal(np.sort(back.frame), np.sort(clean.frame[keep]))


def test_faults_table_pools_and_markdown_sides():
    from gymtrack.eval.fault_bench import faults_markdown, faults_table

    base = {"routine": "r", "apparatus": "a", "camera": "cam1", "fault": "desync 3", "method": "m", "mota": 0.5, "idf1": 0.5}
    rows = [{**base, "state": "clean", "aed_sum": 1.0, "aed_n": 10, "cov_covered": 10, "cov_frames": 10},
            {**base, "state": "fault", "aed_sum": 4.0, "aed_n": 10, "cov_covered": 8, "cov_frames": 10, "exact": True,
             "offset": 3, "found": 3},
            {**base, "state": "fault", "aed_sum": 2.0, "aed_n": 30, "cov_covered": 10, "cov_frames": 10, "exact": False,
             "offset": 3, "found": 2},
            {**base, "state": "corrected", "aed_sum": 1.1, "aed_n": 10, "cov_covered": 10, "cov_frames": 10}]
    t = {x["state"]: x for x in faults_table(rows)}
    assert np.isclose(t["fault"]["aed"], 6.0 / 40) and np.isclose(t["fault"]["coverage"], 0.9)
    md = faults_markdown(rows)
    assert "| desync 3 | m | 0.100 / 0.150 / 0.110 |" in md.replace("0.1 /", "0.100 /")
    assert "exactly in 1 of 2 runs" in md


def test_a_box_weighs_its_motion_across_its_epipolar_line():
    from gymtrack.tracking.sync import LAG, _across_motion

    # epipole at (100, 0): boxes on x = 100 have that vertical line as their epipolar line
    T, size = 2 * LAG + 1, 20.0
    t = np.arange(T) - LAG
    along = np.c_[np.full(T, 100.0), 50.0 + 2.0 * t, np.ones(T)]  # 2 px a frame along the line
    across = np.c_[100.0 + 2.0 * t, np.full(T, 150.0), np.ones(T)]  # 2 px a frame across x = 100
    X = np.stack([along, across], axis=1)  # (T, K=2, 3)
    B = np.concatenate([X[..., :2], np.full((T, 2, 2), size / 2)], -1)
    w = _across_motion(X, B, np.array([100.0, 0.0, 1.0]))
    assert w[LAG, 0] < 1e-9
    assert np.isclose(w[LAG, 1], 2.0 * 2 * LAG / size)
    assert np.all(w[[0, -1]] == 0)  # no box LAG frames before (or after): no weight


@functools.lru_cache(maxsize=1)
def _sim20(apparatus, seed):
    return simulate_routine(apparatus, n_cam=4, seed=seed, seconds=20)


@pytest.mark.parametrize("apparatus, seed, shifts", [("still_rings", 1, {2: 3}), ("still_rings", 1, {2: -5}),
                                                     ("vault", 2, {2: 4}), ("vault", 2, {})])
def test_offsets_exact_where_people_standing_still_leant_the_curve(apparatus, seed, shifts):
    # routines where the boxes' plain mean put camera 2 a frame off at every offset (the judges'
    # and spectators' boxes, still, outnumber the moving gymnast's); weighed by their motion
    # across the epipolar lines they are exact, and the clean routine stays at 0
    sim = _sim20(apparatus, seed)
    det = sim.detections
    for cam, d in shifts.items():
        det = desync_camera(det, cam, d)
    res = estimate_offsets(det, sim.rig)
    assert res.offsets.tolist() == [0] + [shifts.get(c, 0) for c in range(1, 4)]


def test_boxes_cut_by_the_image_border_are_the_ones_left_out(sim):
    from gymtrack.tracking.sync import _at_border

    # against the true boxes: a detection whose person reaches past the image's edge is cut by it
    # (its centre is not the person's), one whose person is well inside is kept
    real = sim.det_person >= 0
    cut = _at_border(sim.detections, sim.rig)[real]
    det = sim.detections.select(np.flatnonzero(real))
    p = np.searchsorted(sim.person_id, sim.det_person[real])
    tb = sim.true_boxes.box[det.camera, p, det.frame - 1]  # xyxy, raw pixels
    W, H = np.array([c.size for c in sim.rig], float)[det.camera].T
    w, h = tb[:, 2] - tb[:, 0], tb[:, 3] - tb[:, 1]
    past = np.max([-tb[:, 0] / w, (tb[:, 2] - W) / w, -tb[:, 1] / h, (tb[:, 3] - H) / h], axis=0)  # share outside
    # (the detector's box may miss the part past the edge, or its noise may reach an edge the
    # person does not: a few in a thousand either way)
    assert (past > 0.05).sum() > 50 and cut[past > 0.05].mean() > 0.99
    assert cut[past < -0.1].mean() < 0.002


@functools.lru_cache(maxsize=1)
def _sim3(apparatus, seed):
    return simulate_routine(apparatus, n_cam=3, seed=seed, seconds=20)


@pytest.mark.parametrize("d", [-3, 5])
def test_the_camera_blind_to_the_target_is_exact(d):
    # n_cam 3: camera 1 never sees the gymnast, only the coaches, judges and spectators, some of
    # them cut by the image's edge as they walk in or out; with the cut boxes it came out a frame
    # late at every offset (sub-frame +0.6 on the clean routine)
    sim = _sim3("still_rings", 1)
    assert sim.target_views.tolist() == [True, False, True, True]
    res = estimate_offsets(desync_camera(sim.detections, 1, d), sim.rig)
    assert res.offsets.tolist() == [0, d, 0, 0]
    assert abs(res.offsets_subframe[1] - d) < 0.5


def test_a_camera_blind_to_the_gymnast_comes_within_a_frame_and_the_others_stay_exact():
    # n_cam 3, balance beam seed 1: camera 1 never sees the gymnast and its curves are flat over
    # three frames (slow walkers): its offset may come out a frame off -- and then it is not always
    # reported undecided (a known gap: bench_sync counts these silent cases) -- while the cameras
    # that see the gymnast stay exact and decided
    sim = _sim3("balance_beam", 1)
    assert sim.target_views.tolist() == [True, False, True, True]
    for d in (-3, 4):
        res = estimate_offsets(desync_camera(sim.detections, 1, d), sim.rig)
        assert res.offsets[[0, 2, 3]].tolist() == [0, 0, 0]
        assert abs(res.offsets[1] - d) <= 1
        assert not {"cam2", "cam3"} & set(res.undecided())
