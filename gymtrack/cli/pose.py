"""``gymtrack pose <routine> <out>``: the target's 3D pose from 2D keypoints in its boxes.

Paper: Section III-D, last paragraph -- the expanded boxes ``b_buf`` are where a top-down pose
model runs; the 3D pose is triangulated from its keypoints (:mod:`gymtrack.pose.stage`).

Reads the track outputs in ``<out>`` (``gymtrack track <routine> --out <out>`` first) and 2D poses
from ``<routine>/keypoints/`` (or ``--keypoints DIR``), or, for a simulated routine (one with
``gt/keypoints_3d.csv``), runs the simulated pose model (``--simulated-model``) on the b_buf boxes
in ``<out>/target_2d/`` (and every track's boxes in ``<out>/tracks_2d/`` with ``--all-tracks``),
or runs an ONNX pose model (``--model FILE.onnx``, :mod:`gymtrack.models.pose`) on affine crops of
those boxes from ``<routine>/videos/``.
Writes ``<out>/keypoints/<camera>.json`` (every pose, with the track it was assigned to) and
``<out>/poses_3d.csv``, and prints where every input pose went.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from gymtrack.cli import app
from gymtrack.cli.options import calibration_format_option, calibration_option, read_routine, skeleton_option, units_option
from gymtrack.cli.locking import force_routine_option, hold_for_command, wait_option
from gymtrack.cli.report import interrupts

console = Console()


def model_poses(routine, result, model, models_yaml, device, all_tracks: bool):
    """The pose model (``--model`` / ``models.yaml``) on the b_buf crops of the routine's videos -> Poses2D."""
    from gymtrack.cli.detect import build_models, open_routine_videos, stage_progress
    from gymtrack.models import pose_videos
    from gymtrack.pose.stage import pose_model_boxes

    _, pm = build_models(models_yaml, pose=model, device=device, need_pose=True)
    boxes = pose_model_boxes(result, all_tracks)
    with open_routine_videos(routine.path, routine.rig, routine.scene) as videos, stage_progress("pose model") as bar:
        task = bar.add_task("pose", total=None)
        run = pose_videos(videos, pm, boxes, progress=lambda k, n: bar.update(task, completed=k, total=n))
    console.print(f"{pm.kind} pose model on {pm.provider}: {len(run.poses)} poses from {run.boxes} boxes"
                  + (f" ({run.no_image} boxes without a video frame)" if run.no_image else ""), highlight=False)
    return run.poses


def empty_reason(summary: dict) -> str:
    """Why no pose was lifted, from the stage's counts, and what to change."""
    read = summary.get("read", 0)
    if summary.get("rejected_frame", 0) == read:
        return ("every pose's frame lies outside the track output's frames: the keypoints' frame numbers must be "
                "the detections' (OpenPose counts from 0, MOTChallenge from 1: renumber one of them)")
    if summary.get("unknown_track", 0) + summary.get("unassigned", 0) + summary.get("rejected", 0) >= read:
        return ("no pose could be given a track: none overlaps a tracked box (min IoU 0.3) in its frame and view; "
                "check that the keypoints and the detections come from the same videos and frame numbers")
    return "the assigned poses had no joint seen by two views; check the cameras' matching (printed above)"


def pose_summary_table(summary: dict, title: str = "Pose stage") -> Table:
    """Where every input pose went, and what was lifted."""
    t = Table(title=title, title_justify="left")
    t.add_column("what")
    t.add_column("value", justify="right")
    rows = [
        ("poses read", "read"), ("  with a track id already", "given"), ("  assigned to a track here", "assigned"),
        ("  unassigned (no track box overlaps)", "unassigned"), ("  rejected: no joint found", "rejected_no_joints"),
        ("  rejected: frame outside the track output", "rejected_frame"),
        ("  track_id naming no track of the output", "unknown_track"), ("assigned poses lifted", "used"),
        ("  duplicates (same track, frame, view)", "duplicate"),
        ("  the same body as another track's pose there (left to that track)", "same_body"),
        ("  another track's body in the crop: moved to it", "foreign_moved"),
        ("  another track's body in the crop, which has its own: dropped", "foreign_dropped"),
        ("  another body's torso (its other views or frames say so): set aside", "foreign_torso"), ("  not lifted (track not lifted)", "not_lifted"),
        ("joint scores above 1, clipped", "scores_clipped"), ("tracks without a 2D pose (no skeleton)", "tracks_without_pose"),
        ("frames with a 3D pose", "frames_with_pose"), ("tracks with a 3D pose", "tracks_with_pose"),
        ("joints triangulated", "joints_triangulated"), ("joints on the plane only", "joints_plane"),
        ("joints fused (rays + plane)", "joints_fused"), ("bone length variation over frames", "bone_length_cv"),
        ("left/right limb difference", "left_right_asymmetry"),
    ]
    for label, key in rows:
        if key in summary:
            t.add_row(label, str(summary[key]))
    return t


