"""``gymtrack sync <routine> [--write]``: each camera's frame offset, estimated from the boxes.

Beyond the paper (which assumes synchronised cameras): :mod:`gymtrack.tracking.sync` searches
every camera's offset against the first camera for the one that makes the views' boxes agree
(Eq. 1). Prints each offset (whole frames, the sub-frame estimate) with a confidence, warns where
the data cannot decide, and with ``--write`` stores the offsets in the routine's scene.yaml
(``frame_offsets``), which every command then applies when it reads the detections and keypoints.
Offsets already in scene.yaml are applied first; the printed offsets are the new totals.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import typer
from rich.console import Console

from gymtrack.cli import app

console = Console()


@app.command("sync")
def sync(
    routine: Path = typer.Argument(..., help="routine folder (scene.yaml, calibration, detections/)"),
    search: int = typer.Option(10, "--search", min=1, max=60, help="frames searched either side of 0"),
    write: bool = typer.Option(False, "--write", help="store the offsets in ROUTINE/scene.yaml (frame_offsets)"),
    as_json: bool = typer.Option(False, "--json", help="print the offsets as JSON"),
) -> None:
    """Estimate each camera's frame offset from the detections; --write stores them in scene.yaml."""
    from gymtrack.errors import GymtrackWarning, InputError
    from gymtrack.formats.routine import load_routine
    from gymtrack.formats.scene import save_scene
    from gymtrack.tracking.sync import LOW_CONFIDENCE, estimate_offsets

    r = load_routine(routine)
    if len(r.rig) < 2:
        raise InputError("sync needs two cameras or more", source=r.calibration_path)
    res = estimate_offsets(r.detections, r.rig, search=search)
    before = r.scene.frame_offsets
    total = {n: int(o) + before.get(n, 0) for n, o in zip(r.rig.names, res.offsets)}
    if as_json:
        console.print_json(json.dumps({n: {**v, "offset": total[n]} for n, v in res.as_dict().items()}))
    else:
        console.print(f"offsets against {r.rig.names[0]} from {res.frames} frames with boxes in two views or more:")
        for n, sub, c in zip(r.rig.names, res.offsets_subframe, res.confidence):
            console.print(f"  {n}: {total[n]:+d} frames (sub-frame {sub + before.get(n, 0):+.2f}), confidence {c:.2f}")
    for n in res.undecided():
        warnings.warn(f"sync: the data cannot decide camera {n}'s offset (confidence below {LOW_CONFIDENCE}); "
                      f"check that it sees the moving gymnast", GymtrackWarning)
    if write:
        offsets = {n: o for n, o in total.items() if o != 0}
        save_scene(r.scene.model_copy(update={"frame_offsets": offsets}), r.path / "scene.yaml")
        console.print(f"wrote frame_offsets to {r.path / 'scene.yaml'}")
