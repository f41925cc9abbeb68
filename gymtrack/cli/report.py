"""One reporting path for the command line: warnings as one-line yellow messages, ``--strict``.

Paper: none (user interface). Library code warns with :func:`warnings.warn` (category
:class:`gymtrack.errors.GymtrackWarning` for the project's own); while a command runs,
:func:`capture_warnings` routes every Python warning to :data:`REPORTER`, which prints it once
as ``warning: <message>`` on stderr and counts it. Commands warn directly with
:meth:`Reporter.warn`; :meth:`Reporter.check_strict` turns the warnings of a ``--strict`` run
into :class:`StrictFailure` (exit status 3).
"""

from __future__ import annotations

import warnings
from contextlib import contextmanager
from typing import Iterator

from rich.console import Console
from rich.markup import escape

from ..errors import GymtrackError

#: Exit status of a ``--strict`` run that had warnings.
STRICT_EXIT = 3


class StrictFailure(GymtrackError):
    """A ``--strict`` run produced warnings."""


class Reporter:
    """Prints warnings once each (yellow, one line, stderr) and remembers them."""

    def __init__(self, console: Console | None = None) -> None:
        self.console = console or Console(stderr=True)
        self.messages: list[str] = []

    def reset(self) -> None:
        self.messages = []

    def warn(self, message: str) -> None:
        """Report ``message`` (a repeated message is printed once)."""
        message = " ".join(str(message).split())
        if message in self.messages:
            return
        self.messages.append(message)
        self.console.print(f"[yellow]warning:[/] {escape(message)}", highlight=False, soft_wrap=True)

    def showwarning(self, message, category, filename, lineno, file=None, line=None) -> None:
        """Stands in for :func:`warnings.showwarning` while a command runs."""
        from ..errors import GymtrackWarning

        text = str(message)
        if not issubclass(category, GymtrackWarning) and category is not UserWarning:
            text = f"{text} ({category.__name__})"
        self.warn(text)

    def check_strict(self, strict: bool) -> None:
        """Raise :class:`StrictFailure` when ``strict`` and any warning was reported."""
        if strict and self.messages:
            n = len(self.messages)
            raise StrictFailure(f"--strict: {n} warning{'s' if n > 1 else ''} (above)")


#: The reporter of the running command.
REPORTER = Reporter()


@contextmanager
def capture_warnings(reporter: Reporter = REPORTER) -> Iterator[Reporter]:
    """Route Python warnings to ``reporter`` (each distinct message once) inside the block.

    The filters stay Python's (deprecations of libraries stay hidden), except that the project's
    own warnings always reach the reporter, also on a second run in the same process."""
    from ..errors import GymtrackWarning

    reporter.reset()
    with warnings.catch_warnings():
        warnings.simplefilter("always", GymtrackWarning)
        warnings.showwarning = reporter.showwarning
        yield reporter


@contextmanager
def interrupts(console: Console | None = None) -> Iterator[None]:
    """Ctrl-C inside the block: one line (with what happened to the outputs) and exit status 130."""
    import typer

    try:
        yield
    except KeyboardInterrupt as exc:
        from .. import interrupts as _interrupts

        notes = "; ".join(getattr(exc, "__notes__", []))
        with _interrupts.quiet():  # a second Ctrl-C while printing is only recorded: still one line
            (console or REPORTER.console).print(f"[red]interrupted[/] (Ctrl-C){': ' + escape(notes) if notes else ''}",
                                                highlight=False, soft_wrap=True)
        raise typer.Exit(130) from None
