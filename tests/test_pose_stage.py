"""The pose stage on a small simulated routine, and ``gymtrack pose`` end to end."""

from __future__ import annotations


import numpy as np
import pytest
from typer.testing import CliRunner

from gymtrack.cli import app
from gymtrack.eval.pose_metrics import target_pose_error
from gymtrack.formats.keypoints import read_keypoints, write_keypoints
from gymtrack.formats.atomic import atomic_output
from gymtrack.formats.outputs import write_outputs
from gymtrack.formats.poses3d import read_poses_3d
from gymtrack.pose.assign import STATUS_NAMES
from gymtrack.pose.stage import lift_poses, pose_model_boxes, read_track_result
from gymtrack.simulate import simulate_routine
from gymtrack.simulate.pose_model import simulate_pose_model
from gymtrack.skeletons import COCO17
from gymtrack.tracking import track_detections

SECONDS = 10


@pytest.fixture(scope="module")
def tracked():
    sim = simulate_routine("balance_beam", n_cam=3, seed=1, seconds=SECONDS)
    res = track_detections(sim.rig, sim.scene, sim.detections, mode="cascade")
    return sim, res


def _model(sim, boxes, seed=0):
    return simulate_pose_model(sim.rig, sim.keypoints, sim.person_id, sim.frames, boxes, seed=seed)


def test_target_pose_from_its_boxes(tracked):
    sim, res = tracked
    poses = _model(sim, res.target_boxes)
    out = lift_poses(res, sim.rig, sim.scene, poses)
    p = out.poses3d
    assert len(p) > 0.8 * len(res.target)
    assert np.unique(p.frame).size == len(p)  # one target pose per frame
    # each row carries the track the target followed at that frame
    i = np.searchsorted(res.target.frame, p.frame)
    assert np.array_equal(res.target.track_id[i], p.track_id)
    k = int(np.flatnonzero(sim.person_id == sim.target_id)[0])
    perf = sim.frames[sim.performing & np.all(np.isfinite(sim.target_centre), axis=1)]
    e = target_pose_error(p.frame, p.xyz, p.skeleton.joints, sim.frames, sim.keypoints[k], COCO17.joints, perf)
    assert e.mpjpe < 150.0 and e.pose_share > 0.8
    c = out.counts
    assert c["read"] == len(poses) == c["given"] and c["used"] + c["foreign_torso"] + c["duplicate"] + c["not_lifted"] == c["given"]
    assert sum(out.how_counts().values()) == int(np.isfinite(p.xyz).all(-1).sum())


def test_all_tracks_from_poses_without_track_ids(tracked):
    sim, res = tracked
    boxes = pose_model_boxes(res, all_tracks=True)
    poses = _model(sim, boxes)
    truth = poses.track_id.copy()
    poses.track_id[:] = -1
    out = lift_poses(res, sim.rig, sim.scene, poses, all_tracks=True)
    a = out.assignment
    c = out.counts
    # every input pose accounted for
    assert sum(c[k] for k in STATUS_NAMES) == c["read"] == len(poses)
    assert c["used"] + c["foreign_torso"] + c["duplicate"] + c["not_lifted"] + c["same_body"] + c["foreign_dropped"] \
        == c["given"] + c["assigned"]
    # the pose ran on its own track's box: the overlap gives it back
    ok = a.poses.track_id >= 0
    assert ok.mean() > 0.95 and np.mean(a.poses.track_id[ok] == truth[ok]) > 0.97
    p = out.poses3d
    key = p.frame * 100000 + p.track_id
    assert np.unique(key).size == len(p)  # one skeleton per (frame, track)
    lifted_tracks = set(np.unique(p.track_id))
    tracks_with_poses = set(np.unique(a.poses.track_id[ok]))
    assert len(lifted_tracks) >= 0.7 * len(tracks_with_poses)
    assert lifted_tracks <= set(np.unique(res.tracks.track_id))


def test_read_back_outputs_give_the_same_poses(tracked, tmp_path):
    sim, res = tracked
    write_outputs(res, tmp_path)
    back = read_track_result(tmp_path, sim.rig.names)
    assert len(back.target) == len(res.target) and len(back.boxes) == len(res.boxes)
    poses = _model(sim, res.target_boxes)
    a = lift_poses(res, sim.rig, sim.scene, poses, method="dlt").poses3d
    b = lift_poses(back, sim.rig, sim.scene, poses, method="dlt").poses3d
    assert np.array_equal(a.frame, b.frame)
    assert np.allclose(a.xyz, b.xyz, equal_nan=True)  # dlt does not use the centre: identical


def test_cli_pose_end_to_end(tracked, tmp_path):
    sim, res = tracked
    routine, out = tmp_path / "routine", tmp_path / "out"
    sim.write(routine)
    with atomic_output(out, "track") as staging:  # as `gymtrack track` writes it (with the output marker)
        write_outputs(res, staging)
    poses = _model(sim, pose_model_boxes(res, all_tracks=True))
    poses.track_id[:] = -1
    write_keypoints(routine / "keypoints", poses)
    r = CliRunner().invoke(app, ["pose", str(routine), str(out), "--all-tracks"])
    assert r.exit_code == 0, r.output
    assert "poses read" in r.output and str(len(poses)) in r.output
    p3 = read_poses_3d(out / "poses_3d.csv")
    assert len(np.unique(p3.track_id)) > 1
    back = read_keypoints(out / "keypoints", sim.rig.names)
    assert len(back) == len(poses) and (back.track_id >= 0).mean() > 0.95


