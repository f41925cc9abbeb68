"""``gymtrack detect <routine> --model det.onnx``: person boxes from the routine's videos.

Paper: Section III-A -- a person detector (YOLOX-S in the paper, frames rescaled to 608 x 608)
on every frame of every synchronised view gives the boxes the tracker starts from. Runs an ONNX
detector (:mod:`gymtrack.models.detector`) on ``videos/<camera>.*`` (numbered with scene.yaml's
``first_frame`` and ``video_offsets``) and writes ``detections/<camera>.txt`` (MOTChallenge, one
file per camera, each written to a temporary name and renamed, so a stopped run leaves no half
file). Also the helpers ``gymtrack run`` shares: the rig and scene of a routine without
detections, the models from options or ``models.yaml``, a progress bar, a table of times.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn
from rich.table import Table

from gymtrack.cli import app
from gymtrack.cli.options import calibration_format_option, units_option

console = Console()


def load_rig_scene(routine: Path, calibration_format: Optional[str] = None, units: Optional[str] = None):
    """(rig, scene) of a routine folder that may not have ``detections/`` yet."""
    from gymtrack.errors import RoutineError
    from gymtrack.formats.calibration import find_calibration, read_calibration
    from gymtrack.formats.scene import load_scene

    routine = Path(routine)
    if not routine.is_dir():
        raise RoutineError("routine folder not found", source=routine)
    if not (routine / "scene.yaml").is_file():
        raise RoutineError("missing scene.yaml: write one with at least 'apparatus: <preset>' (see docs/formats.md)",
                           source=routine / "scene.yaml")
    opts = {} if units is None else {"units": units}
    rig, _ = read_calibration(find_calibration(routine, error=RoutineError), calibration_format, **opts)
    return rig, load_scene(routine / "scene.yaml")


def open_routine_videos(routine: Path, rig, scene, required: bool = True):
    """The routine's videos as a VideoSet in rig order (first_frame and video_offsets from the scene)."""
    from gymtrack.errors import InputError
    from gymtrack.formats.video import open_videos

    try:  # boxes and keypoints are written in the calibration's pixels, whatever the video's size
        return open_videos(routine, rig.names, scene.first_frame, scene.video_offsets, required=required,
                           sizes=[tuple(int(v) for v in cam.size) for cam in rig])
    except InputError as exc:
        if exc.field and exc.field.startswith("video_offsets"):
            raise exc.located(source=Path(routine) / "scene.yaml") from None
        raise


def build_models(models_yaml: Optional[Path], detector: Optional[Path] = None, pose: Optional[Path] = None,
                 device: Optional[str] = None, need_detector: bool = False, need_pose: bool = False):
    """(Detector or None, PoseModel or None) from options, falling back to ``models.yaml`` entries."""
    from gymtrack.errors import InputError
    from gymtrack.models import Detector, PoseModel, load_models_config

    cfg = load_models_config(models_yaml)
    dev = device or cfg.device
    det_path = detector or cfg.detector.path
    pose_path = pose or cfg.pose.path
    if need_detector and det_path is None:
        raise InputError("no detector: give --model/--detector FILE.onnx or detector.path in models.yaml "
                         "(docs/models.md lists exports that fit)", field="--detector")
    if need_pose and pose_path is None:
        raise InputError("no pose model: give --pose-model FILE.onnx or pose.path in models.yaml", field="--pose-model")
    det = Detector(det_path, cfg.detector.options(), dev) if det_path is not None else None
    pm = PoseModel(pose_path, cfg.pose.options(), dev) if pose_path is not None else None
    return det, pm


def stage_progress(label: str) -> Progress:
    return Progress(TextColumn(f"[bold]{label}"), BarColumn(), MofNCompleteColumn(), TextColumn("frames"),
                    TimeRemainingColumn(), console=console, transient=True)


