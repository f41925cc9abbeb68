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
from ..modes import DEFAULT_MODE, INGREDIENTS, Method
from .report import REPORTER


def mode_option() -> str:
    return typer.Option(DEFAULT_MODE, "--mode", "-m", help="cascade (the paper) | cascade+ (beyond it) | triangulation | plane")


def without_option() -> Optional[list[str]]:
    return typer.Option(None, "--without", help=f"switch this ingredient of the mode off (repeat the option): {', '.join(INGREDIENTS)}")


def adding_option() -> Optional[list[str]]:
    return typer.Option(None, "--adding", help="switch this ingredient on as cascade+ has it (repeat the option; names as --without)")


def recipe_of(mode: str, without: Optional[list[str]], adding: Optional[list[str]]) -> Method:
    """The recipe of ``--mode`` / ``--without`` / ``--adding`` (its ``name`` carries it as text,
    :func:`gymtrack.modes.method_of`); InputError naming the option that is wrong."""
    from ..errors import InputError
    from ..modes import method_of, recipe

    try:
        return recipe(method_of(mode), without or (), adding or ())
    except ValueError as e:
        raise InputError(str(e), field="--without/--adding" if "ingredient" in str(e) else "--mode") from None


def calibration_format_option() -> Optional[str]:
    return typer.Option(
        None, "--calibration-format", help="native | anipose | easymocap | panoptic | wildtrack (default: from the file name)"
    )


def units_option() -> Optional[str]:
    return typer.Option(None, "--units", help="units of an aniposelib / EasyMocap calibration's translations: m | cm | mm")


def calibration_option() -> Optional[Path]:
    return typer.Option(None, "--calibration", help="the calibration file, any name (default: found in ROUTINE, or a "
                        "Pose2Sim project's calibration/Calib*.toml)")


def keypoints_option() -> Optional[Path]:
    return typer.Option(None, "--keypoints", "-k", help="the 2D poses' folder, any layout the keypoints readers take "
                        "(default: ROUTINE/keypoints, else Pose2Sim's ROUTINE/pose)")


def skeleton_option() -> Optional[str]:
    return typer.Option(None, "--skeleton", help="joint order of the 2D poses: body25 | body25b | coco17 | halpe26 | "
                        "coco_wholebody | coco18, or the joint names in file order, comma-separated (default: the file's, else "
                        "recognised from the joints' layout)")


def strict_option() -> bool:
    return typer.Option(False, "--strict", help="exit with status 3 when there was any warning (and write no outputs)")


def silent_seconds_option() -> float:
    return typer.Option(SILENT_SECONDS, "--silent-seconds", help="report a camera with no detections for longer than this (s)")


def overwrite_option() -> bool:
    return typer.Option(False, "--overwrite", help="replace --out even when it is a non-empty folder that is not a gymtrack output")


def read_routine(
    path: Path, calibration_format: Optional[str] = None, units: Optional[str] = None,
    silent_seconds: float = SILENT_SECONDS, calibration: Optional[Path] = None, keypoints: Optional[Path] = None,
    skeleton: Optional[str] = None,
) -> tuple[Routine, StreamChecks]:
    """Load a routine with the calibration and keypoints options; report the calibration notes,
    where the 2D poses came from (when read here: no ``detections/``) and the stream checks."""
    opts = {} if units is None else {"units": units}
    r = load_routine(path, calibration_format, calibration=calibration, keypoints=keypoints, skeleton=skeleton, **opts)
    if r.keypoints_report is not None:
        for line in r.keypoints_report.lines():
            REPORTER.console.print(f"2D poses: {line}", highlight=False, soft_wrap=True)
    if r.pose_boxes is not None:
        REPORTER.console.print(r.pose_boxes.describe(), highlight=False, soft_wrap=True)
    checks = check_detections(r.detections, r.rig, r.scene.fps, silent_seconds)
    # a pause of hours costs the tracker nothing, but a wrong frame number is likelier
    for msg in r.gap_warnings() + checks.warnings():
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
