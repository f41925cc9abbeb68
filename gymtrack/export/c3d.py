"""C3D: the motion-capture file biomechanics tools read (``shared/formats.md``, "Exports").

The paper's 3D pose (Section III-D, last paragraph) as C3D points, written with ``ezc3d`` (the
``export`` extra): POINT:LABELS the joint names, POINT:RATE the fps, POINT:UNITS ``m``, the world
frame as it is (z up, metres; POINT:X_SCREEN ``+X`` and POINT:Y_SCREEN ``+Z`` tell viewers so). A joint without an estimate in a frame has residual -1, C3D's
"invalid", and no position (ezc3d stores it as the spec's zeros); an estimated joint has residual
0 ("valid"; gymtrack has no residual in metres to give). Nothing is interpolated: a gap stays a gap.

Shapes: ``xyz`` (T, J, 3) world metres over consecutive frames, NaN = no estimate.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from ..errors import InputError

__all__ = ["write_c3d"]


def _ezc3d():
    try:
        import ezc3d
    except ImportError:
        raise InputError("writing C3D needs the ezc3d package: pip install 'gymtrack[export]'", field="--format") from None
    return ezc3d


def write_c3d(path: str | Path, first_frame: int, xyz: np.ndarray, joints: Sequence[str], fps: float) -> tuple[Path, int]:
    """Write ``xyz`` (T, J, 3) as a C3D file; returns the path and the number of invalid points
    (joint-frames without an estimate, residual -1)."""
    ezc3d = _ezc3d()
    path = Path(path)
    T, J = xyz.shape[:2]
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [float(fps)]
    c["parameters"]["POINT"]["UNITS"]["value"] = ["m"]
    c["parameters"]["POINT"]["LABELS"]["value"] = tuple(joints)
    c["parameters"]["POINT"]["DESCRIPTIONS"]["value"] = tuple(f"gymtrack 3D pose: {n}" for n in joints)
    # the screen axes viewers (Mokka, Nexus) orient the view by: the world's z is up
    c.add_parameter("POINT", "X_SCREEN", "+X")
    c.add_parameter("POINT", "Y_SCREEN", "+Z")
    c["header"]["points"]["first_frame"] = int(first_frame)
    ok = np.all(np.isfinite(xyz), axis=-1)  # (T, J)
    pts = np.ones((4, J, T))
    pts[:3] = np.where(ok[..., None], xyz, np.nan).transpose(2, 1, 0)
    c["data"]["points"] = pts
    c["data"]["meta_points"]["residuals"] = np.where(ok, 0.0, -1.0).T[None]  # (1, J, T)
    c.write(str(path))
    return path, int((~ok).sum())
