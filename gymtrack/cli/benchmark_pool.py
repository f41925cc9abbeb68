"""``gymtrack benchmark-pool OUT1 OUT2 ... --out POOLED``: benchmark outputs already run, pooled.

Paper: Section IV (Tables 3 and 5) and Section III-D's judging measurements, with the spread of
each figure over suites (:mod:`gymtrack.eval.pooled`). Reads each output's ``rows.csv`` (one
suite, or the suites of its ``s<seed>/`` prefixes when it was run with ``--seeds``), and writes
the headline ratios and the judging targets pooled over all of them, each with a percentile
bootstrap interval over routines: ``report.md``, ``pooled_ratios.csv``, ``pooled_judging.csv``
and ``results.json`` under ``--out`` (:mod:`gymtrack.eval.pool_outputs`). Nothing is rerun.
"""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from gymtrack.cli import app

console = Console()


@app.command("benchmark-pool")
def benchmark_pool(
    outputs: list[Path] = typer.Argument(..., help="benchmark output folders (each with the rows.csv of gymtrack benchmark)"),
    out: Path = typer.Option(..., "--out", "-o", help="folder for the pooled report.md, CSVs and results.json (not one of the outputs)"),
    n_boot: int = typer.Option(2000, "--n-boot", min=1, help="bootstrap draws of the tracking ratios"),
    n_boot_judging: int = typer.Option(1000, "--n-boot-judging", min=1, help="bootstrap draws of the judging targets (~0.1 s each)"),
    level: float = typer.Option(0.9, "--level", min=0.01, max=0.999, help="interval level (0.9: the 5th to 95th percentiles)"),
    seed: int = typer.Option(0, "--seed", help="seed of the bootstrap's random draws"),
) -> None:
    """Pool benchmark outputs already run: headline ratios and judging targets with bootstrap intervals."""
    from gymtrack.eval.pool_outputs import pool_outputs, pooled_results, write_pooled

    rows = pool_outputs(outputs, out)
    suites = len({r["suite"] for r in rows})
    console.print(f"{len(outputs)} outputs, {suites} suites, {len(rows)} rows: bootstrap ({n_boot} draws for the ratios, "
                  f"{n_boot_judging} for the judging targets) ...")
    sections, records = pooled_results(rows, n_boot_judging, n_boot, level, seed)
    files = write_pooled(out, outputs, sections, records)
    console.print("\n".join(s for s in sections if s), highlight=False, soft_wrap=True)
    console.print(f"report: [bold]{files['report']}[/]")