@app.command()
def pose(
    ctx: typer.Context,
    routine: Path = typer.Argument(..., help="routine folder (cameras.yaml, scene.yaml, detections/, keypoints/ or gt/)"),
    out: Path = typer.Argument(..., help="the track output folder of `gymtrack track`; poses are written into it"),
    keypoints: Optional[Path] = typer.Option(None, "--keypoints", "-k", help="2D poses folder, any layout the keypoints "
                                             "readers take (default: ROUTINE/keypoints, else Pose2Sim's ROUTINE/pose)"),
    skeleton: Optional[str] = skeleton_option(),
    calibration: Optional[Path] = calibration_option(),
    simulated_model: bool = typer.Option(False, "--simulated-model", help="run the simulated pose model on the boxes in OUT (needs ROUTINE/gt)"),
    all_tracks: bool = typer.Option(False, "--all-tracks", help="lift every 3D track, not only the target"),
    lift: str = typer.Option("robust", "--lift", help="dlt | robust"),
    seed: int = typer.Option(0, "--seed", help="seed of the simulated pose model"),
    calibration_format: Optional[str] = calibration_format_option(),
    units: Optional[str] = units_option(),
    model: Optional[Path] = typer.Option(None, "--model", help="pose ONNX file: run it on the b_buf crops of ROUTINE/videos"),
    models_yaml: Optional[Path] = typer.Option(None, "--models", help="models.yaml (pose.path and adapter options)"),
    device: Optional[str] = typer.Option(None, "--device", help="cpu | cuda | tensorrt | auto (with --model)"),
    force: bool = force_routine_option(),
    wait: float = wait_option(),
) -> None:
    """Lift 2D keypoints in the tracker's boxes to the target's 3D pose (every track's with --all-tracks)."""
    from gymtrack.errors import InputError
    from gymtrack.formats.keypoints import write_keypoints
    from gymtrack.formats.poses3d import write_poses_3d
    from gymtrack.formats.atomic import atomic_update
    from gymtrack.pose.sources import routine_poses
    from gymtrack.pose.stage import LIFT_METHODS, check_liftable, lift_poses, read_track_result

    if lift not in LIFT_METHODS:
        raise InputError(f"unknown lifting method {lift!r}; choose one of {', '.join(LIFT_METHODS)}", field="--lift")
    use_model = model is not None or models_yaml is not None
    if sum([simulated_model, keypoints is not None, use_model]) > 1:
        raise InputError("give one of --keypoints, --simulated-model, --model", field="--keypoints")
    hold_for_command(ctx, out, "pose", wait, routine, force)  # from the first read of OUT to the last write
    from gymtrack.formats.keypoints import KeypointsReport

    r, _ = read_routine(routine, calibration_format, units, calibration=calibration,
                        keypoints=None if simulated_model or use_model else keypoints, skeleton=skeleton)
    result = read_track_result(out, r.rig.names)
    report = KeypointsReport()
    if use_model:
        poses = model_poses(r, result, model, models_yaml, device, all_tracks)
    else:
        with console.status("running the simulated pose model on the boxes" if simulated_model else "reading the 2D poses"):
            poses = routine_poses(r, result, keypoints, simulated_model, all_tracks, seed, skeleton, report)
        if report.sources and r.keypoints_report is None:  # not printed yet by read_routine
            for line in report.lines():
                console.print(f"2D poses: {line}", highlight=False, soft_wrap=True)
    check_liftable(result, poses, all_tracks)
    with console.status(f"lifting ({lift})"):
        res = lift_poses(result, r.rig, r.scene, poses, all_tracks=all_tracks, method=lift)
    if not len(res.poses3d):
        console.print(pose_summary_table(res.summary()))
        raise InputError("no 3D pose: " + empty_reason(res.summary()), field="keypoints")
    inputs = {"routine": str(routine), "lift": lift, "all_tracks": all_tracks,
              "keypoints": (f"pose model {model or models_yaml}" if use_model else "simulated model" if simulated_model
                            else str(keypoints or r.keypoints_path or Path(routine) / "keypoints"))}
    with interrupts(), atomic_update(out, "pose", inputs) as staging:  # all or nothing, into the track output
        write_keypoints(staging / "keypoints", res.poses2d)
        write_poses_3d(staging / "poses_3d.csv", res.poses3d)
    console.print(pose_summary_table(res.summary()))
    console.print(f"wrote [bold]{Path(out) / 'keypoints'}[/] and [bold]{Path(out) / 'poses_3d.csv'}[/]")


def demo_pose_table(sim, results: dict, perf_frames: np.ndarray, seed: int = 0) -> Table:
    """``gymtrack demo``'s pose lines: the target's pose error from each method's b_buf boxes.

    sim: the SimulatedRoutine (its ``keypoints`` (P, T, 17, 3) are the ground truth); results:
    mode -> TrackResult; the simulated pose model runs on each result's ``target_boxes`` with the
    same seed, the pose stage lifts the target (robust), errors on ``perf_frames``; PCK@150 over
    all of them (a frame without a pose counts as a miss) beside MPJPE (over the posed joints).
    """
    from gymtrack.eval.pose_metrics import target_pose_error
    from gymtrack.pose.stage import lift_poses
    from gymtrack.simulate.pose_model import simulate_pose_model
    from gymtrack.skeletons import COCO17

    t = Table(title="Target's 3D pose vs ground truth (simulated pose model in each method's b_buf, robust lifting)",
              title_justify="left")
    # PCK over every performing frame (a frame without a pose: its joints are misses), so a method
    # that poses fewer frames does not read as posing as well as one that poses them all
    for col in ("mode", "MPJPE", "PCK@150mm (all performing frames)", "PA-MPJPE", "frames with a pose"):
        t.add_column(col, justify="right" if col != "mode" else "left")
    k = int(np.flatnonzero(sim.person_id == sim.target_id)[0])
    for mode, res in results.items():
        poses = simulate_pose_model(sim.rig, sim.keypoints, sim.person_id, sim.frames, res.target_boxes, seed=seed)
        p = lift_poses(res, sim.rig, sim.scene, poses).poses3d
        e = target_pose_error(p.frame, p.xyz, p.skeleton.joints, sim.frames, sim.keypoints[k], COCO17.joints, perf_frames)
        t.add_row(mode, f"{e.mpjpe:.0f} mm", f"{e.pck_all:.0%}", f"{e.pa_mpjpe:.0f} mm", f"{e.pose_share:.0%}")
    return t
