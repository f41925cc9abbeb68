"""Which calibration format a path holds, and the dispatch table that reads it.

Paper: Section III-B's per-camera ``K_c``, ``R_c``, ``t_c`` from whichever file a user has; each
format module contributes one :class:`~.checks.CalibrationFormat` to :data:`READERS`.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from ...errors import CalibrationError
from ...geometry.camera import Rig
from . import anipose, easymocap, native, panoptic, wildtrack
from .checks import CalibrationFormat, CalibrationReport
from .wildtrack import is_wildtrack_dir

__all__ = ["READERS", "FORMATS", "CALIBRATION_NAMES", "detect_format", "find_calibration", "read_calibration", "load_calibration"]

#: The dispatch table: format name -> reader and the options it accepts.
READERS: dict[str, CalibrationFormat] = {
    f.name: f for f in (native.FORMAT, anipose.FORMAT, easymocap.FORMAT, panoptic.FORMAT, wildtrack.FORMAT)
}
#: The format names ``format=`` accepts.
FORMATS: tuple[str, ...] = tuple(READERS)


def detect_format(path: str | Path) -> str:
    """The calibration format of ``path`` from its name (see the module docstring).

    A folder is a WILDTRACK calibration when it (or its ``calibrations/`` sub-folder) holds
    ``extrinsic/`` and ``intrinsic_zero/``; any other folder is searched with
    :func:`find_calibration`.
    """
    path = Path(path)
    if path.is_dir():
        if is_wildtrack_dir(path):
            return "wildtrack"
        return detect_format(find_calibration(path))
    name = path.name.lower()
    if name in ("cameras.yaml", "cameras.yml", "cameras.json"):
        return "native"
    if name.endswith(".toml"):
        return "anipose"
    if name in ("intri.yml", "intri.yaml", "extri.yml", "extri.yaml"):
        return "easymocap"
    if re.fullmatch(r"calibration_.+\.json", name):
        return "panoptic"
    raise CalibrationError(
        "cannot tell the calibration format from the file name; name it cameras.yaml / cameras.json (native), "
        "calibration.toml (aniposelib), intri.yml + extri.yml (EasyMocap), calibration_<seq>.json (CMU Panoptic), "
        f"or pass format= one of {', '.join(FORMATS)}",
        source=path,
    )



#: Calibration file names searched in a folder, in this order.
CALIBRATION_NAMES: tuple[str, ...] = ("cameras.yaml", "cameras.yml", "cameras.json", "calibration.toml", "intri.yml", "intri.yaml")


def find_calibration(folder: str | Path, error=CalibrationError) -> Path:
    """The one calibration inside ``folder``: a file named in :data:`CALIBRATION_NAMES`, a
    ``calibration_*.json`` or a WILDTRACK ``calibrations/`` folder. None or several is an error."""
    folder = Path(folder)
    found = [folder / n for n in CALIBRATION_NAMES if (folder / n).is_file()]
    found += sorted(folder.glob("calibration_*.json"))
    if (folder / "calibrations").is_dir() and is_wildtrack_dir(folder / "calibrations"):
        found.append(folder / "calibrations")
    if not found:
        raise error(
            "no calibration found: add cameras.yaml (see shared/formats.md) or one of "
            f"{', '.join(CALIBRATION_NAMES[3:])}, calibration_<seq>.json, calibrations/",
            source=folder,
        )
    if len(found) > 1:
        raise error(f"several calibrations found ({', '.join(p.name for p in found)}); keep one", source=folder)
    return found[0]


def read_calibration(path: str | Path, format: str | None = None, **options: Any) -> tuple[Rig, CalibrationReport]:
    """Read any supported calibration; returns the rig and a :class:`CalibrationReport`.

    Parameters
    ----------
    path: a calibration file, a WILDTRACK calibrations folder, or a folder holding exactly one
        calibration (see :func:`find_calibration`).
    format: one of :data:`FORMATS`; detected from the name when None.
    options: passed to the reader: ``units`` (anipose, easymocap), ``size`` (easymocap),
        ``camera_types`` (panoptic), ``intrinsics`` (wildtrack: ``"zero"`` or ``"original"``).
    """
    path = Path(path)
    if not path.exists():
        raise CalibrationError("file not found", source=path)
    if format is None:
        format = detect_format(path)
        if path.is_dir() and format != "wildtrack":
            path = find_calibration(path)
    if format not in FORMATS:
        raise CalibrationError(f"unknown calibration format {format!r}; use one of {', '.join(FORMATS)}", source=path, field="format")
    report = CalibrationReport(path=path, format=format)
    allowed = READERS[format].options
    bad = sorted(set(options) - allowed)
    if bad:
        raise CalibrationError(f"option {bad[0]!r} does not apply to the {format} format (accepted: {', '.join(sorted(allowed)) or 'none'})",
                               source=path, field=bad[0])
    rig = READERS[format].read(path, report, **options)
    report.cameras = len(rig)
    return rig, report


def load_calibration(path: str | Path, format: str | None = None, **options: Any) -> Rig:
    """Read any supported calibration into a Rig (metres, z up); see :func:`read_calibration`."""
    return read_calibration(path, format, **options)[0]
