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


def _print_version(value: bool) -> None:
    if value:
        from ..version import version

        typer.echo(f"gymtrack {version()}")
        raise typer.Exit()


@app.callback()
def _root(
    ctx: typer.Context,
    _version: bool = typer.Option(False, "--version", "-V", callback=_print_version, is_eager=True,
                                  help="print gymtrack's version and exit"),
) -> None:
    """Route Python warnings to the one reporting path (:mod:`gymtrack.cli.report`) while a command runs."""
    from .report import capture_warnings

    cm = capture_warnings()
    cm.__enter__()
    ctx.call_on_close(lambda: cm.__exit__(None, None, None))


# Sub-modules register their commands on `app` when imported.
from . import options  # noqa: E402,F401  (first: its help patch applies to every command)
from . import info, simulate, track, benchmark, pose, eval, fit_plane, detect, run, models, view, batch  # noqa: E402,F401
from . import export  # noqa: E402,F401
from . import sync  # noqa: E402,F401


def main() -> None:
    """Entry point: runs the app; a :class:`GymtrackError` becomes a one-line message (plus its
    notes, e.g. what happened to the outputs) and exit 2 (3 for a failed ``--strict``)."""
    import sys

    from rich.console import Console

    from rich.markup import escape

    from ..errors import GymtrackError
    from .report import STRICT_EXIT, StrictFailure

    try:
        app()
    except GymtrackError as exc:
        console = Console(stderr=True)
        console.print(f"[bold red]error:[/] {escape(str(exc))}", highlight=False, soft_wrap=True)
        for note in getattr(exc, "__notes__", []):
            console.print(f"  {escape(note)}", highlight=False, soft_wrap=True)
        sys.exit(STRICT_EXIT if isinstance(exc, StrictFailure) else 2)
    except KeyboardInterrupt:  # outside a command's own handling (e.g. while printing its summary)
        Console(stderr=True).print("[red]interrupted[/] (Ctrl-C)", highlight=False)
        sys.exit(130)
