"""``gymtrack export <out> --format trc|c3d|mot|bvh``: the skeleton in OpenSim, C3D and BVH files.

Rule: ``shared/formats.md``, "Exports" (:mod:`gymtrack.export`). Reads ``<out>/poses_3d.csv``
(``gymtrack pose``), or ``<out>/analysis/angles.csv`` (``gymtrack analyse``) for MOT; the frame
rate from ``--fps``, the routine's ``scene.yaml`` (``--routine``, else the one the output's marker
names). Prints what was interpolated, split, left out or marked invalid, and the files written.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer
from rich.console import Console

from gymtrack.cli import app
from gymtrack.cli.report import interrupts

console = Console()


@app.command()
def export(
    out: Path = typer.Argument(..., help="output folder of `gymtrack track` + `gymtrack pose` (+ `gymtrack analyse` for mot)"),
    fmt: str = typer.Option(..., "--format", "-f", help="trc (OpenSim markers) | c3d | mot (OpenSim angles) | bvh (animation rig)"),
    all_tracks: bool = typer.Option(False, "--all-tracks", help="one file per track, not only the target's"),
    output: Optional[Path] = typer.Option(None, "--output", "-o", help="file to write, or a folder (default: OUT/export/target.FORMAT; track<id> with --all-tracks)"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace existing files"),
    fps: Optional[float] = typer.Option(None, "--fps", help="frame rate (default: the routine's scene.yaml)"),
    routine: Optional[Path] = typer.Option(None, "--routine", help="routine folder whose scene.yaml gives the frame rate"),
) -> None:
    """Write the target's 3D skeleton (every track's with --all-tracks) as TRC, C3D or BVH, or its joint angles as MOT."""
    from gymtrack.export import export_output

    with interrupts():
        res = export_output(out, fmt, all_tracks=all_tracks, dest=output, overwrite=overwrite, fps=fps, routine=routine)
    for line in res.lines:
        console.print(line, highlight=False, soft_wrap=True)
    c = res.counts
    if c["fk_frames_steady"] + c["fk_frames_other"]:
        parts = []
        if c["fk_frames_steady"]:
            parts.append(f"in the {c['fk_frames_steady']} frames whose bone lengths are within 0.25 mm of the rig's, "
                         f"its forward kinematics is within {c['fk_steady_max_m'] * 1000:.2f} mm of the exported joints")
        if c["fk_frames_other"]:
            parts.append(f"in the {c['fk_frames_other']} frames whose bones differ more, a joint is {c['fk_other_median_m'] * 1000:.1f} mm "
                         f"off (median), {c['fk_max_m'] * 1000:.1f} mm at most (the rig keeps the median bone lengths)")
        console.print("BVH rig: " + "; ".join(parts), highlight=False, soft_wrap=True)
    for p in res.files:
        console.print(f"wrote [bold]{p}[/]", soft_wrap=True)
    if not res.files:
        console.print("[yellow]nothing written:[/] no frame has every joint (see above)")
