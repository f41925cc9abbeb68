"""The ``gymtrack`` command line (typer). Each sub-module registers its commands on :data:`app`."""

from __future__ import annotations

import typer

app = typer.Typer(
    name="gymtrack",
    help="Multi-camera gymnast tracking: simulate routines, track them, evaluate and benchmark.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

# Sub-modules register their commands on `app` when imported.
from . import info, simulate, track, benchmark, pose, eval, batch  # noqa: E402,F401


def main() -> None:
    """Entry point: runs the app; a :class:`GymtrackError` becomes a one-line message and exit 2."""
    import sys

    from rich.console import Console

    from ..errors import GymtrackError

    try:
        app()
    except GymtrackError as exc:
        Console(stderr=True).print(f"[bold red]error:[/] {exc}", highlight=False)
        sys.exit(2)