def test_cli_pose_clear_errors(tracked, tmp_path):
    sim, res = tracked
    routine = tmp_path / "routine"
    sim.write(routine)
    runner = CliRunner()
    r = runner.invoke(app, ["pose", str(routine), str(tmp_path / "nothing")])
    assert r.exit_code != 0 and "track output folder not found" in str(r.exception or r.output)
    with atomic_output(tmp_path / "out", "track") as staging:
        write_outputs(res, staging)
    r = runner.invoke(app, ["pose", str(routine), str(tmp_path / "out"), "--keypoints", str(tmp_path / "none")])
    assert r.exit_code != 0 and "no 2D keypoints" in str(r.exception or r.output)
    r = runner.invoke(app, ["pose", str(routine), str(tmp_path / "out"), "--lift", "magic"])
    assert r.exit_code != 0 and "unknown lifting method" in str(r.exception or r.output)


def test_cli_pose_simulated_model(tracked, tmp_path):
    sim, res = tracked
    routine, out = tmp_path / "routine", tmp_path / "out"
    sim.write(routine)
    with atomic_output(out, "track") as staging:
        write_outputs(res, staging)
    r = CliRunner().invoke(app, ["pose", str(routine), str(out), "--simulated-model", "--lift", "dlt"])
    assert r.exit_code == 0, r.output
    p3 = read_poses_3d(out / "poses_3d.csv")
    # the target only: one row per frame, the target's track at that frame
    assert np.unique(p3.frame).size == len(p3) > 0.8 * len(res.target)
    assert (p3.how[np.isfinite(p3.xyz).all(-1)] == 1).all()  # dlt: triangulated only
    back = read_keypoints(out / "keypoints", sim.rig.names)
    assert len(back) == len(res.target_boxes)  # one pose per b_buf crop


def test_demo_prints_the_pose_error_of_both_methods():
    r = CliRunner().invoke(app, ["demo", "--seconds", "10"])
    assert r.exit_code == 0, r.output
    block = r.output[r.output.index("Target's 3D pose"):]
    assert "MPJPE" in block and "PCK" in block and "cascade" in block and "triangulation" in block
    assert block.count(" mm") >= 4


def test_demo_pose_table_counts_a_frame_without_a_pose_as_a_miss():
    from gymtrack.cli.pose import demo_pose_table
    from gymtrack.simulate import simulate_routine

    sim = simulate_routine("uneven_bars", n_cam=2, seed=0, seconds=20)  # (the demo's: triangulation poses ~90 %)
    res = track_detections(sim.rig, sim.scene, sim.detections, mode="triangulation")
    perf = sim.frames[sim.performing & np.all(np.isfinite(sim.target_centre), axis=1)]
    t = demo_pose_table(sim, {"triangulation": res}, perf)
    head = [c.header for c in t.columns]
    assert head[1:3] == ["MPJPE", "PCK@150mm (all performing frames)"]
    pck, share = (float(t.columns[k]._cells[0].rstrip("%")) for k in (2, 4))
    assert share < 100 and pck <= share  # triangulation misses frames: PCK over all of them cannot exceed the share


def test_stage_holes_are_counted_and_warned(tracked):
    """Poses of the target only with --all-tracks, a track_id naming no track, scores above 1, no
    poses, no target: counted and warned, or a clear error; never a crash or a silent drop."""
    from dataclasses import replace

    from gymtrack.errors import GymtrackWarning, InputError
    from gymtrack.pose.stage import NoTargetError, check_liftable
    from gymtrack.poses import Poses2D
    from gymtrack.tracking.types import Target

    sim, res = tracked
    poses = _model(sim, res.target_boxes)
    with pytest.warns(GymtrackWarning, match=r"tracks have no 2D pose assigned and get no 3D skeleton"):
        out = lift_poses(res, sim.rig, sim.scene, poses, all_tracks=True)
    n_tracks = len(np.unique(res.tracks.track_id))
    assert out.counts["tracks_without_pose"] == n_tracks - len(np.unique(out.poses3d.track_id)) > 0
    odd = replace(poses, track_id=poses.track_id.copy(), keypoints=poses.keypoints.copy())
    odd.track_id[:40] = 9999
    odd.keypoints[40:60, :, 2] = np.where(odd.keypoints[40:60, :, 2] > 0, 1.0373, 0)
    with pytest.warns(GymtrackWarning, match=r"40 poses name a track_id the track output does not have \(9999\)"):
        out = lift_poses(res, sim.rig, sim.scene, odd)
    assert out.counts["unknown_track"] == 40 and out.counts["used"] + out.counts["foreign_torso"] == len(poses) - 40
    assert out.counts["scores_clipped"] == int((odd.keypoints[40:60, :, 2] > 1).sum()) > 0
    assert (out.poses3d.score <= 1).all()
    with pytest.raises(InputError, match="no 2D poses to lift"):
        check_liftable(res, Poses2D.empty(COCO17, sim.rig.names), all_tracks=True)
    no_target = replace(res, target=Target(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3)),
                                           np.zeros(0, np.int8)))
    with pytest.raises(NoTargetError, match="no target frames.*--all-tracks"):
        check_liftable(no_target, poses, all_tracks=False)
    check_liftable(no_target, poses, all_tracks=True)
