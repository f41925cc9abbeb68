"""``gymtrack benchmark``: every method on every routine of a suite; the paper's Tables 3, 5, 6, Fig. 6.

``gymtrack benchmark --suite <dir> --out <dir> [--jobs N] [--methods cascade,triangulation,...]``
runs the methods of :mod:`gymtrack.eval.benchmark` on every routine of the suite (routines in
parallel: the batch machinery's Dask workers, ``--scheduler ADDRESS`` for a cluster), prints the summary tables with rich and writes ``report.md``, CSV, JSON
and the Fig. 6 plots under ``--out``, plus the WILDTRACK section when the data is there.

Without ``--suite`` it first simulates the default suite into ``<out>/suite`` -- the same
routines as ``gymtrack simulate-suite --per-apparatus 4 --seconds 25``: 7 apparatus x 4
performances x n_cam 2, 3, 4 = 84 routine folders, apparatus simulated in parallel -- unless
``<out>/suite/suite.json`` already exists, and benchmarks that. ``--per-apparatus 20 --seconds 0``
gives the paper's 140 performances (each seen with n_cam = 2, 3 and 4) at the simulator's lengths.

``--ablation``: instead, cascade+'s ablation (:mod:`gymtrack.eval.ablation`): each ingredient beyond
the paper switched off alone in cascade+ and added alone to the cascade, on the suite and on
WILDTRACK, written as ``ablation.md`` and ``ablation.json`` under ``--out``.

``--check``: exit status 1 when a target of :func:`gymtrack.eval.aggregate.claims` fails or a
run fails (for CI); without it the status is 0 whatever the results.
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path
from typing import Callable, Optional

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from gymtrack.cli import app

console = Console()


DEFAULT_METHODS = "cascade,cascade+,triangulation,plane,mvpt,oracle"


def _methods(given: Optional[list[str]]) -> list[str]:
    """The methods of ``--methods``, comma-separated, repeated or both (``-m cascade+ -m oracle``:
    every one counts); the default set when not given."""
    from gymtrack.errors import InputError
    from gymtrack.eval.aggregate import METHODS

    text = ",".join(given) if given else DEFAULT_METHODS
    out = list(dict.fromkeys(m.strip() for m in text.replace(" ", ",").split(",") if m.strip()))
    bad = [m for m in out if m not in METHODS]
    if bad or not out:
        raise InputError(f"unknown method {bad[0] if bad else text!r}; choose from {', '.join(METHODS)}", field="--methods")
    return out


def _seeds(text: Optional[str], suite: Optional[Path]) -> list[int]:
    """``--seeds`` as integers (empty without it); an InputError naming the option when it is not
    a list of integers or comes with ``--suite``."""
    from gymtrack.errors import InputError

    if text is None:
        return []
    try:
        out = [int(x) for x in text.replace(" ", ",").split(",") if x.strip()]
    except ValueError:
        raise InputError(f"expected comma-separated integers, got {text!r}", field="--seeds") from None
    if not out or len(set(out)) != len(out):
        raise InputError(f"expected distinct seeds, got {text!r}", field="--seeds")
    if suite is not None:
        raise InputError("--seeds simulates its own suites (OUT/suite-s<seed>); give --suite or --seeds, not both", field="--seeds")
    return out


def print_summary(rows: list[dict]) -> list:
    """Table 5 and the targets, with rich; returns the claims (:func:`gymtrack.eval.aggregate.claims`)."""
    from gymtrack.eval.aggregate import claims, table5
    from gymtrack.eval.render import fmt

    t5 = table5(rows)
    if t5:
        ns = [k[3:] for k in t5[0] if k.startswith("fr_")]
        tab = Table(title="Table 5: average FR and speed", title_justify="left")
        tab.add_column("method")
        for n in ns:
            tab.add_column(f"FR n_cam={n}", justify="right")
        tab.add_column("frames/s", justify="right")
        for r in t5:
            tab.add_row(r["method"], *[fmt(r[f"fr_{n}"], "pct") for n in ns], fmt(r["fps"], "fps"))
        console.print(tab)
    found = claims(rows)
    console.print(claims_table("Targets", found, lambda v: fmt(v, "ratio") if abs(v) < 100 else fmt(v, "fps")))
    return found


def claims_table(title: str, found: list, value: Callable[[float], str]) -> Table:
    """Claims (:class:`gymtrack.eval.aggregate.Claim`) as a rich table, PASS green and FAIL red."""
    tab = Table(title=title, title_justify="left")
    for col in ("target", "value", "result", "detail"):
        tab.add_column(col)
    colour = {"PASS": "green", "FAIL": "red"}
    for c in found:
        tab.add_row(c.name, value(c.value), f"[{colour.get(c.status, 'yellow')}]{c.status}[/]", c.detail)
    return tab


def print_pose_claims(rows: list[dict]) -> list:
    """The benchmark's pose targets (Fig. 7, lifting ablation) as a table; returns the claims."""
    from gymtrack.eval.pose_bench import pose_claims

    found = pose_claims(rows)
    console.print(claims_table("Pose targets (MPJPE averaged over apparatus)", found,
                               lambda v: "-" if not np.isfinite(v) else f"{v:.2f}"))
    return found


