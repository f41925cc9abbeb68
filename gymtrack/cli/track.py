"""``gymtrack track`` and ``gymtrack demo``: run the tracker of Section III.

* ``gymtrack track <routine> --out <out> [--mode cascade|triangulation|plane] [--without floor]
  [--adding floor]`` (a recipe's ingredients switched off or on alone, :class:`gymtrack.modes.Method`) reads a routine
  folder (with the calibration options of ``info``: ``--units``, ``--calibration-format``),
  tracks it with a progress bar, writes the outputs of ``shared/formats.md``
  (:func:`gymtrack.formats.outputs.write_outputs`) atomically (:mod:`gymtrack.formats.atomic`:
  a complete new folder or the previous one untouched; ``--overwrite`` for a non-empty folder
  that is not a gymtrack output) and prints a short summary. Silent cameras, gaps, boxes outside
  the image and a run without tracks or target are warnings; ``--strict`` makes them exit 3
  with nothing written. Ctrl-C: one line, exit 130.
* ``gymtrack demo [--out DIR] [--seconds S]`` simulates a difficult routine (uneven bars seen by
  two opposite cameras), tracks it with the cascade and with triangulation only, and prints the
  target's mean 3D error (AED) against the ground truth for both, and the error of the target's
  3D pose (MPJPE, PCK) from each method's boxes: the point of the method in one command.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np
import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn
from rich.table import Table

from gymtrack.cli import app
from gymtrack.cli.options import (adding_option, calibration_format_option, calibration_option, keypoints_option,
                                  mode_option, overwrite_option, read_routine, recipe_of, silent_seconds_option,
                                  skeleton_option, strict_option, units_option, without_option)
from gymtrack.cli.locking import hold, wait_option
from gymtrack.cli.report import REPORTER, interrupts

console = Console()


def summary_table(summary: dict, title: str = "Tracking summary") -> Table:
    """A short table of a tracker summary: per-camera detections, tracks, target, speed."""
    t = Table(title=title, title_justify="left")
    t.add_column("what")
    t.add_column("value", justify="right")
    t.add_row("mode", str(summary["mode"]))
    t.add_row("frames (with boxes)", f"{summary['frames']}")
    read, used = summary["detections_read"], summary["detections_used"]
    for cam in read:
        t.add_row(f"detections {cam} (used / read)", f"{used[cam]} / {read[cam]}")
    t.add_row("tracks", str(summary["tracks"]))
    t.add_row("target frames", str(summary["target_frames"]))
    t.add_row("target switches", str(summary["target_switches"]))
    t.add_row("segments dropped (< min boxes)", str(summary["segments_dropped_short"]))
    t.add_row("3D tracklets removed as outliers", str(summary["tracklets_outliers"]))
    slowest = max(summary["seconds"], key=summary["seconds"].get)
    t.add_row("seconds (slowest stage)", f"{summary['seconds_total']:.2f} ({slowest})")
    t.add_row("frames per second", f"{summary['fps']}")
    return t


def checks_line(checks) -> str:
    """One line of the stream checks (:class:`gymtrack.formats.checks.StreamChecks`)."""
    outside = ", ".join(f"{c} {checks.outside[c]:.1%}/{checks.partly_outside[c]:.1%}" for c in checks.outside)
    return (f"input: {checks.frames_with_data} frames with detections; {len(checks.silences)} silent stretch(es), "
            f"{len(checks.gaps)} gap(s); boxes outside the image (wholly/partly): {outside}")


def empty_result_warnings(summary: dict) -> list[str]:
    """Warnings for a run that found no 3D tracks or no target, with the usual reasons."""
    why = ("check the calibration's units (--units mm|cm for a file in millimetres or centimetres), that its "
           "world frame is the scene's (metres, z up, origin on the floor under the apparatus) and scene.yaml's "
           "performance_space")
    if summary.get("tracks", 0) == 0:
        return [f"no 3D tracks: nothing was tracked inside the scene's tracking space; {why}"]
    if summary.get("target_frames", 0) == 0:
        return [f"no target frames: no track stayed in the performance space at the target's heights; {why}, "
                "and the target heights h_top / h_bot"]
    return []


@app.command()
def track(
    routine: Path = typer.Argument(..., help="routine folder (cameras.yaml, scene.yaml, detections/)"),
    out: Path = typer.Option(..., "--out", "-o", help="output folder (replaced whole, atomically, when the run completes)"),
    mode: str = mode_option(),
    calibration_format: Optional[str] = calibration_format_option(),
    units: Optional[str] = units_option(),
    calibration: Optional[Path] = calibration_option(),
    keypoints: Optional[Path] = keypoints_option(),
    skeleton: Optional[str] = skeleton_option(),
    overwrite: bool = overwrite_option(),
    strict: bool = strict_option(),
    silent_seconds: float = silent_seconds_option(),
    without: Optional[list[str]] = without_option(),
    adding: Optional[list[str]] = adding_option(),
    watch_cameras: bool = typer.Option(True, "--watch-cameras/--no-watch-cameras", help="watch each camera's residuals: "
                                       "warn when one is knocked (and when, by how many degrees) or out of sync (a few "
                                       "per cent of the tracking speed; a clean routine's outputs are the same either way)"),
    recalibrate: bool = typer.Option(True, "--recalibrate/--no-recalibrate", help="with --watch-cameras: re-estimate a "
                                     "knocked camera's rotation from the other views and track the routine again with it "
                                     "applied from the frame the camera moved"),
    wait: float = wait_option(),
) -> None:
    """Track a routine: 3D tracks, per-view boxes and the target gymnast (paper Section III)."""
    from gymtrack.cli.system import compile_notice
    from gymtrack.formats.atomic import atomic_output, check_output_folder
    from gymtrack.formats.outputs import write_outputs
    from gymtrack.tracking.offline import track_detections

    method = recipe_of(mode, without, adding)
    inputs = {"routine": Path(routine).absolute(), "mode": mode, "calibration_format": calibration_format, "units": units,
              "calibration": calibration and Path(calibration).absolute(), "keypoints": keypoints and Path(keypoints).absolute()}
    if without or adding:
        inputs |= {"without": list(without or ()), "adding": list(adding or ())}
    if not (watch_cameras and recalibrate):  # (recorded where not the default)
        inputs |= {"watch_cameras": watch_cameras, "recalibrate": recalibrate}
    with interrupts(), hold(check_output_folder(out, overwrite, [routine]), "track", wait), \
            atomic_output(out, "track", inputs, overwrite=overwrite, protect=[routine]) as staging:
        r, checks = read_routine(routine, calibration_format, units, silent_seconds, calibration, keypoints, skeleton)
        notice = compile_notice()
        if notice:
            console.print(notice, highlight=False)
        with Progress(TextColumn("[bold]tracking"), BarColumn(), MofNCompleteColumn(), TextColumn("frames"),
                      TimeRemainingColumn(), console=console, transient=True) as bar:
            task = bar.add_task("track", total=None)

            def progress(done: int, total: int) -> None:
                bar.update(task, completed=done, total=total)

            result = track_detections(r.rig, r.scene, r.detections, mode=method, progress=progress, watch_cameras=watch_cameras,
                                       recalibrate=recalibrate)
        if r.pose_boxes is not None:  # the summary says where the boxes came from
            b = r.pose_boxes
            result.summary["boxes_from_poses"] = {"poses": b.poses, "boxes": b.boxes, "too_few_joints": b.too_few_joints,
                                                  "min_score": b.min_score, "pad": b.pad,
                                                  "keypoints": str(r.keypoints_path)}
        for msg in empty_result_warnings(result.summary):
            REPORTER.warn(msg)
        REPORTER.check_strict(strict)
        write_outputs(result, staging)
    console.print(summary_table(result.summary))
    console.print(checks_line(checks), highlight=False)
    console.print(f"outputs written to [bold]{out}[/]")


def _target_error(result, gt_frame: np.ndarray, gt_xyz: np.ndarray) -> tuple[float, float]:
    """(AED in metres over the frames both have, coverage = share of GT frames with an output target)."""
    from gymtrack.eval.metrics import pairs_by_key

    i, j = pairs_by_key(result.target.frame, gt_frame)
    aed = float(np.linalg.norm(result.target.xyz[i] - gt_xyz[j], axis=1).mean()) if len(i) else float("nan")
    cov = len(np.unique(gt_frame[j])) / max(len(np.unique(gt_frame)), 1)
    return aed, cov


#: the demo's modes: the paper's method, beyond it, and the baseline it improves on
DEMO_MODES = ("cascade", "cascade+", "triangulation")


@app.command()
def demo(
    out: Optional[Path] = typer.Option(None, "--out", "-o", help="also write the routine and both results here"),
    seconds: float = typer.Option(30.0, "--seconds", "-s", help="length of the simulated routine (7 s to an hour)"),
    seed: int = typer.Option(0, "--seed", help="simulation seed"),
) -> None:
    """Simulate uneven bars seen by two opposite cameras; compare the cascade with triangulation (and cascade+)."""
    from gymtrack.eval.metrics import average_euclidean_distance, coverage
    from gymtrack.formats.atomic import atomic_output
    from gymtrack.formats.outputs import write_outputs
    from gymtrack.simulate import simulate_routine
    from gymtrack.tracking.offline import track_detections

    if out is not None:  # fail on a bad --out before the work
        from gymtrack.formats.atomic import check_output_folder

        for sub in ("routine",) + DEMO_MODES:
            check_output_folder(Path(out) / sub)
    with console.status(f"simulating {seconds:g} s of uneven bars, two opposite cameras (seed {seed})"):
        sim = simulate_routine("uneven_bars", n_cam=2, seed=seed, seconds=seconds)
    if out is not None:
        with interrupts(), atomic_output(Path(out) / "routine", "demo") as staging:
            sim.write(staging)
    gt = sim.target_centre
    ok = np.all(np.isfinite(gt), axis=1)
    perf = sim.frames[sim.performing & ok]
    plane = sim.scene.planes[0]
    off = np.abs((gt[sim.performing & ok] - np.array(plane.point)) @ np.array(plane.normal))
    from gymtrack.cli.system import compile_notice

    notice = compile_notice()
    if notice:
        console.print(notice, highlight=False)
    results = {}
    for mode in DEMO_MODES:
        with console.status(f"tracking with {mode}"):
            results[mode] = track_detections(sim.rig, sim.scene, sim.detections, mode=mode)
        if out is not None:
            with interrupts(), atomic_output(Path(out) / mode, "demo") as staging:
                write_outputs(results[mode], staging)
    both = perf
    for res in results.values():
        both = np.intersect1d(both, res.target.frame)
    t = Table(title="Target gymnast vs ground truth (performing frames)", title_justify="left")
    for col in ("mode", "AED", "AED where both found it", "coverage", "switches", "frames/s"):
        t.add_column(col, justify="right" if col != "mode" else "left")
    for mode, res in results.items():
        d = average_euclidean_distance(sim.frames[ok], gt[ok], res.target.frame, res.target.xyz, frames=perf)
        dc = average_euclidean_distance(sim.frames[ok], gt[ok], res.target.frame, res.target.xyz, frames=both)
        cov = coverage(perf, res.target.frame)
        t.add_row(mode, f"{d.mean:.3f} m", f"{dc.mean:.3f} m ({dc.n})", f"{cov.share:.0%}",
                  str(res.summary["target_switches"]), f"{res.summary['fps']:.0f}")
    console.print(
        f"{sim.n_frames} frames, {len(sim.detections)} detections in {len(sim.rig)} views; only the opposite pair "
        f"{sim.rig.names[0]}/{sim.rig.names[1]} detects the gymnast, who stays a median "
        f"{np.median(off):.2f} m from the scene's plane."
    )
    console.print(t)
    from gymtrack.cli.pose import demo_pose_table

    with console.status("running the simulated pose model in each method's boxes and lifting the target's pose"):
        console.print(demo_pose_table(sim, results, perf, seed=seed))
    console.print(
        "Triangulating two opposite views is ill-conditioned along the line between the cameras; the cascade "
        "intersects their rays with the gymnast's plane instead (paper Section III-C). Its error grows with the "
        "gymnast's distance from the plane (try other --seed values). cascade+, the default mode, goes beyond the "
        "paper: people on the floor, duplicates left out (README, 'Beyond the paper')."
    )
    if out is not None:
        console.print(f"routine and results written to [bold]{out}[/]")
