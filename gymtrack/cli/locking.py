"""The options and the lock of commands that write into (or score) an output folder.

Paper: none (the project's rule: the output folder is the unit of safety,
:mod:`gymtrack.formats.folder_lock`). ``track``, ``run``, ``pose`` and ``eval`` hold the folder from
their first read to their last write (``eval`` as a reader: several may score one folder at
once); a second command waits ``--wait`` seconds, then refuses naming the holder. ``pose`` and
``eval`` refuse an output folder made from another routine unless ``--force``.
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import typer

from .report import REPORTER


def wait_option() -> float:
    return typer.Option(0.0, "--wait", help="when another command holds the output folder, wait up to this many seconds for it (default: refuse at once)")


def force_routine_option() -> bool:
    return typer.Option(False, "--force", help="use the output folder even when its marker records another routine")


@contextmanager
def hold(out: Path, command: str, wait: float = 0.0, shared: bool = False) -> Iterator[None]:
    """Hold output folder ``out`` (:func:`~gymtrack.formats.folder_lock.folder_lock`); the wait is reported once."""
    from gymtrack.formats.folder_lock import folder_lock

    with folder_lock(out, command, wait=wait, shared=shared,
                     notify=lambda msg: REPORTER.console.print(msg, highlight=False, soft_wrap=True)):
        yield


def hold_for_command(ctx: typer.Context, out: Path, command: str, wait: float = 0.0, routine: Path | None = None,
                     force: bool = False, shared: bool = False) -> None:
    """Hold ``out`` until the running command ends (a resource of click's context), then check that
    its marker records ``routine`` (unless ``force``). A missing folder is left to the command's own error."""
    from gymtrack.formats.atomic import check_routine

    if not Path(out).is_dir():
        return
    ctx.with_resource(hold(out, command, wait, shared))
    if routine is not None:
        check_routine(out, routine, force)
