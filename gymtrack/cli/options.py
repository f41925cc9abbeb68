"""Options shared by the commands, and the one way a command reads a routine.

Paper: the routine's inputs of Section III (calibration ``P_c``, boxes, scene). Every command that
reads a routine (info, track; pose and eval reuse it) declares the calibration options with
:func:`calibration_format_option` / :func:`units_option` and reads the folder with
:func:`read_routine`, which also reports (through :mod:`gymtrack.cli.report`) the calibration's
notes and the stream checks of :mod:`gymtrack.formats.checks` (silent cameras, gaps, boxes
outside the image).

Typer's help shows boolean flags as ``--plot <bool>`` with this typer/click pair; the patch at
the end shows them as ``--plot``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..formats.checks import SILENT_SECONDS, StreamChecks, check_detections
from ..formats.routine import Routine, load_routine
from .report import REPORTER


def calibration_format_option() -> Optional[str]:
    return typer.Option(
        None, "--calibration-format", help="native | anipose | easymocap | panoptic | wildtrack (default: from the file name)"
    )


def units_option() -> Optional[str]:
    return typer.Option(None, "--units", help="units of an aniposelib / EasyMocap calibration's translations: m | cm | mm")


def strict_option() -> bool:
    return typer.Option(False, "--strict", help="exit with status 3 when there was any warning (and write no outputs)")


def silent_seconds_option() -> float:
    return typer.Option(SILENT_SECONDS, "--silent-seconds", help="report a camera with no detections for longer than this (s)")


def overwrite_option() -> bool:
    return typer.Option(False, "--overwrite", help="replace --out even when it is a non-empty folder that is not a gymtrack output")


def read_routine(
    path: Path, calibration_format: Optional[str] = None, units: Optional[str] = None,
    silent_seconds: float = SILENT_SECONDS,
) -> tuple[Routine, StreamChecks]:
    """Load a routine with the calibration options; report the calibration notes and stream checks."""
    opts = {} if units is None else {"units": units}
    r = load_routine(path, calibration_format, **opts)
    checks = check_detections(r.detections, r.rig, r.scene.fps, silent_seconds)
    for msg in checks.warnings():
        REPORTER.warn(msg)
    return r, checks


def _patch_flag_display() -> None:
    """Show boolean flags without a type (``--plot``, not ``--plot <bool>``) in rich help."""
    try:
        from typer.core import TyperOption
    except ImportError:  # pragma: no cover
        return
    orig = getattr(TyperOption, "display_type_rich", None)
    if orig is None or getattr(orig, "_gymtrack", False):
        return

    def display_type_rich(self, ctx):
        if getattr(self, "is_flag", False) or getattr(self, "count", False):
            return None
        return orig(self, ctx)

    display_type_rich._gymtrack = True
    TyperOption.display_type_rich = display_type_rich


_patch_flag_display()
