"""``gymtrack eval <routine> <out>``: score an output folder against the routine's ground truth.

Paper: Section IV-A. The target gymnast's ID switches, AED, FR (Fig. 5) and coverage over its
performing frames, the all-people MOTA and IDF1, and the target's pose metrics when both
``<out>/poses_3d.csv`` and ``<routine>/gt/keypoints_3d.csv`` exist -- the numbers the benchmark
computes, from the files of any run (:func:`gymtrack.eval.score.score_output`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console
from rich.table import Table

from gymtrack.cli import app
from gymtrack.cli.options import calibration_format_option, calibration_option, keypoints_option, units_option
from gymtrack.cli.locking import force_routine_option, hold_for_command, wait_option

console = Console()


def _f(v: float, fmt: str) -> str:
    return "n/a" if v is None or (isinstance(v, float) and math.isnan(v)) else fmt.format(v)


def _no_nan(v):
    """NaN (a metric with nothing to average) as JSON null: NaN is not JSON."""
    if isinstance(v, dict):
        return {k: _no_nan(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_no_nan(x) for x in v]
    return None if isinstance(v, float) and math.isnan(v) else v


def score_table(s: dict) -> Table:
    """The scores of :func:`gymtrack.eval.score.score_output` as one table."""
    t = Table(title=f"{s['out']} vs {s['routine']}/gt", title_justify="left")
    t.add_column("metric")
    t.add_column("value", justify="right")
    t.add_column("detail")
    g = s["target"]
    t.add_row("target ID switches", str(g["id_switches"]),
              f"{g['id_switches_track']} track id changes, {g['id_switches_person']} person changes")
    t.add_row("target AED", _f(g["aed_m"], "{:.3f} m"), f"over {g['aed_frames']} frames")
    t.add_row("target FR", _f(g["fr"], "{:.1%}"),
              f"{g['fr_failures']} / {g['fr_evaluated']} boxes: {g['fr_missing']} missing, "
              f"{g['fr_outside']} outside, {g['fr_too_small']} too small")
    t.add_row("target coverage", _f(g["coverage"], "{:.1%}"), f"{g['covered_frames']} / {g['performing_frames']} performing frames")
    p = s["people"]
    if p is not None:
        t.add_row("all people MOTA", _f(p["mota"], "{:.3f}"),
                  f"{p['misses']} misses, {p['false_positives']} false positives, {p['id_switches']} switches, "
                  f"{p['objects']} person-frames")
        t.add_row("all people IDF1", _f(p["idf1"], "{:.3f}"), "")
    q = s["poses"]
    if q is not None:
        t.add_row("target MPJPE", _f(q["mpjpe_mm"], "{:.0f} mm"), f"PA-MPJPE {_f(q['pa_mpjpe_mm'], '{:.0f} mm')}")
        t.add_row("target PCK@150 mm", _f(q["pck"], "{:.1%}"), f"pose in {_f(q['pose_share'], '{:.1%}')} of performing frames")
    j = s.get("judging")
    if j is not None:
        _judging_rows(t, j)
    return t


def _judging_rows(t: Table, j: dict) -> None:
    """The judging scores (:func:`gymtrack.eval.score.judging_scores`) as rows of the table."""
    e = j["elements"]
    for kind, k in e["kinds"].items():
        t.add_row(f"{kind}s found", f"{k['matched']} / {k['gt']}",
                  f"recall {_f(k['recall'], '{:.0%}')}, precision {_f(k['precision'], '{:.0%}')} ({k['measured']} measured"
                  + (f"; {e['not_analysed'][kind]} true outside the analysed frames)" if e["not_analysed"].get(kind) else ")"))
    fl = e["flight"]
    for name, key in (("exact saltos", "saltos_exact"), ("exact twists", "twists_exact"), ("shape right", "shape")):
        t.add_row(name, _f(fl[key]["share"], "{:.0%}"), f"over {fl[key]['n']} matched flights")
    t.add_row("flight-time error", _f(fl["time_err_frames"]["median"], "{:.1f} frames"),
              f"median of starts and ends (start {_f(fl['start_err_frames']['median'], '{:.1f}')}, end "
              f"{_f(fl['end_err_frames']['median'], '{:.1f}')})")
    t.add_row("apex error", _f(fl["apex_err_m"]["median"], "{:.3f} m"), f"median over {fl['apex_err_m']['n']} flights")
    h = e["hold"]
    t.add_row("hold errors", _f(h["duration_err_s"]["median"], "{:.2f} s"),
              f"median duration error; deviation {_f(h['deviation_err_deg']['median'], '{:.1f} deg')}")
    t.add_row("landings stuck right", _f(e["landing"]["stuck"]["share"], "{:.0%}"), f"over {e['landing']['stuck']['n']} matched")
    t.add_row("turn degrees right", _f(e["turn"]["degrees"]["share"], "{:.0%}"), f"over {e['turn']['degrees']['n']} matched")
    for col, st in (j.get("angles") or {}).items():
        unit = "m" if col == "com" else "deg"
        t.add_row(f"{col} error", _f(st["median"], "{:.3f} m" if unit == "m" else "{:.1f} deg"),
                  f"median; mean {_f(st['mean'], '{:.3f}' if unit == 'm' else '{:.1f}')} over {st['n']} frames")


def explain_table_of(why: dict) -> Table:
    """The failure breakdown of one output (:func:`gymtrack.eval.explain.explain_failures`) as a table."""
    from gymtrack.eval.explain import CAUSES

    t = Table(title=f"target FR failures by cause ({why['failures']} of {why['evaluated']} boxes)", title_justify="left")
    for col in ("cause", "boxes", "share of evaluated"):
        t.add_column(col, justify="left" if col == "cause" else "right")
    for c in CAUSES:
        t.add_row(c.replace("_", " "), str(why[c]), _f(why[c] / why["evaluated"] if why["evaluated"] else float("nan"), "{:.1%}"))
    return t


@app.command("eval")
def eval_cmd(
    ctx: typer.Context,
    routine: Path = typer.Argument(..., help="routine folder with gt/ (persons_3d.csv, boxes_2d/)"),
    out: Path = typer.Argument(..., help="output folder written by `gymtrack track --out`"),
    as_json: bool = typer.Option(False, "--json", help="print the scores as JSON instead of a table"),
    mot: bool = typer.Option(True, "--mot/--no-mot", help="also score all people (MOTA, IDF1; the slowest part)"),
    calibration_format: Optional[str] = calibration_format_option(),
    units: Optional[str] = units_option(),
    calibration: Optional[Path] = calibration_option(),
    keypoints: Optional[Path] = keypoints_option(),
    force: bool = force_routine_option(),
    wait: float = wait_option(),
    explain: bool = typer.Option(False, "--explain", help="also give every failed target box (FR) its cause: no detection "
                                 "in any view, box wrong though the centre is right, never clustered, taken by a phantom "
                                 "cluster, a wrong identification, a linking break"),
) -> None:
    """Score an output folder against the routine's ground truth (target and all people)."""
    from gymtrack.eval.score import score_output

    opts = {} if units is None else {"units": units}
    opts.update({k: v for k, v in (("calibration", calibration), ("keypoints", keypoints)) if v is not None})
    hold_for_command(ctx, out, "eval", wait, routine, force, shared=True)  # no writer replaces OUT while it is scored
    s = score_output(routine, out, mot=mot, calibration_format=calibration_format, explain=explain, **opts)
    if as_json:
        s = {k: v for k, v in s.items() if k != "row"}
        typer.echo(json.dumps(_no_nan(s), indent=2))
        return
    console.print(score_table(s))
    if explain:
        console.print(explain_table_of(s["explain"]))
    for note in s["notes"]:
        console.print(f"note: {note}", highlight=False)
