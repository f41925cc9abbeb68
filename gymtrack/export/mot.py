"""MOT: OpenSim's motion file of the analysis stage's joint angles (``shared/formats.md``, "Exports").

The judging measurements of the paper's Fig. 8 (``analysis/angles.csv``: knee, hip, elbow,
shoulder, split, inclination, somersault, twist, in degrees) in the form OpenSim's plotter and
tools read::

    <name>
    version=1
    nRows=<rows>
    nColumns=<1 + angles>
    inDegrees=yes
    endheader
    time  left_knee  right_knee ...
    <frame / fps>  ...

Tab separated, time with 8 decimals, angles with 6; a measure that could not be computed is ``NaN`` (OpenSim reads it as
a missing value), never a guessed angle.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Mapping

import numpy as np

from ..formats.elements import ANGLE_MEASURES

__all__ = ["MOT_COLUMNS", "write_mot"]

#: the columns after ``time``
MOT_COLUMNS: tuple[str, ...] = ANGLE_MEASURES


def write_mot(path: str | Path, angles: Mapping[str, np.ndarray], fps: float) -> tuple[Path, int]:
    """Write the angle columns of ``angles`` (read by ``formats.elements.read_angles``; its rows in
    frame order) at time ``frame / fps``; returns the path and the number of NaN cells."""
    path = Path(path)
    frame = np.asarray(angles["frame"], np.int64)
    order = np.argsort(frame, kind="stable")
    data = np.column_stack([frame[order] / fps] + [np.asarray(angles[c], float)[order] for c in MOT_COLUMNS])
    head = [path.stem, "version=1", f"nRows={len(frame)}", f"nColumns={1 + len(MOT_COLUMNS)}", "inDegrees=yes",
            "endheader", "\t".join(("time",) + MOT_COLUMNS)]
    buf = io.StringIO()
    np.savetxt(buf, data, fmt=["%.8f"] + ["%.6f"] * len(MOT_COLUMNS), delimiter="\t")
    with open(path, "w", newline="") as fh:
        fh.write("\n".join(head) + "\n" + buf.getvalue().replace("nan", "NaN"))
    return path, int(np.isnan(data).sum())
