"""``gymtrack analyse <routine> <out>``: what judges measure, from the target's 3D skeleton.

Paper: Section III-D, last paragraph and Fig. 8 -- the 3D pose sequence segmented and measured
against the Code of Points (:mod:`gymtrack.analysis`). Reads ``<out>/poses_3d.csv`` (``gymtrack
pose`` first) and ``<routine>/scene.yaml``; writes ``<out>/analysis/`` (``angles.csv``,
``elements.json``, ``report.html``) atomically into the output folder and prints the elements.
"""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console
from rich.table import Table

from gymtrack.cli import app
from gymtrack.cli.locking import force_routine_option, hold_for_command, wait_option
from gymtrack.cli.report import interrupts

console = Console()


def element_table(analysis) -> Table:
    """The elements, one row each, in frame order."""
    from gymtrack.analysis.folder import element_rows

    t = Table(title=f"Elements ({len(analysis.elements)}), track {analysis.track_id}, {analysis.apparatus or 'no apparatus'}",
              title_justify="left")
    for col in ("element", "frames", "time", "measured"):
        t.add_column(col, justify="right" if col in ("frames", "time") else "left")
    for row in element_rows(analysis):
        t.add_row(*row)
    return t


def missing_lines(analysis) -> list[str]:
    """What could not be computed and why, and what still was."""
    if not analysis.missing:
        return []
    from gymtrack.analysis.joints import NEEDS

    lines = [f"not computed: {k}: {v}" for k, v in analysis.missing.items()]
    kept = [m for m in NEEDS if m not in analysis.missing]
    kept += [k for k in ("flight", "landing", "hold", "circle", "turn") if k not in analysis.missing]
    lines.append(f"still computed: {', '.join(kept) or 'nothing'}")
    return lines


@app.command()
def analyse(
    ctx: typer.Context,
    routine: Path = typer.Argument(..., help="routine folder (its scene.yaml: apparatus, plane, fps)"),
    out: Path = typer.Argument(..., help="the output folder of `gymtrack track` + `gymtrack pose`; analysis/ is written into it"),
    track: int = typer.Option(None, "--track", help="analyse this track of poses_3d.csv instead of the target"),
    samples: int = typer.Option(32, "--samples", min=0, help="Monte Carlo samples for the uncertainties (0: none)"),
    no_report: bool = typer.Option(False, "--no-report", help="skip the routine sheet (report.html)"),
    force: bool = force_routine_option(),
    wait: float = wait_option(),
) -> None:
    """Measure flights (saltos, twists, shape), landings, holds, circles and turns; write OUT/analysis/."""
    from gymtrack.analysis import analyse as run_analysis
    from gymtrack.analysis.folder import target_poses, write_analysis
    from gymtrack.formats.atomic import atomic_update
    from gymtrack.formats.poses3d import read_poses_3d
    from gymtrack.formats.scene import load_scene

    hold_for_command(ctx, out, "analyse", wait, routine, force)  # from the first read of OUT to the last write
    scene = load_scene(Path(routine) / "scene.yaml")
    with console.status("analysing the skeleton"):
        if track is None:
            a = run_analysis(target_poses(Path(out)), scene, samples=samples)
        else:
            a = run_analysis(read_poses_3d(Path(out) / "poses_3d.csv"), scene, track_id=track, samples=samples)
    notes: list[str] = []
    with interrupts(), atomic_update(out, "analyse", {"routine": str(routine), "track": track, "samples": samples}) as staging:
        notes = write_analysis(a, staging / "analysis", report=not no_report)
    console.print(element_table(a))
    for line in missing_lines(a) + notes:
        console.print(line, highlight=False)
    s = a.summary
    console.print(f"{s['rows']} poses, {s['flights']} flights, {s['holds']} holds, {s['circles']} circles, {s['turns']} turns"
                  + (f"; {s['rows_without_joints']} rows without joints left out" if s["rows_without_joints"] else "")
                  + (f"; {s['airborne_runs_not_ballistic']} runs off every surface that do not fall freely (not flights)"
                     if s["airborne_runs_not_ballistic"] else "")
                  + (f"; {s['flight_rows_settled']} rows next to flights read airborne (a joint within 0.10 m of its surface "
                     "still moving to or from it, the centre of mass on the flight's parabola)" if s.get("flight_rows_settled") else ""),
                  highlight=False)
    console.print(f"wrote [bold]{Path(out) / 'analysis'}[/]")