def print_judging(rows: list[dict]) -> list:
    """Judging measurements: pooled per n_cam and method, the definitions check, the targets; returns the claims."""
    from gymtrack.eval.judging import HEADER, judging_line, judging_claims, judging_tables

    t = judging_tables(rows)
    if not t["overall"] and not t["truth"]:
        return []
    tab = Table(title="Judging measurements (pooled over apparatus; per apparatus in the report)", title_justify="left")
    keep = range(8)  # flights, counts, shape, time, apex, knee, hip: the rest is in the report
    tab.add_column("n")
    tab.add_column("skeleton", no_wrap=True, min_width=13)
    for col in [HEADER[i] for i in keep]:
        tab.add_column(col)
    for (n, m), s in sorted(t["overall"].items()):
        line = judging_line(s)
        tab.add_row(str(n), m, *[line[i] for i in keep])
    if "all" in t["truth"]:
        line = judging_line(t["truth"]["all"])
        tab.add_row("-", "true skeleton", *[line[i] for i in keep])
    console.print(tab)
    for e in t["errors"]:
        console.print(f"[red]analysis failed:[/] {e}", highlight=False)
    found = judging_claims(rows)
    console.print(claims_table("Judging targets (cascade+, pooled over apparatus)", found,
                               lambda v: "-" if not np.isfinite(v) else f"{v:.3g}"))
    return found


