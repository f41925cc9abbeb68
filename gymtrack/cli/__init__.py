"""The ``gymtrack`` command line (typer). Each sub-module registers its commands on :data:`app`.

Ctrl-C at any moment (also during these imports and numba's compile or cache load) ends with one
line and exit status 130 (:mod:`gymtrack.interrupts`): the handler is installed before anything
heavy is imported, and a command's KeyboardInterrupt is turned into that line by :class:`_Group`.
"""

from __future__ import annotations

import sys

from .. import interrupts as _interrupts

_interrupts.install()  # before the heavy imports (typer, rich, numpy, numba)


def _interrupted(notes: str = "") -> None:
    """The one line of an interrupted run, then exit 130 (a further Ctrl-C while printing is ignored)."""
    with _interrupts.quiet():
        sys.stderr.write(f"interrupted (Ctrl-C){': ' + notes if notes else ''}\n")
        sys.stderr.flush()
    raise SystemExit(130)


try:
    import typer
    from typer.core import TyperGroup
except KeyboardInterrupt:
    _interrupted("nothing was written")


class _Group(TyperGroup):
    """The root command: a KeyboardInterrupt escaping any command is one line and exit 130, not
    click's "Aborted!" and exit 1 (a command's notes say what happened to its outputs)."""

    def make_context(self, *args, **kwargs):
        try:
            return super().make_context(*args, **kwargs)
        except KeyboardInterrupt:
            _interrupted("nothing was written")

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt as exc:
            _interrupted("; ".join(getattr(exc, "__notes__", [])))


app = typer.Typer(
    cls=_Group,
    name="gymtrack",
    help="Multi-camera gymnast tracking: simulate routines, track them, evaluate and benchmark.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


@app.callback()
def _root(ctx: typer.Context) -> None:
    """Route Python warnings to the one reporting path (:mod:`gymtrack.cli.report`) while a command runs."""
    from .report import capture_warnings

    cm = capture_warnings()
    cm.__enter__()
    ctx.call_on_close(lambda: cm.__exit__(None, None, None))


# Sub-modules register their commands on `app` when imported.
try:
    from . import options  # noqa: E402,F401  (first: its help patch applies to every command)
    from . import info, simulate, track, benchmark, pose, eval, fit_plane, detect, run, models, view, batch  # noqa: E402,F401
    _interrupts.defer_during_numba()  # numba is imported by now (geometry)
except KeyboardInterrupt:
    _interrupted("nothing was written")


def main() -> None:
    """Entry point: runs the app; a :class:`GymtrackError` becomes a one-line message (plus its
    notes, e.g. what happened to the outputs) and exit 2 (3 for a failed ``--strict``)."""
    from rich.console import Console

    from rich.markup import escape

    from ..errors import GymtrackError
    from .report import STRICT_EXIT, StrictFailure

    try:
        try:
            app()
        except SystemExit as exc:  # typer ends every run so; a swallowed Ctrl-C must not end as success
            if exc.code in (0, None) and _interrupts.pending():
                raise KeyboardInterrupt from None
            raise
    except GymtrackError as exc:
        console = Console(stderr=True)
        console.print(f"[bold red]error:[/] {escape(str(exc))}", highlight=False, soft_wrap=True)
        for note in getattr(exc, "__notes__", []):
            console.print(f"  {escape(note)}", highlight=False, soft_wrap=True)
        sys.exit(STRICT_EXIT if isinstance(exc, StrictFailure) else 2)
    except KeyboardInterrupt as exc:  # outside a command's own handling (e.g. while printing its summary)
        _interrupted("; ".join(getattr(exc, "__notes__", [])))
