"""A rig and a set of planes as contiguous arrays: the named groups compiled kernels take.

Paper: Section III-B (``P_c = K_c [R_c | t_c]``), Eq. 5-6 (rays ``R^T K^-1 [u, v, 1]`` from the
camera centres), Eq. 7 (planes ``(n, X^p)``) and Eq. 14 (projection with distortion). The
numba kernels of :mod:`gymtrack.tracking` cannot read :class:`~.camera.Camera` objects; they
take these tuples (numba accepts NamedTuples of arrays), built once per rig
(:attr:`.camera.Rig.arrays`) or per list of planes.
"""

from __future__ import annotations

from typing import Iterable, NamedTuple

import numpy as np


class RigArrays(NamedTuple):
    """Per-camera calibration of a rig of C cameras, float64, C order.

    K, R: (C, 3, 3); t: (C, 3); dist: (C, 8) OpenCV coefficients zero-padded to 8;
    size: (C, 2) image width, height; centres: (C, 3) ``-R^T t``; back: (C, 3, 3)
    ``R^T K^-1`` (Eq. 6); P: (C, 3, 4) ``K [R | t]``.
    """

    K: np.ndarray
    R: np.ndarray
    t: np.ndarray
    dist: np.ndarray
    size: np.ndarray
    centres: np.ndarray
    back: np.ndarray
    P: np.ndarray

    @classmethod
    def from_cameras(cls, cameras: Iterable) -> "RigArrays":
        """From :class:`~.camera.Camera` objects (prefer the cached :attr:`.camera.Rig.arrays`)."""
        cams = list(cameras)
        dist = np.zeros((len(cams), 8))
        for i, c in enumerate(cams):
            dist[i, : c.dist.size] = c.dist[:8]
        K = np.stack([c.K for c in cams])
        R = np.stack([c.R for c in cams])
        c = np.ascontiguousarray
        return cls(K=K, R=R, t=np.stack([cam.t for cam in cams]), dist=dist,
                   size=np.array([cam.size for cam in cams], dtype=np.float64),
                   centres=c(np.stack([cam.centre for cam in cams]), dtype=np.float64),
                   back=c(np.swapaxes(R, 1, 2) @ np.linalg.inv(K), dtype=np.float64),
                   P=np.stack([cam.P for cam in cams]))


class PlaneArrays(NamedTuple):
    """P planes: point (P, 3) and unit normal (P, 3), float64."""

    point: np.ndarray
    normal: np.ndarray

    @classmethod
    def from_planes(cls, planes: Iterable) -> "PlaneArrays":
        """From :class:`~.plane.Plane` objects; a ``PlaneArrays`` is returned as it is."""
        if isinstance(planes, PlaneArrays):
            return planes
        planes = list(planes)
        return cls(np.array([pl.point for pl in planes], np.float64).reshape(-1, 3),
                   np.array([pl.normal for pl in planes], np.float64).reshape(-1, 3))
