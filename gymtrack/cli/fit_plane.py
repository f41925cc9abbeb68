"""``gymtrack fit-plane``: the apparatus plane and the floor fitted from a routine's data (beyond the paper).

Paper: Section III-C's vertical plane (Eq. 7), here estimated (:mod:`gymtrack.tracking.plane_fit`):
a ``triangulation``-mode pass, the target's triangulated centres weighted by their covariance, a
vertical plane (its direction kept from scene.yaml, with a warning why, where the data do not fix it);
the floor from standing people's box bottoms. Prints how far the scene's plane is from the
fitted one; ``--write`` saves a scene.yaml with the fitted plane. ``gymtrack plane-bench`` runs
the wrong-plane experiment of :mod:`gymtrack.eval.plane_bench` on a suite.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console

from gymtrack.cli import app

console = Console()


@app.command("fit-plane")
def fit_plane(
    routine: Path = typer.Argument(..., help="routine folder (scene.yaml, calibration, detections/)"),
    min_views: int = typer.Option(3, "--min-views", help="views a target point needs to count as well triangulated"),
    write: Optional[Path] = typer.Option(None, "--write", help="write scene.yaml with the fitted plane here"),
) -> None:
    """Fit the apparatus plane and the floor from the data; report the scene's plane's offset and angle."""
    from gymtrack.formats.routine import load_routine
    from gymtrack.formats.scene import save_scene
    from gymtrack.tracking.plane_fit import fit_scene_planes, with_plane
    from gymtrack.tracking.offline import track_detections

    r = load_routine(routine)
    extra = track_detections(r.rig, r.scene, r.detections, mode="cascade") if r.scene.planes else None
    fit = fit_scene_planes(track_detections(r.rig, r.scene, r.detections, mode="triangulation"), r.scene, min_views,
                           rig=r.rig, extra=extra)
    console.print_json(json.dumps(fit.to_dict()))
    if fit.plane is None:
        console.print(f"[yellow]too few well-triangulated target points ({fit.n_target}) for a plane[/]")
        raise typer.Exit(1)
    if not fit.plane.determined:
        console.print(f"[yellow]the plane's direction is kept from scene.yaml ({fit.plane.reason}); only its offset was fitted[/]")
    if r.scene.planes:
        console.print(f"scene plane vs fitted: offset {fit.offset:.3f} m, angle {fit.angle:.2f} deg")
    if write is not None:
        save_scene(with_plane(r.scene, fit.plane.plane), write)
        console.print(f"wrote {write}")


@app.command("plane-bench")
def plane_bench(
    suite: Path = typer.Option(..., "--suite", "-s", help="suite folder (simulate-suite output)"),
    shift: float = typer.Option(0.3, "--shift", help="metres the wrong plane is shifted along its normal"),
    turn: float = typer.Option(10.0, "--turn", help="degrees the wrong plane is turned about the vertical"),
    out: Optional[Path] = typer.Option(None, "--out", "-o", help="write the rows as JSON here"),
    markdown: Optional[Path] = typer.Option(None, "--markdown", help="write the per apparatus x n_cam table here"),
    refine_every: int = typer.Option(20, "--refine-every", min=1, help="windows between the online refits (cascade+)"),
    fit_pass: str = typer.Option("both", "--fit-pass", help="first pass(es) the fit reads: triangulation | cascade "
                                 "(with the wrong plane) | both"),
) -> None:
    """The wrong-plane experiment: target AED with the true, shifted/turned, fitted and online-refined planes."""
    import numpy as np

    from gymtrack.eval.benchmark import read_suite
    from gymtrack.errors import InputError
    from gymtrack.eval.plane_bench import FIT_PASSES, plane_experiment, plane_markdown, plane_table
    from gymtrack.formats.ground_truth import load_ground_truth
    from gymtrack.formats.routine import load_routine

    if fit_pass not in FIT_PASSES:  # before any routine is read
        raise InputError(f"--fit-pass must be one of {', '.join(FIT_PASSES)}, got {fit_pass!r}", field="--fit-pass")
    rows = []
    for spec in read_suite(suite):
        r = load_routine(spec.path)
        gt = load_ground_truth(spec.path, r.rig.names, image_size=np.array([c.size for c in r.rig], dtype=np.float64))
        row = {"routine": spec.name, "apparatus": spec.apparatus, "n_cam": spec.n_cam, **plane_experiment(r, gt, shift, turn, refine_every=refine_every,
                                                                                      fit_pass=fit_pass)}
        rows.append(row)
        console.print(f"{spec.name}: AED true {row['aed_true']:.3f} wrong {row['aed_wrong']:.3f} fitted "
                      f"{row['aed_fitted']:.3f} m; fitted plane {row['offset_m']:.3f} m, {row['angle_deg']:.2f} deg off"
                      f"{'' if row['direction_determined'] else ' (direction kept: ' + row['why_not'] + ')'}; cascade+ "
                      f"true {row['aed_true_plus']:.3f} online {row['aed_online']:.3f} m", soft_wrap=True)
    if out is not None:
        out.write_text(json.dumps(rows, indent=1))
    md = plane_markdown(plane_table(rows))
    console.print(md, soft_wrap=True)
    if markdown is not None:
        markdown.write_text(md)