def times_table(rows: list[tuple[str, float, int]], title: str = "Time per stage") -> Table:
    """(stage, seconds, frames) rows -> a table with seconds and ms per multi-view frame."""
    t = Table(title=title, title_justify="left")
    for c in ("stage", "seconds", "ms / frame"):
        t.add_column(c, justify="left" if c == "stage" else "right")
    for name, sec, frames in rows:
        t.add_row(name, f"{sec:.2f}", f"{1000 * sec / frames:.1f}" if frames else "-")
    t.add_row("[bold]total", f"{sum(r[1] for r in rows):.2f}", "")
    return t


def write_detections_atomic(folder: Path, detections) -> list[Path]:
    """One MOTChallenge file per camera under ``folder``, each written then renamed into place."""
    from gymtrack.formats.motchallenge import write_mot_detections

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for cam in detections.camera_names:
        final = folder / f"{cam}.txt"
        tmp = folder / f".{cam}.txt.partial-{os.getpid()}"
        write_mot_detections(tmp, detections.for_camera(cam))
        os.replace(tmp, final)
        paths.append(final)
    return paths


def run_detector(routine: Path, det, rig, scene, label: str = "detecting"):
    """Detector over the routine's videos with a progress bar -> DetectRun."""
    from gymtrack.models import detect_videos

    from gymtrack.cli.report import REPORTER

    with open_routine_videos(routine, rig, scene) as videos, stage_progress(label) as bar:
        task = bar.add_task(label, total=None)
        run = detect_videos(videos, det, progress=lambda d, n: bar.update(task, completed=d, total=n))
    for cam, faults in run.video_faults.items():  # boxes stay on their frames; the frames a camera lacks are said
        REPORTER.warn(f"video of {cam}: {faults.summary()}")
    return run


def detect_report(run, det) -> str:
    counts = run.detections.counts_per_camera()
    lines = [f"{det.kind} detector on {det.provider}: {run.frames} frames, "
             + ", ".join(f"{c} {n}" for c, n in counts.items()) + " boxes"]
    if run.skipped_frames:
        lines.append(f"{run.skipped_frames} frames numbered below 1 (video_offsets) skipped")
    if run.missing_images:
        lines.append(f"{run.missing_images} (frame, camera) pairs without an image (shorter video, offset, "
                     "dropped or corrupt frames)")
    return "\n".join(lines)


@app.command()
def detect(
    routine: Path = typer.Argument(..., help="routine folder (cameras.yaml, scene.yaml, videos/<camera>.*)"),
    model: Optional[Path] = typer.Option(None, "--model", "-m", help="detector ONNX file (or detector.path in --models)"),
    models_yaml: Optional[Path] = typer.Option(None, "--models", help="models.yaml with paths and adapter options"),
    device: Optional[str] = typer.Option(None, "--device", help="cpu | cuda | tensorrt | auto (default cpu)"),
    force: bool = typer.Option(False, "--force", help="replace existing detections/<camera>.txt files"),
    calibration_format: Optional[str] = calibration_format_option(),
    units: Optional[str] = units_option(),
) -> None:
    """Run a person detector on the routine's videos and write detections/<camera>.txt."""
    from gymtrack.errors import InputError

    rig, scene = load_rig_scene(routine, calibration_format, units)
    out = Path(routine) / "detections"
    existing = [n for n in rig.names if (out / f"{n}.txt").exists()]
    if existing and not force:
        raise InputError(f"detections/ already has {', '.join(e + '.txt' for e in existing)}: give --force to replace them",
                         source=out)
    det, _ = build_models(models_yaml, detector=model, device=device, need_detector=True)
    run = run_detector(routine, det, rig, scene)
    write_detections_atomic(out, run.detections)
    console.print(detect_report(run, det))
    ms = run.times.ms_per_frame(run.frames)
    console.print(times_table([(k, ms[k] * run.frames / 1000, run.frames) for k in ms], "Time per step"))
    console.print(f"wrote [bold]{out}[/] ({len(run.detections)} boxes)")
