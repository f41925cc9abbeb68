"""``gymtrack batch``: many routines through track, pose, analyse and eval, on Dask (:mod:`gymtrack.batch`).

Paper: Sections III-IV over a folder of routines (the paper's 140 performances).
``gymtrack batch <folder-or-list> --out <out> [--steps track,pose,analyse,eval] [--mode cascade]
[--without INGREDIENT] [--adding INGREDIENT]
[--workers N | --scheduler tcp://host:8786] [--force]`` writes ``<out>/<routine>/`` for every
routine, ``<out>/batch.csv`` and ``<out>/batch.json``; complete routines are skipped, failed ones
reported, and a second run redoes only what is not complete. Exit status 1 when a routine
failed, 130 on Ctrl-C (the files then hold what finished).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from gymtrack.cli import app
from gymtrack.cli.options import adding_option, mode_option, recipe_of, without_option

console = Console()


@app.command()
def batch(
    source: Path = typer.Argument(..., help="folder of routines (every sub-folder with a scene.yaml) or a list file, one routine folder a line"),
    out: Path = typer.Option(..., "--out", "-o", help="output folder: <routine>/ per routine, batch.csv, batch.json"),
    steps: str = typer.Option("track,pose,eval", "--steps", help="comma-separated: track, pose, analyse, eval"),
    mode: str = mode_option(),
    without: Optional[list[str]] = without_option(),
    adding: Optional[list[str]] = adding_option(),
    workers: int = typer.Option(0, "--workers", "-w", help="LocalCluster worker processes (0: one per CPU); ignored with --scheduler"),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="address of a running Dask scheduler, e.g. tcp://host:8786"),
    force: bool = typer.Option(False, "--force", help="redo routines whose outputs are already complete (and replace routine folders under OUT that are not gymtrack outputs)"),
    mot: bool = typer.Option(True, "--mot/--no-mot", help="eval: also score all people (MOTA, IDF1)"),
    calibration: Optional[Path] = typer.Option(None, "--calibration", help="one calibration file for every routine "
                                               "(default: each routine's own, or its Pose2Sim project's)"),
    keypoints: Optional[str] = typer.Option(None, "--keypoints", "-k", help="the 2D poses' folder inside each routine "
                                            "(default: keypoints/, else Pose2Sim's pose/)"),
) -> None:
    """Run many routines on a Dask cluster (local processes by default); resumable, failures isolated."""
    from gymtrack.batch import find_routines, parse_steps, run_batch

    step_list = parse_steps(steps)
    mode = recipe_of(mode, without, adding).name  # a derived recipe travels to the workers by its name
    n = len(find_routines(source))
    where = scheduler or f"a LocalCluster of {workers or 'one per CPU'} processes"
    console.print(f"{n} routines, steps {', '.join(step_list)} (mode {mode}), on {where}")
    with Progress(TextColumn("[bold]batch"), BarColumn(), MofNCompleteColumn(), TextColumn("routines"),
                  TextColumn("[green]{task.fields[ok]} ok[/] [red]{task.fields[failed]} failed[/] {task.fields[skipped]} skipped"),
                  TextColumn("{task.fields[fps]} frames/s"), TimeElapsedColumn(), console=console) as bar:
        task = bar.add_task("", total=n, ok=0, failed=0, skipped=0, fps="-")

        def on_row(row: dict, res) -> None:
            fps = f"{res.frames_done / res.seconds:.0f}" if res.seconds > 0 else "-"
            bar.update(task, completed=len(res.rows), ok=res.count("ok"), failed=res.count("failed"),
                       skipped=res.count("skipped"), fps=fps)
            if row["status"] == "failed":
                bar.console.print(f"[red]failed[/] {row['routine']}: {row['error']}", highlight=False)

        try:
            res = run_batch(source, out, step_list, mode, workers or None, scheduler, force, mot, on_row=on_row,
                            log=lambda s: bar.console.print(s, highlight=False),
                            routine_options={"calibration": calibration and Path(calibration).absolute(),
                                             "keypoints": keypoints})
        except KeyboardInterrupt:
            bar.stop()
            console.print(f"[yellow]interrupted[/]: finished routines kept; {out / 'batch.csv'} lists them; "
                          "run the same command again to do the rest")
            sys.exit(130)
    done = res.count("ok") + res.count("failed")
    rate = f", {done / (res.seconds / 60):.1f} routines/min, {res.frames_done / res.seconds:.0f} frames/s" if res.seconds > 0 and done else ""
    console.print(f"{res.count('ok')} ok, {res.count('failed')} failed, {res.count('skipped')} skipped "
                  f"in {res.seconds:.1f} s{rate}")
    console.print(f"wrote [bold]{res.files['csv']}[/] and [bold]{res.files['json']}[/]")
    if res.count("failed"):
        raise typer.Exit(1)
