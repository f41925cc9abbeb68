"""TRC: OpenSim's marker file, of one track's joints (``shared/formats.md``, "Exports").

The paper's 3D pose (Section III-D, last paragraph) as the markers OpenSim scales a model to and
runs inverse kinematics on. Tab separated, five header lines, then one line a frame::

    PathFileType  4  (X/Y/Z)  <file name>
    DataRate  CameraRate  NumFrames  NumMarkers  Units  OrigDataRate  OrigDataStartFrame  OrigNumFrames
    <fps>  <fps>  <T>  <J>  m  <fps>  <first frame>  <T>
    Frame#  Time  <joint 1>  ''  ''  <joint 2> ...
    ''  ''  X1  Y1  Z1  X2  Y2  Z2 ...
    (a blank line)
    <frame>  <frame / fps>  x  y  z ...

Metres with 6 decimals (the 4 of ``poses_3d.csv`` kept; interpolated values rounded to a micron),
**Y up** as OpenSim expects: the world's (x, y, z) (z up) is written as (y, z, x), a rotation, so
the skeleton keeps its handedness. ``Frame#`` is the input's frame number and ``Time`` its time (8 decimals),
so the parts of a split track keep their place in the routine. Every cell holds a number: the
caller fills or cuts gaps first (:mod:`gymtrack.export.series`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

__all__ = ["to_y_up", "from_y_up", "write_trc"]

DIGITS = 6


def to_y_up(xyz: np.ndarray) -> np.ndarray:
    """(..., 3) world (x, y, z), z up -> OpenSim's (y, z, x), y up."""
    return xyz[..., [1, 2, 0]]


def from_y_up(xyz: np.ndarray) -> np.ndarray:
    """Inverse of :func:`to_y_up`."""
    return xyz[..., [2, 0, 1]]


def write_trc(path: str | Path, frames: np.ndarray, xyz: np.ndarray, joints: Sequence[str], fps: float) -> Path:
    """Write a TRC file of ``xyz`` (T, J, 3) world metres (all finite) at ``frames`` (T,)."""
    path = Path(path)
    frames = np.asarray(frames, np.int64)
    T, J = xyz.shape[:2]
    if not np.all(np.isfinite(xyz)):
        raise ValueError("a TRC file cannot hold a missing value: fill or cut the gaps first")
    if len(joints) != J or len(frames) != T:
        raise ValueError(f"{len(joints)} names and {len(frames)} frames for xyz of shape {xyz.shape}")
    first = int(frames[0]) if T else 0
    head = [
        f"PathFileType\t4\t(X/Y/Z)\t{path.name}",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames",
        f"{fps:g}\t{fps:g}\t{T}\t{J}\tm\t{fps:g}\t{first}\t{T}",
        "\t".join(["Frame#", "Time"] + [f"{n}\t\t" for n in joints]).rstrip("\t"),
        "\t".join(["", ""] + [f"X{k}\tY{k}\tZ{k}" for k in range(1, J + 1)]),
        "",
    ]
    body = np.column_stack([frames / fps, to_y_up(xyz).reshape(T, 3 * J)]) if T else np.zeros((0, 1 + 3 * J))
    with open(path, "w", newline="") as fh:
        fh.write("\n".join(head) + "\n")
        np.savetxt(fh, np.column_stack([frames, body]), fmt=["%d", "%.8f"] + [f"%.{DIGITS}f"] * (3 * J), delimiter="\t")
    return path
