"""Where a Pose2Sim project keeps a trial's calibration and 2D poses.

Rule (``shared/formats.md``, routine folder; Pose2Sim's documented project layout): a session
folder holds ``Config.toml``, a calibration folder (``calibration/``; any folder whose name holds
"calib", as Pose2Sim itself looks for it) with ``Calib_<method>.toml`` (aniposelib's format), and
one folder per trial (optionally inside a participant folder), each with ``videos/`` and
``pose/<camera>_json/`` (OpenPose-style JSON, one file a frame)::

    Session/
      Config.toml
      calibration/Calib_scene.toml
      Participant/                     optional level
        Trial_1/
          Config.toml, videos/, pose/cam01_json/, pose/cam02_json/, ...

gymtrack reads a trial as a routine (``gymtrack track Session/Participant/Trial_1``): the
calibration is searched in the trial, then its parent, then the session; the poses are its
``pose/`` folder (``keypoints/`` first where both exist). Only a trial (a folder with ``pose/`` or
``Config.toml``) looks above itself for the calibration. A ``scene.yaml`` in the trial gives the
domain knowledge, as for any routine.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import RoutineError

__all__ = ["find_project_calibration", "find_keypoints_folder", "KEYPOINT_FOLDERS"]

#: 2D pose folders of a routine, in the order they are looked for
KEYPOINT_FOLDERS: tuple[str, ...] = ("keypoints", "pose")


def _calib_files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.glob("*.toml") if p.name.lower().startswith("calib") and p.is_file())


def find_project_calibration(routine: str | Path, levels: int = 2) -> Path | None:
    """The ``Calib*.toml`` of a Pose2Sim trial (module docstring), None when there is none.

    Looks in the routine folder and, when the routine is a Pose2Sim trial (it has ``pose/`` or a
    ``Config.toml``), up to ``levels`` folders above it, in each folder and its sub-folders whose name
    holds "calib". Several in the nearest folder that has any is an error naming them (give
    ``--calibration FILE``). A plain routine never looks above itself: the folders beside it are
    other routines', not its project's."""
    folder = Path(routine).resolve()
    if not ((folder / "pose").is_dir() or (folder / "Config.toml").is_file()):
        levels = 0
    for _ in range(levels + 1):
        found = _calib_files(folder)
        for sub in sorted(p for p in folder.iterdir() if p.is_dir() and "calib" in p.name.lower()):
            found += _calib_files(sub)
        if len(found) > 1:
            raise RoutineError(f"several calibrations ({', '.join(str(p.relative_to(folder)) for p in found)}): "
                               "give the one to use with --calibration FILE", source=folder)
        if found:
            return found[0]
        if folder.parent == folder:
            break
        folder = folder.parent
    return None


def find_keypoints_folder(routine: str | Path) -> Path | None:
    """``keypoints/`` or Pose2Sim's ``pose/`` in the routine folder, None when neither."""
    for name in KEYPOINT_FOLDERS:
        p = Path(routine) / name
        if p.is_dir():
            return p
    return None
