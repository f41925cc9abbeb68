"""Which views see a point from opposite sides: the line-of-sight angle.

Paper: Section III-C. When only two views see a person and their lines of sight meet at nearly
180 degrees, triangulation is ill-conditioned along the line joining the cameras; such a pair
is "opposite" and goes to the plane fallback (the cascaded data association).
"""

from __future__ import annotations

import numpy as np

from .camera import Rig


def line_of_sight_angle(centre_a: np.ndarray, centre_b: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Angle in degrees between the lines of sight ``X - C_a`` and ``X - C_b``.

    Parameters
    ----------
    centre_a, centre_b: (..., 3) camera centres.
    X: (..., 3) the observed point(s); all three broadcast.

    Returns
    -------
    (...) degrees in [0, 180]: 0 for cameras on the same side along one ray, 180 for two cameras
    facing each other through ``X``.
    """
    a = np.asarray(X, dtype=np.float64) - np.asarray(centre_a, dtype=np.float64)
    b = np.asarray(X, dtype=np.float64) - np.asarray(centre_b, dtype=np.float64)
    cos = np.sum(a * b, axis=-1) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def pairwise_angles(rig: Rig, X: np.ndarray) -> np.ndarray:
    """(C, C) line-of-sight angles between every camera pair at the point ``X`` (3,)."""
    c = rig.centres
    return line_of_sight_angle(c[:, None, :], c[None, :, :], np.asarray(X, dtype=np.float64))


def opposite_pairs(rig: Rig, X: np.ndarray, threshold_deg: float = 150.0) -> np.ndarray:
    """(C, C) bool, symmetric: True where two distinct cameras look at ``X`` (3,) from
    opposite sides, i.e. their line-of-sight angle exceeds ``threshold_deg``."""
    ang = pairwise_angles(rig, X)
    out = ang > threshold_deg
    np.fill_diagonal(out, False)
    return out
