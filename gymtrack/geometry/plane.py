"""Planes and the ray-plane intersection of paper Eq. 5-7.

Paper: Section III-C. A box centre defines a ray from the camera centre ``X^o_c`` along
``{}^w v`` (Eq. 5-6, :meth:`Camera.rays`); its intersection with the vertical plane
``(n, X^p)`` is ``X = X^o + (n . (X^p - X^o)) / (n . v) v`` (Eq. 7), a 3D candidate from a
single view.

Two cases have no sensible answer and are reported rather than returned as a wrong number:
the ray (nearly) parallel to the plane (``n . v`` ~ 0: the intersection is at infinity or
anywhere) and the plane behind the camera (the ray parameter is negative: the "intersection"
lies behind the camera, where nothing it sees can be).

The arithmetic is :func:`gymtrack.geometry.primitives.ray_plane`, the code the tracker's plane
kernel runs: Eq. 7 is written once.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from .primitives import rays_plane


class RayPlaneStatus(IntEnum):
    """Outcome of one ray-plane intersection."""

    OK = 0
    PARALLEL = 1  #: |cos| between ray and plane normal below the tolerance (or no direction: zero/NaN)
    BEHIND = 2  #: the plane is hit behind the ray origin


@dataclass(frozen=True, eq=False)
class Plane:
    """A plane through ``point`` with unit ``normal`` (both (3,), world frame, metres)."""

    point: np.ndarray
    normal: np.ndarray

    def __post_init__(self) -> None:
        p = np.asarray(self.point, dtype=np.float64).reshape(3)
        n = np.asarray(self.normal, dtype=np.float64).reshape(3)
        norm = np.linalg.norm(n)
        if not np.isfinite(norm) or norm < 1e-12 or not np.all(np.isfinite(p)):
            raise ValueError(f"a plane needs a finite point and a non-zero normal, got point={p}, normal={n}")
        object.__setattr__(self, "point", p)
        object.__setattr__(self, "normal", n / norm)

    @classmethod
    def from_spec(cls, spec) -> "Plane":
        """From a :class:`gymtrack.scene.PlaneSpec`."""
        return cls(np.asarray(spec.point), np.asarray(spec.normal))

    def signed_distance(self, X: np.ndarray) -> np.ndarray:
        """(..., 3) points -> (...) signed distance along the normal, metres."""
        return (np.asarray(X, dtype=np.float64) - self.point) @ self.normal

    def project(self, X: np.ndarray) -> np.ndarray:
        """(..., 3) points -> (..., 3) their orthogonal projections onto the plane."""
        X = np.asarray(X, dtype=np.float64)
        return X - self.signed_distance(X)[..., None] * self.normal


def intersect_rays_plane(
    origins: np.ndarray,
    directions: np.ndarray,
    plane: Plane,
    min_cos: float = 1e-3,
) -> tuple[np.ndarray, np.ndarray]:
    """Intersect rays with a plane (paper Eq. 7), vectorised.

    Parameters
    ----------
    origins: (..., 3) ray origins (camera centres ``X^o_c``), broadcast against ``directions``.
    directions: (..., 3) ray directions ``{}^w v`` (need not be unit length).
    plane: the plane.
    min_cos: rays whose direction makes ``|cos| < min_cos`` with the normal count as parallel.
        The default (about 0.06 degrees off the plane) keeps intersections within ~1000 x the
        camera's distance to the plane; raise it to refuse grazing rays whose intersection is
        too sensitive to pixel noise.

    Returns
    -------
    X: (..., 3) intersection points; NaN where the status is not OK.
    status: (...) int8 :class:`RayPlaneStatus` codes.
    """
    o, d = np.broadcast_arrays(np.asarray(origins, dtype=np.float64), np.asarray(directions, dtype=np.float64))
    shape = o.shape[:-1]
    c = np.ascontiguousarray
    X, status = rays_plane(c(o.reshape(-1, 3)), c(d.reshape(-1, 3)), plane.point, plane.normal, float(min_cos))
    return X.reshape(shape + (3,)), status.reshape(shape)
