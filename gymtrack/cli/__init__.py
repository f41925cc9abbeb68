"""The ``gymtrack`` command line (typer). Each sub-module registers its commands on :data:`app`.

Ctrl-C at any moment (also during these imports and numba's compile or cache load) ends with one
line and exit status 130 (:mod:`gymtrack.interrupts`): the handler is installed before anything
heavy is imported, and a command's KeyboardInterrupt is turned into that line by :class:`_Group`.
"""

from __future__ import annotations

import os
import sys

from .. import interrupts as _interrupts

_interrupts.install()  # before the heavy imports (typer, rich, numpy, numba)


def _interrupted(notes: str = "", final: bool = False) -> None:
    """The one line of an interrupted run, then exit 130 (a further Ctrl-C is only recorded).
    ``final``: the program ends here (not a command run in-process by a test): ignore Ctrl-C from now on."""
    if final:
        _interrupts.settle()
    with _interrupts.quiet():
        sys.stderr.write(f"interrupted (Ctrl-C){': ' + notes if notes else ''}\n")
        sys.stderr.flush()
    if final:
        _exit_130()
    raise SystemExit(130)


def _exit_130() -> None:
    """Exit 130 now. Not through SystemExit: a KeyboardInterrupt once raised inside code an extension
    ran during an import leaves CPython's flag "unhandled interrupt" set, and the interpreter would
    then end by killing itself with SIGINT (status -2) whatever the exit code."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(130)


try:
    import typer
    from typer.core import TyperGroup
except BaseException:  # a KeyboardInterrupt, or what an import made of it (a RuntimeError from __set_name__...)
    if _interrupts.pending():
        _interrupted("no outputs were written", final=True)
    raise


class _Group(TyperGroup):
    """The root command: a KeyboardInterrupt escaping any command is one line and exit 130, not
    click's "Aborted!" and exit 1 (a command's notes say what happened to its outputs)."""

    def make_context(self, *args, **kwargs):
        try:
            return super().make_context(*args, **kwargs)
        except KeyboardInterrupt:
            _interrupted("no outputs were written")

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt as exc:
            _interrupted("; ".join(getattr(exc, "__notes__", [])) or _interrupts.outcome())
        except Exception as exc:  # what a library made of a KeyboardInterrupt (a RuntimeError...)
            if _interrupts.pending() and not isinstance(exc, typer.Exit):
                _interrupted("; ".join(getattr(exc, "__notes__", [])) or _interrupts.outcome())
            raise


app = typer.Typer(
    cls=_Group,
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
try:
    from . import options  # noqa: E402,F401  (first: its help patch applies to every command)
    from . import info, simulate, track, benchmark, pose, eval, fit_plane, detect, run, models, view, batch  # noqa: E402,F401
    from . import export, analyse, sync, benchmark_pool  # noqa: E402,F401
    _interrupts.defer_during_numba()  # numba is imported by now (geometry)
except BaseException:
    if _interrupts.pending():
        _interrupted("no outputs were written", final=True)
    raise


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
        except SystemExit as exc:  # typer ends every run so
            _interrupts.settle()  # Python's teardown must not die of a late Ctrl-C
            if exc.code in (0, None) and _interrupts.pending():  # one swallowed on its way: not a success
                raise KeyboardInterrupt from None
            if exc.code == 130:
                _exit_130()
            raise
    except GymtrackError as exc:
        _interrupts.settle()
        console = Console(stderr=True)
        console.print(f"[bold red]error:[/] {escape(str(exc))}", highlight=False, soft_wrap=True)
        for note in getattr(exc, "__notes__", []):
            console.print(f"  {escape(note)}", highlight=False, soft_wrap=True)
        sys.exit(STRICT_EXIT if isinstance(exc, StrictFailure) else 2)
    except KeyboardInterrupt as exc:  # outside a command's own handling (e.g. while printing its summary)
        _interrupted("; ".join(getattr(exc, "__notes__", [])) or _interrupts.outcome(), final=True)
