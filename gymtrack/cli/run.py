"""``gymtrack run <routine> --out <out> --detector det.onnx --pose-model pose.onnx``: videos to 3D poses.

Paper: the whole system of Section III in one command -- the person detector on every view
(III-A), the cascaded tracker and the target gymnast (III-B to III-D), the top-down pose model on
the crops of ``b_buf`` and the lifted 3D pose (III-D, last paragraph). Writes into ``<out>``
every output of ``docs/formats.md``: ``detections/`` (the detector's boxes, so ``track`` can be
rerun), the track outputs, ``keypoints/``, ``poses_3d.csv`` and ``analysis/`` (what judges measure,
:mod:`gymtrack.analysis`); shows a progress bar per stage
and the time per stage. ``--mode``, ``--without`` and ``--adding`` choose the tracker's recipe as
for ``gymtrack track``.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Optional

import typer

from gymtrack.cli import app
from gymtrack.cli.options import (adding_option, calibration_format_option, mode_option, overwrite_option, recipe_of,
                                  units_option, without_option)
from gymtrack.cli.locking import hold, wait_option
from gymtrack.cli.report import interrupts
from gymtrack.cli.detect import (build_models, console, detect_report, load_rig_scene, open_routine_videos,
                                 run_detector, stage_progress, times_table, write_detections_atomic)


@app.command()
def run(
    routine: Path = typer.Argument(..., help="routine folder (cameras.yaml, scene.yaml, videos/<camera>.*)"),
    out: Path = typer.Option(..., "--out", "-o", help="output folder (replaced whole, atomically, when the run completes)"),
    detector: Optional[Path] = typer.Option(None, "--detector", help="detector ONNX file (or detector.path in --models)"),
    pose_model: Optional[Path] = typer.Option(None, "--pose-model", help="pose ONNX file (or pose.path in --models)"),
    models_yaml: Optional[Path] = typer.Option(None, "--models", help="models.yaml with paths and adapter options"),
    device: Optional[str] = typer.Option(None, "--device", help="cpu | cuda | tensorrt | auto (default cpu)"),
    mode: str = mode_option(),
    without: Optional[list[str]] = without_option(),
    adding: Optional[list[str]] = adding_option(),
    all_tracks: bool = typer.Option(False, "--all-tracks", help="pose and lift every 3D track, not only the target"),
    lift: str = typer.Option("robust", "--lift", help="dlt | robust"),
    overwrite: bool = overwrite_option(),
    calibration_format: Optional[str] = calibration_format_option(),
    units: Optional[str] = units_option(),
    wait: float = wait_option(),
) -> None:
    """Videos -> detections -> tracks -> 2D poses in b_buf -> 3D poses -> judging measurements, in one command."""
    from gymtrack.errors import InputError
    from gymtrack.formats.atomic import atomic_output, check_output_folder
    from gymtrack.pose.stage import LIFT_METHODS

    mode = recipe_of(mode, without, adding).name
    if lift not in LIFT_METHODS:
        raise InputError(f"unknown lifting method {lift!r}; choose one of {', '.join(LIFT_METHODS)}", field="--lift")
    out = Path(out)
    rig, scene = load_rig_scene(routine, calibration_format, units)
    det, pm = build_models(models_yaml, detector, pose_model, device, need_detector=True, need_pose=True)
    inputs = {"routine": Path(routine).absolute(), "detector": det.session.path.absolute(),
              "pose_model": pm.session.path.absolute(), "mode": mode, "lift": lift, "all_tracks": all_tracks,
              "calibration_format": calibration_format, "units": units}
    with interrupts(), hold(check_output_folder(out, overwrite, [routine]), "run", wait), \
            atomic_output(out, "run", inputs, overwrite=overwrite, protect=[routine]) as staging:
        times = _stages(routine, staging, rig, scene, det, pm, mode, all_tracks, lift)
    console.print(times_table(times))
    console.print(f"outputs written to [bold]{out}[/]")


def _stages(routine: Path, out: Path, rig, scene, det, pm, mode: str, all_tracks: bool, lift: str) -> list:
    """The stages into ``out`` (the staging folder); returns (stage, seconds, frames) rows."""
    from gymtrack.cli.pose import pose_summary_table
    from gymtrack.cli.track import summary_table
    from gymtrack.formats.keypoints import write_keypoints
    from gymtrack.formats.outputs import write_outputs
    from gymtrack.formats.poses3d import write_poses_3d
    from gymtrack.models import pose_videos
    from gymtrack.pose.stage import lift_poses, pose_model_boxes
    from gymtrack.tracking.offline import track_detections

    console.print(f"detector {det.session.path.name} ({det.kind}, {det.provider}); "
                  f"pose model {pm.session.path.name} ({pm.kind}, {pm.skeleton.name}, {pm.provider})", highlight=False)
    times = []

    t0 = time.perf_counter()
    d = run_detector(routine, det, rig, scene, "1/3 detecting")
    detections = d.detections.sorted()
    write_detections_atomic(out / "detections", detections)
    times.append(("detect (decode, letterbox, model, NMS)", time.perf_counter() - t0, d.frames))
    console.print(detect_report(d, det))

    t0 = time.perf_counter()
    with stage_progress("2/3 tracking") as bar:
        task = bar.add_task("track", total=None)
        result = track_detections(rig, scene, detections, mode=mode,
                                  progress=lambda k, n: bar.update(task, completed=k, total=n))
    write_outputs(result, out)
    times.append(("track", time.perf_counter() - t0, d.frames))
    console.print(summary_table(result.summary))

    t0 = time.perf_counter()
    boxes = pose_model_boxes(result, all_tracks)
    with open_routine_videos(routine, rig, scene) as videos, stage_progress("3/3 pose model") as bar:
        task = bar.add_task("pose", total=None)
        p = pose_videos(videos, pm, boxes, progress=lambda k, n: bar.update(task, completed=k, total=n))
    times.append(("pose model (decode, crops, model)", time.perf_counter() - t0, d.frames))
    if p.no_image:
        console.print(f"{p.no_image} of {p.boxes} pose boxes have no video frame (not posed)")

    t0 = time.perf_counter()
    res = lift_poses(result, rig, scene, p.poses, all_tracks=all_tracks, method=lift)
    write_keypoints(out / "keypoints", res.poses2d)
    write_poses_3d(out / "poses_3d.csv", res.poses3d)
    times.append(("lift", time.perf_counter() - t0, d.frames))
    console.print(pose_summary_table(res.summary()))

    from gymtrack.analysis.folder import analyse_output, write_analysis
    from gymtrack.cli.analyse import element_table
    from gymtrack.errors import InputError

    t0 = time.perf_counter()
    try:  # the judging layer on the target's skeleton
        a = analyse_output(routine, out)
    except InputError as exc:  # no target or no pose: the run's other outputs stand
        console.print(f"no analysis/: {exc}", highlight=False)
        return times
    for note in write_analysis(a, out / "analysis"):
        console.print(note, highlight=False)
    times.append(("analyse", time.perf_counter() - t0, d.frames))
    console.print(element_table(a))
    return times
