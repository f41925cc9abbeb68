"""The analysis stage on files: ``<out>/poses_3d.csv`` + the routine's scene -> ``<out>/analysis/``.

Paper: Section III-D, last paragraph. What ``gymtrack analyse`` and the batch's ``analyse`` step
share: read the target's poses (the rows of ``poses_3d.csv`` that ``target_3d.csv`` names as the
target), analyse them, write ``angles.csv`` and ``elements.json``, and the routine sheet
(``report.html``) where matplotlib is installed. Also the element table's rows for people.
"""

from __future__ import annotations

import importlib.util
import warnings
from pathlib import Path

from ..errors import GymtrackWarning, InputError
from ..formats.outputs import of_target, read_target_3d
from ..formats.poses3d import read_poses_3d
from ..formats.scene import load_scene
from .api import Analysis, analyse

__all__ = ["analyse_output", "write_analysis", "element_rows"]


def target_poses(out: Path):
    """The target's rows of ``<out>/poses_3d.csv`` (every row when there is no ``target_3d.csv``)."""
    path = out / "poses_3d.csv"
    if not path.is_file():
        raise InputError("no poses_3d.csv: run `gymtrack pose <routine> <out>` first", source=path)
    poses = read_poses_3d(path)
    if len(poses) == 0:
        raise InputError("poses_3d.csv holds no pose (the pose stage lifted nothing): nothing to analyse", source=path)
    tpath = out / "target_3d.csv"
    if not tpath.is_file():
        return poses
    t = read_target_3d(tpath)
    if len(t["frame"]) == 0:
        raise InputError("target_3d.csv has no row: the tracker found no target (no track rose above the scene's "
                         "target heights in the performance space), so there is no gymnast to analyse", source=tpath)
    mine = of_target(poses.frame, poses.track_id, t)
    if not mine.any():
        raise InputError("poses_3d.csv has no pose of the target named in target_3d.csv (lifted with other tracks "
                         "only?): run `gymtrack pose` again", source=path)
    return poses.subset(mine)


def analyse_output(routine: str | Path, out: str | Path, **kw) -> Analysis:
    """Analyse the target's poses in ``out`` with the scene of ``routine`` (``<routine>/scene.yaml``)."""
    out = Path(out)
    scene = load_scene(Path(routine) / "scene.yaml")
    return analyse(target_poses(out), scene, **kw)


def write_analysis(analysis: Analysis, folder: str | Path, report: bool = True) -> list[str]:
    """Write ``angles.csv``, ``elements.json`` and (``report``) ``report.html`` into ``folder``;
    returns notes on what was left out (the routine sheet without matplotlib)."""
    folder = analysis.write(folder)
    notes = []
    if not report:
        return notes
    if importlib.util.find_spec("gymtrack.analysis.report") is None:
        return ["the routine sheet (report.html) is not part of this version"]
    if importlib.util.find_spec("matplotlib") is None:
        msg = "matplotlib is not installed: no report.html (install the `plot` extra: pip install 'gymtrack[plot]')"
        warnings.warn(msg, GymtrackWarning, stacklevel=2)
        return [msg]
    from .report import write_report  # noqa: PLC0415  (optional: matplotlib)

    write_report(folder)
    return notes


def _f(v, digits=2, unit="") -> str:
    return "-" if v is None else f"{v:.{digits}f}{unit}"


def _pm(el: dict, name: str, digits: int = 1, unit: str = "") -> str:
    v, sd = el.get(name), el.get(f"{name}_sd")
    if v is None:
        return "-"
    return f"{v:.{digits}f}" + (f" ± {sd:.{digits}f}" if sd else "") + unit


def element_rows(analysis: Analysis) -> list[tuple[str, str, str, str]]:
    """(kind, frames, seconds, what) per element, for the element table."""
    rows = []
    for e in analysis.elements:
        k = e["kind"]
        frames = f"{e['start_frame']}-{e['end_frame']}" if "start_frame" in e else str(e["frame"])
        secs = _f(e.get("duration_s"), 2, " s") if "duration_s" in e else ""
        if k == "flight":
            what = (f"{_f(e['saltos'], 2)} saltos, {_f(e['twists'], 1)} twists, {e['shape'] or '-'}; apex "
                    f"{_pm(e, 'apex_z', 2, ' m')}, gain {_f(e['height_gain'], 2, ' m')}, distance {_f(e['distance'], 2, ' m')}")
        elif k == "landing":
            what = "-" if e["steps"] is None else ("stuck" if e["stuck"] else f"{e['steps']} step(s), largest {e['largest_step']:.2f} m")
        elif k == "hold":
            what = f"{e['position']}, deviation {_pm(e, 'deviation', 1, ' deg')}"
        elif k == "circle":
            what = f"{e['turns']} turn about the bar" + (" (backward)" if e.get("direction", 1) < 0 else "")
        else:
            what = f"{_f(e['degrees'], 0)} deg"
        rows.append((k, frames, secs, what))
    return rows
