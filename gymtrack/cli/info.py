"""``gymtrack info <routine>``: check a routine folder and show what the tracker will work with.

Paper: summarises the inputs of Section III: the calibrated views (``P_c``, III-B), the opposite
view pairs whose line-of-sight angle makes triangulation ill-conditioned and calls for the
ray-plane intersection (III-C), the per-view boxes (III-A) and the domain knowledge of the scene
(performance space, buffer, planes, identification heights ``h_top`` / ``h_bot``, parameters).
It also reports the stream checks of :mod:`gymtrack.formats.checks` (cameras that go silent,
gaps, share of boxes outside the image) as warnings (``--strict``: exit 3 on any).
``gymtrack info --system``: versions, numba cache, CPUs (:mod:`gymtrack.cli.system`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from gymtrack.cli import app
from gymtrack.cli.options import (calibration_format_option, calibration_option, keypoints_option, read_routine,
                                  silent_seconds_option, skeleton_option, strict_option, units_option)
from gymtrack.cli.report import REPORTER
from gymtrack.formats.checks import StreamChecks
from gymtrack.formats.routine import Routine
from gymtrack.scene import Scene
from gymtrack.geometry.camera import Rig


def _vec(v, fmt: str = "{:+.2f}") -> str:
    return "(" + ", ".join(fmt.format(float(x)) for x in v) + ")"


def cameras_table(rig: Rig) -> Table:
    """One row per camera: size, centre, viewing direction (azimuth and tilt of the optical axis),
    focal length, distortion."""
    t = Table(title=f"Cameras ({len(rig)})", title_justify="left")
    t.add_column("#", justify="right")
    t.add_column("name", no_wrap=True)
    t.add_column("size", no_wrap=True)
    t.add_column("centre (m)", no_wrap=True)
    t.add_column("looks (az, tilt)", no_wrap=True)
    t.add_column("f (px)", justify="right")
    t.add_column("dist.")
    for i, c in enumerate(rig):
        d = c.optical_axis
        az = float(np.degrees(np.arctan2(d[1], d[0])))
        tilt = float(np.degrees(np.arcsin(np.clip(d[2], -1, 1))))  # negative = looking down
        f = 0.5 * (c.K[0, 0] + c.K[1, 1])
        t.add_row(
            str(i), c.name, f"{c.size[0]}x{c.size[1]}", _vec(c.centre, "{:.1f}"), f"{az:+.0f}, {tilt:+.0f} deg",
            f"{f:.0f}", "yes" if c.has_distortion else "no",
        )
    return t


def opposite_table(rig: Rig, scene: Scene) -> Table:
    """Camera pairs whose lines of sight meet at the scene's focus (the apparatus; by default the
    performance-space centre) at more than ``params.opposite_angle_deg`` (the pairs the ray-plane
    fallback is for)."""
    from gymtrack.geometry.views import pairwise_angles

    centre = scene.focus_point
    thr = scene.params.opposite_angle_deg
    ang = pairwise_angles(rig, centre)
    t = Table(
        title=f"Opposite camera pairs: line-of-sight angle > {thr:g} deg at the focus {_vec(centre, '{:.2f}')}",
        title_justify="left", min_width=60,
    )
    t.add_column("camera a", no_wrap=True)
    t.add_column("camera b", no_wrap=True)
    t.add_column("angle", justify="right")
    iu, ju = np.triu_indices(len(rig), k=1)
    sel = ang[iu, ju] > thr
    for i, j in zip(iu[sel], ju[sel]):
        t.add_row(rig[int(i)].name, rig[int(j)].name, f"{ang[i, j]:.1f} deg")
    if not sel.any():
        t.add_row("(none)", "", "")
    return t


def detections_table(routine: Routine, checks: StreamChecks | None = None) -> Table:
    """Per camera: boxes, frames, frame range, out-of-order lines, frame-0 lines, skipped lines;
    with ``checks``: frames silent (longer than the threshold), share of boxes outside the image."""
    t = Table(title=f"Detections ({len(routine.detections)} boxes)", title_justify="left")
    t.add_column("camera", no_wrap=True)
    cols = ("boxes", "frames", "frame range", "unsorted", "frame 0") + (("silent frames", "outside image (wholly / partly)") if checks else ())
    for col in cols:
        t.add_column(col, justify="right")
    t.add_column("skipped")
    for r in routine.reports:
        rng = f"{r.frame_range[0]}..{r.frame_range[1]}" if r.frame_range else "-"
        skipped = ", ".join(f"{k}: {v}" for k, v in r.skipped.items()) or "-"
        extra = ()
        if checks:
            silent = sum(s.frames for s in checks.silences if s.camera == r.camera)
            extra = (str(silent), f"{checks.outside[r.camera]:.1%} / {checks.partly_outside[r.camera]:.1%}")
        t.add_row(r.camera, str(r.boxes), str(r.frames), rng, str(r.unsorted_lines), str(r.frame_zero_lines), *extra, skipped)
    return t


def scene_table(scene: Scene) -> Table:
    """The domain knowledge: apparatus, spaces, planes, target heights, parameters."""
    t = Table(title="Scene", title_justify="left", show_header=False)
    t.add_column("key", style="bold")
    t.add_column("value")
    t.add_row("apparatus", scene.apparatus or "(none: custom scene)")
    t.add_row("fps", f"{scene.fps:g}")
    t.add_row("performance space (m)", _vec(scene.performance_space[:3], "{:.2f}") + " .. " + _vec(scene.performance_space[3:], "{:.2f}"))
    ts = scene.tracking_space
    t.add_row(f"tracking space (buffer {scene.buffer:g} m)", _vec(ts[:3], "{:.2f}") + " .. " + _vec(ts[3:], "{:.2f}"))
    if scene.planes:
        for k, p in enumerate(scene.planes):
            t.add_row(f"plane {k}", f"point {_vec(p.point, '{:.2f}')}, normal {_vec(p.normal, '{:+.2f}')}"
                      + ("" if p.is_vertical else "  (not vertical)"))
    else:
        t.add_row("planes", "(none)")
    t.add_row("target h_top / h_bot", f"{scene.target.h_top:g} m / {scene.target.h_bot:g} m")
    t.add_row("params", ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in scene.params.model_dump().items()))
    return t


def video_size_lines(routine: Routine) -> list[str]:
    """One line per camera video in ``videos/``: its size against the calibration's (another size
    warns through :func:`gymtrack.formats.video.size_scale`; ``--strict`` makes it exit 3)."""
    from gymtrack.formats.video import VideoReader, find_videos, size_scale

    if not (routine.path / "videos").is_dir():
        return []
    out = []
    for name, path in find_videos(routine.path, routine.rig.names).items():
        with VideoReader(path) as r:
            size = r.size
        cam = routine.rig[routine.rig.names.index(name)]
        calibrated = tuple(int(v) for v in cam.size)
        scale = size_scale(name, calibrated, size, path)
        out.append(f"video {path.name}: {size[0]}x{size[1]}" + ("" if scale == 1 else f", scaled by {scale:.4f} to the "
                                                                   f"calibrated {calibrated[0]}x{calibrated[1]}"))
    return out


def print_routine_info(routine: Routine, console: Console | None = None, checks: StreamChecks | None = None) -> None:
    """Print every table of ``gymtrack info`` for a loaded routine (and its stream checks)."""
    console = console or Console()
    rep = routine.calibration_report
    console.print(f"[bold]Routine[/] {routine.path}")
    console.print(f"calibration: {routine.calibration_path.name} ({rep.format}, translations in {rep.units})", highlight=False)
    for reason, n in rep.skipped.items():
        console.print(f"  left out {n} camera(s): {reason}", highlight=False)
    for note in rep.notes:
        console.print(f"  note: {note}", highlight=False)
    console.print(cameras_table(routine.rig))
    for line in video_size_lines(routine):
        console.print(line, highlight=False)
    console.print(opposite_table(routine.rig, routine.scene))
    console.print(detections_table(routine, checks))
    if checks and checks.frame_range:
        lo, hi = checks.frame_range
        console.print(f"frames with detections: {checks.frames_with_data} of the range {lo}..{hi}; "
                      f"{len(checks.gaps)} gap(s) with no camera, {len(checks.silences)} silent stretch(es) of single cameras",
                      highlight=False)
    if routine.ignored:
        console.print(f"ignored in detections/ (not .txt): {', '.join(p.name for p in routine.ignored)}", highlight=False)
    console.print(scene_table(routine.scene))
    from gymtrack.formats.floor_check import standing_bottoms

    floor = standing_bottoms(routine.detections, routine.rig)
    sc = routine.scene
    if floor is None:
        console.print("floor: too few standing people seen by two views to say where the box bottoms lie", highlight=False)
    else:
        console.print(f"floor: {floor.describe()}; target.h_bot is {sc.target.h_bot:g} m above z = 0", highlight=False)
        advice = floor.advice(sc.performance_space[2], sc.target.h_bot)
        if advice:
            REPORTER.warn(advice)
    if routine.has_gt:
        have = ", ".join(routine.gt) or "no known files"
        console.print(f"ground truth: gt/ ({have})", highlight=False)
    else:
        console.print("ground truth: none", highlight=False)


@app.command()
def info(
    routine: Optional[Path] = typer.Argument(None, help="routine folder (cameras.yaml, scene.yaml, detections/<camera>.txt)"),
    calibration_format: Optional[str] = calibration_format_option(),
    units: Optional[str] = units_option(),
    calibration: Optional[Path] = calibration_option(),
    keypoints: Optional[Path] = keypoints_option(),
    skeleton: Optional[str] = skeleton_option(),
    silent_seconds: float = silent_seconds_option(),
    strict: bool = strict_option(),
    system: bool = typer.Option(False, "--system", help="print versions, the numba cache and CPUs (for a bug report)"),
) -> None:
    """Validate a routine folder and show its cameras, opposite pairs, detections and scene."""
    from gymtrack.errors import InputError

    console = Console()
    if system:
        from gymtrack.cli.system import system_rows

        t = Table(title="System", title_justify="left", show_header=False)
        t.add_column("what", style="bold")
        t.add_column("value", overflow="fold")  # whole paths: the table goes into bug reports
        for k, v in system_rows():
            t.add_row(k, v)
        console.print(t)
        if routine is None:
            return
    if routine is None:
        raise InputError("give a routine folder (gymtrack info <routine>), or --system", field="ROUTINE")
    r, checks = read_routine(routine, calibration_format, units, silent_seconds, calibration, keypoints, skeleton)
    if r.keypoints_report is None and r.keypoints_path is not None:  # poses beside detections: check them too
        from gymtrack.formats.keypoints import KeypointsReport, read_keypoints

        report = KeypointsReport()
        read_keypoints(r.keypoints_path, r.rig.names, skeleton=skeleton, report=report)
        for line in report.lines():
            console.print(f"2D poses: {line}", highlight=False, soft_wrap=True)
    print_routine_info(r, console, checks)
    REPORTER.check_strict(strict)
