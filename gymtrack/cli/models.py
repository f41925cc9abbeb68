"""``gymtrack models check FILE.onnx``: a model's inputs and outputs, and which adapter fits it.

Paper: Section III-A (person detector) and III-D (top-down pose model) -- the models gymtrack
runs are the user's ONNX exports; this says whether one fits an adapter of
:mod:`gymtrack.models` (detector: yolox, yolox_nms, yolov8; pose: simcc, heatmap) or why not.
"""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console
from rich.table import Table

from gymtrack.cli import app

console = Console()
models_app = typer.Typer(help="ONNX models: check which adapter an export fits (docs/models.md).", no_args_is_help=True)
app.add_typer(models_app, name="models")


@models_app.command("check")
def check(model: Path = typer.Argument(..., help="an ONNX file")) -> None:
    """Print the model's inputs and outputs and the adapter that fits it (exit 1 if none does)."""
    from gymtrack.models import check_model

    c = check_model(model)
    t = Table(title=f"{model.name}", title_justify="left")
    for col in ("", "name", "shape", "type"):
        t.add_column(col)
    for kind, tensors in (("input", c.signature.inputs), ("output", c.signature.outputs)):
        for x in tensors:
            t.add_row(kind, x.name, "(" + ", ".join(str(d) if d else "?" for d in x.shape) + ")", x.dtype)
    console.print(t)
    if c.fits:
        console.print(f"[green]fits[/] the {c.role} adapter [bold]{c.kind}[/]: {c.reason}", highlight=False)
    else:
        console.print(f"[red]no adapter fits[/]: {c.reason}", highlight=False)
        raise typer.Exit(1)