@app.command()
def benchmark(
    out: Path = typer.Option(..., "--out", "-o", help="output folder: report.md, CSV, JSON, plots"),
    suite: Optional[Path] = typer.Option(None, "--suite", "-s", help="suite folder (simulate-suite output); absent: simulate the default suite into OUT/suite"),
    jobs: int = typer.Option(0, "--jobs", "-j", help="parallel routines: LocalCluster worker processes (0: one per CPU; 1: in this process)"),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="run the routines on a running Dask scheduler, e.g. tcp://host:8786 (as gymtrack batch)"),
    methods: Optional[list[str]] = typer.Option(None, "--methods", "-m",
                                                help="comma-separated or repeated: cascade, cascade+, triangulation, plane, "
                                                     "mvpt, oracle (default: all six)"),
    # 4 = gymtrack.eval.benchmark.DEFAULT_PER_APPARATUS (kept literal: importing gymtrack.eval here slows every command)
    per_apparatus: int = typer.Option(4, "--per-apparatus", help="routines per apparatus (each seen with n_cam = 2, 3, 4) when simulating the default suite; 20 = the paper's 140 routines"),
    seconds: float = typer.Option(25.0, "--seconds", help="routine length in seconds when simulating the default suite (0: the simulator's defaults, 60 s and 20 s for vault)"),
    wildtrack: Optional[Path] = typer.Option(None, "--wildtrack", help="WILDTRACK folder for the real-data section (skipped with a note if absent; default: gymtrack.eval.config's, ../shared/data/wildtrack)"),
    no_wildtrack: bool = typer.Option(False, "--no-wildtrack", help="skip the real-data section"),
    no_mot: bool = typer.Option(False, "--no-mot", help="skip the all-people MOT metrics (faster)"),
    no_dropout: bool = typer.Option(False, "--no-dropout", help="skip the camera drop-out section (gymtrack.eval.dropout)"),
    faults: bool = typer.Option(False, "--faults", help="also the venue-faults section (gymtrack.eval.fault_bench): "
                                "desync, knock, dropped frames, silent camera; clean / with the fault / corrected"),
    no_pose: bool = typer.Option(False, "--no-pose", help="skip the target's 3D pose (Fig. 7 table, lifting ablation)"),
    mvor: Optional[Path] = typer.Option(None, "--mvor", help="MVOR folder for the real-keypoints pose section (default: $GYMTRACK_MVOR or shared/data/mvor above the project; skipped with a note if absent)"),
    seeds: Optional[str] = typer.Option(None, "--seeds", help="comma-separated base seeds, e.g. 0,1,2: one default suite "
                                        "per seed (OUT/suite-s<seed>, simulated unless there), pooled; the headline figures and judging targets "
                                        "get 90 % bootstrap intervals over routines"),
    n_cams: Optional[str] = typer.Option(None, "--n-cams", help="comma-separated: only the suite's routines with these "
                                         "n_cam (e.g. 2)"),
    check: bool = typer.Option(False, "--check", help="exit with status 1 when a target (claim) fails or a run fails"),
    ablation: bool = typer.Option(False, "--ablation", help="instead of the methods: cascade+ with each ingredient beyond "
                                  "the paper switched off alone, and the cascade with each added alone (target FR / AED, "
                                  "all people's MOTA / IDF1 per n_cam, WILDTRACK): OUT/ablation.md"),
) -> None:
    """Benchmark the tracker's modes, the MvPT-like baseline and the GT-association oracle (paper Tables 3, 5, 6)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from gymtrack.eval.benchmark import read_suite, run_suite, simulate_default_suite, write_benchmark

    method_list = _methods(methods)
    n_jobs = jobs if jobs > 0 else (os.cpu_count() or 1)
    seed_list = _seeds(seeds, suite)
    if seed_list:
        from gymtrack.eval.benchmark import seeded_suites

        console.print(f"--seeds: one suite per seed {', '.join(map(str, seed_list))} ({per_apparatus} routines per apparatus, "
                      f"each with n_cam = 2, 3, 4) in [bold]{out}/suite-s<seed>[/]")
        specs = seeded_suites(out, seed_list, per_apparatus, seconds or None, jobs=n_jobs,
                              progress=lambda k, n, a: console.print(f"  simulated {a} ({k}/{n})"))
        suite = out
    elif suite is None:
        suite = out / "suite"
        if not (suite / "suite.json").is_file():
            console.print(f"no --suite: simulating the default suite ({per_apparatus} routines per apparatus, each with "
                          f"n_cam = 2, 3, 4) into [bold]{suite}[/]")
            simulate_default_suite(suite, per_apparatus, seconds or None, jobs=n_jobs,
                                   progress=lambda k, n, a: console.print(f"  simulated {a} ({k}/{n})"))
        else:
            console.print(f"no --suite: using the suite already simulated in [bold]{suite}[/]")
    if not seed_list:
        specs = read_suite(suite)
    if n_cams:
        from gymtrack.errors import InputError

        try:
            keep = {int(x) for x in n_cams.split(",") if x.strip()}
        except ValueError:
            raise InputError(f"expected comma-separated integers, got {n_cams!r}", field="--n-cams") from None
        specs = [s for s in specs if s.n_cam in keep]
        if not specs:
            raise InputError(f"no routine of the suite has n_cam in {sorted(keep)}", field="--n-cams")
    runner = None
    if not scheduler and n_jobs > 1 and importlib.util.find_spec("distributed") is None:
        console.print("[yellow]note:[/] Dask is not installed (the 'batch' extra: pip install 'gymtrack[batch]'): "
                      "running the routines one after another in this process")
        n_jobs = 1
    if scheduler or n_jobs > 1:
        from gymtrack.batch.engine import dask_runner

        runner = dask_runner(n_jobs, scheduler, log=lambda s: console.print("  " + s, highlight=False))
    where = f"on the Dask scheduler {scheduler}" if scheduler else f"{n_jobs} parallel jobs"
    if ablation:
        return _ablation(specs, out, n_jobs, runner, where, not no_wildtrack, wildtrack)
    console.print(f"{len(specs)} routines x {len(method_list)} methods, {where}")
    with Progress(TextColumn("[bold]benchmark"), BarColumn(), MofNCompleteColumn(), TextColumn("routines"),
                  TimeElapsedColumn(), TextColumn("{task.description}"), console=console, transient=True) as bar:
        task = bar.add_task("", total=len(specs))

        def progress(done: int, total: int, name: str) -> None:
            bar.update(task, completed=done, description=name)

        run = run_suite(specs, method_list, jobs=n_jobs, mot=not no_mot, progress=progress, pose=not no_pose, runner=runner)
    drop = None
    if not no_dropout:
        from gymtrack.eval.dropout import dropout_markdown, run_dropout

        console.print("camera drop-out section ...")
        rows = run_dropout(specs)
        drop = (dropout_markdown(rows), rows)
    if faults:
        from gymtrack.eval.fault_bench import faults_markdown, run_faults

        console.print("venue faults section ...")
        rows = run_faults(specs)
        md = faults_markdown(rows)
        drop = (md, rows) if drop is None else (drop[0] + "\n\n" + md, drop[1])
        (out / "faults.json").parent.mkdir(parents=True, exist_ok=True)
        (out / "faults.json").write_text(__import__("json").dumps(rows, indent=1, default=str))
    wt = None
    if not no_wildtrack:
        from gymtrack.eval.config import DEFAULT_CONFIG
        from gymtrack.eval.wildtrack import run_wildtrack

        wildtrack = DEFAULT_CONFIG.wildtrack if wildtrack is None else wildtrack
        console.print("WILDTRACK real-data section ...")
        wt = run_wildtrack(wildtrack, log=lambda s: console.print("  " + s))
        if not wt.get("available"):
            console.print(f"[yellow]{wt['note']}[/]")
    mv = None
    if not no_pose:
        from gymtrack.eval.pose_mvor import run_mvor_pose

        console.print("MVOR real-keypoints pose section ...")
        mv = run_mvor_pose(mvor, log=lambda s: console.print("  " + s))
        if not mv.get("available"):
            console.print(f"[yellow]{mv['note']}[/]")
    from gymtrack.eval.explain import explain_markdown
    from gymtrack.eval.pool_outputs import pooled_results

    pooled_mds, pooled_recs = pooled_results(run.rows)  # the judging targets' part is empty without judged rows (--no-pose)
    explain_md = explain_markdown(run.rows)
    meta = {"suite": str(suite) + (f" (seeds {', '.join(map(str, seed_list))})" if seed_list else ""), "methods": ", ".join(method_list)}
    files = write_benchmark(run, out, meta=meta, wildtrack=wt, mvor=mv, dropout=drop, sections=[*pooled_mds, explain_md],
                            results=pooled_recs)
    found = print_summary(run.rows)
    console.print("\n".join(pooled_mds), highlight=False)
    if "cascade+" in method_list:
        from gymtrack.eval.plus_claims import plus_claims
        from gymtrack.eval.render import fmt

        plus = plus_claims(run.rows, wt)
        console.print(claims_table("Targets beyond the paper (cascade+)", plus,
                                   lambda v: fmt(v, "ratio") if abs(v) < 100 or not np.isfinite(v) else fmt(v, "fps")))
        found = found + plus
    if not no_pose:
        found = found + print_pose_claims(run.rows) + print_judging(run.rows)
    failed = [r for r in run.rows if r.get("error")]
    if failed:
        console.print(f"[red]{len(failed)} runs failed[/] (listed in the report), e.g. {failed[0]['routine']} / "
                      f"{failed[0]['method']}: {failed[0]['error']}")
    console.print(f"report: [bold]{files['report']}[/] ({run.seconds:.0f} s)")
    if check:
        bad = [c.name for c in found if c.status == "FAIL"]
        if bad or failed:
            what = [f"{len(bad)} target(s) failed ({'; '.join(bad)})"] if bad else []
            what += [f"{len(failed)} run(s) failed"] if failed else []
            console.print(f"[red]--check failed:[/] {', '.join(what)}", highlight=False)
            raise typer.Exit(1)
        console.print(f"[green]--check passed:[/] {sum(c.status == 'PASS' for c in found)} targets met "
                      f"({sum(c.status == 'n/a' for c in found)} n/a)", highlight=False)


def _ablation(specs, out: Path, n_jobs: int, runner, where: str, with_wildtrack: bool, wildtrack: Optional[Path]) -> None:
    """``--ablation``: the recipes of :func:`gymtrack.eval.ablation.ablation_recipes` on the suite
    (and on WILDTRACK, at ``wildtrack`` or the configured place), ``ablation.md`` / ``ablation.json`` under ``out``."""
    import json

    from gymtrack.eval.ablation import ablation_markdown, ablation_recipes, ablation_table
    from gymtrack.eval.benchmark import run_suite

    recipes = ablation_recipes()
    console.print(f"ablation: {len(specs)} routines x {len(recipes)} recipes, {where}")
    run = run_suite(specs, recipes, jobs=n_jobs, mot=True, pose=False, runner=runner,
                    progress=lambda k, n, name: console.print(f"  {name} ({k}/{n})", highlight=False))
    wt = None
    if with_wildtrack:
        from gymtrack.eval.config import DEFAULT_CONFIG
        from gymtrack.eval.wildtrack import WildtrackSetup, run_wildtrack

        console.print("WILDTRACK ...")
        wt = run_wildtrack(DEFAULT_CONFIG.wildtrack if wildtrack is None else wildtrack, WildtrackSetup(modes=tuple(recipes)))
        if not wt.get("available"):
            console.print(f"[yellow]{wt['note']}[/]")
    table = ablation_table(run.rows, recipes, wt)
    failed = [r for r in run.rows if r.get("error")]
    note = (lambda: f"{len(specs)} routines, {len(failed)} failed runs.")
    out.mkdir(parents=True, exist_ok=True)
    md = ablation_markdown(table, note)
    (out / "ablation.md").write_text(md)
    (out / "ablation.json").write_text(json.dumps({"table": table, "rows": run.rows}, indent=1, default=str))
    console.print(md, highlight=False)
    if failed:
        console.print(f"[red]{len(failed)} runs failed[/], e.g. {failed[0]['routine']} / {failed[0]['method']}: "
                      f"{failed[0]['error']}")
    console.print(f"ablation: [bold]{out / 'ablation.md'}[/] ({run.seconds:.0f} s)")
