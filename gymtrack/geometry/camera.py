"""Pinhole cameras with OpenCV lens distortion, and a rig of them.

Paper: Section III-B (projection matrix ``P_c = K_c [R_c | t_c]``) and Eq. 5-6 (the world-space
ray through a pixel). Conventions (``shared/formats.md``): the world is right-handed, z up,
metres; extrinsics map world to camera, ``X_cam = R @ X_world + t``; the camera centre is
``C = -R.T @ t``; camera axes x right, y down, z forward; pixels are those of the raw
(distorted) image.

Design choice: projection with distortion is written out in numpy (vectorised, no per-point
calls) so it can be checked against ``cv2.projectPoints``; undistortion, which needs an
iterative inverse, is delegated to OpenCV.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Iterable, Iterator, Sequence

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import CalibrationError
from .arrays import RigArrays

_ROTATION_TOL = 1e-5


def _as_float_array(value, shape: tuple[int, ...], what: str, name: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise CalibrationError(f"{what} must be numeric, got {value!r}", field=f"{name}") from exc
    if arr.shape != shape:
        raise CalibrationError(f"{what} must have shape {shape}, got {arr.shape}", field=name)
    if not np.all(np.isfinite(arr)):
        raise CalibrationError(f"{what} contains NaN or infinity", field=name)
    return arr


@dataclass(frozen=True, eq=False)
class Camera:
    """One calibrated camera.

    Attributes
    ----------
    name: camera name, used to pair calibration with ``detections/<name>.txt``.
    size: ``(width, height)`` in pixels.
    K: (3, 3) intrinsic matrix ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]``.
    R: (3, 3) world-to-camera rotation (proper: orthonormal, det +1).
    t: (3,) world-to-camera translation, metres.
    dist: (k,) OpenCV distortion ``k1, k2, p1, p2[, k3[, k4, k5, k6]]``; zeros = none.

    Construction validates everything and raises :class:`CalibrationError` naming the field.
    """

    name: str
    size: tuple[int, int]
    K: np.ndarray
    R: np.ndarray
    t: np.ndarray
    dist: np.ndarray = field(default_factory=lambda: np.zeros(5))

    def __post_init__(self) -> None:
        n = self.name
        if not isinstance(n, str) or not n:
            raise CalibrationError(f"camera name must be a non-empty string, got {n!r}", field="name")
        try:
            w, h = (int(v) for v in self.size)
        except (TypeError, ValueError) as exc:
            raise CalibrationError(f"size must be [width, height], got {self.size!r}", field=f"{n}.size") from exc
        if w <= 0 or h <= 0:
            raise CalibrationError(f"size must be positive, got {self.size!r}", field=f"{n}.size")
        K = _as_float_array(self.K, (3, 3), "K", f"{n}.K")
        R = _as_float_array(self.R, (3, 3), "R", f"{n}.R")
        t_raw = np.ravel(self.t) if np.ndim(self.t) == 2 else self.t  # accept (3, 1) column vectors
        t = _as_float_array(t_raw, (3,), "t", f"{n}.t")
        dist = np.ravel(np.asarray(self.dist if self.dist is not None else np.zeros(5), dtype=np.float64))
        if dist.size not in (0, 4, 5, 8):
            raise CalibrationError(f"dist must have 4, 5 or 8 coefficients, got {dist.size}", field=f"{n}.dist")
        if not np.all(np.isfinite(dist)):
            raise CalibrationError("dist contains NaN or infinity", field=f"{n}.dist")
        dist = np.concatenate([dist, np.zeros(5 - dist.size)]) if dist.size < 5 else dist
        if abs(K[2, 2] - 1.0) > 1e-9 or abs(K[2, 0]) > 1e-9 or abs(K[2, 1]) > 1e-9 or abs(K[1, 0]) > 1e-9:
            raise CalibrationError(f"K must have last row [0, 0, 1] and K[1,0] = 0, got {K.tolist()}", field=f"{n}.K")
        if K[0, 0] <= 0 or K[1, 1] <= 0:
            raise CalibrationError(
                f"K is singular or mirrored: focal lengths fx={K[0, 0]}, fy={K[1, 1]} must be positive", field=f"{n}.K"
            )
        err = np.abs(R @ R.T - np.eye(3)).max()
        if err > _ROTATION_TOL:
            raise CalibrationError(f"R is not a rotation: R @ R.T differs from I by {err:.3g}", field=f"{n}.R")
        det = np.linalg.det(R)
        if det < 0:
            raise CalibrationError(f"R is a reflection (det = {det:.3f}), not a rotation", field=f"{n}.R")
        for attr, val in (("size", (w, h)), ("K", K), ("R", R), ("t", t), ("dist", dist)):
            if isinstance(val, np.ndarray):
                val.setflags(write=False)
            object.__setattr__(self, attr, val)

    # ----------------------------------------------------------------- derived quantities
    @property
    def centre(self) -> np.ndarray:
        """(3,) camera centre in world coordinates, ``C = -R.T @ t``."""
        return -self.R.T @ self.t

    @property
    def P(self) -> np.ndarray:
        """(3, 4) projection matrix ``K [R | t]`` (of the undistorted image)."""
        return self.K @ np.hstack([self.R, self.t[:, None]])

    @property
    def optical_axis(self) -> np.ndarray:
        """(3,) unit viewing direction (camera +z) in world coordinates."""
        return self.R[2].copy()

    @property
    def has_distortion(self) -> bool:
        return bool(np.any(self.dist != 0))

    @property
    def rvec(self) -> np.ndarray:
        """(3,) Rodrigues vector of ``R``."""
        # not cv2.Rodrigues: it returns 0 for rotations below 1e-5 rad
        return Rotation.from_matrix(self.R).as_rotvec()

    # ----------------------------------------------------------------- operations
    def to_camera(self, X: np.ndarray) -> np.ndarray:
        """World points ``(..., 3)`` -> camera-frame points ``(..., 3)``."""
        X = np.asarray(X, dtype=np.float64)
        return X @ self.R.T + self.t

    def depth(self, X: np.ndarray) -> np.ndarray:
        """Depth (camera z) of world points ``(..., 3)`` -> ``(...)``; negative = behind."""
        return self.to_camera(X)[..., 2]

    def project(self, X: np.ndarray, distort: bool = True) -> np.ndarray:
        """Project world points to pixels.

        Parameters
        ----------
        X: (..., 3) world points, metres.
        distort: apply the lens distortion (pixels of the raw image). False gives pixels of the
            ideal undistorted image with the same ``K``.

        Returns
        -------
        (..., 2) pixel coordinates; NaN for points on or behind the camera plane.
        """
        Xc = self.to_camera(X)
        z = Xc[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.where(z > 1e-12, Xc[..., 0] / z, np.nan)
            y = np.where(z > 1e-12, Xc[..., 1] / z, np.nan)
        if distort and self.has_distortion:
            x, y = _distort_normalised(x, y, self.dist)
        K = self.K
        u = K[0, 0] * x + K[0, 1] * y + K[0, 2]
        v = K[1, 1] * y + K[1, 2]
        return np.stack([u, v], axis=-1)

    def undistort(self, uv: np.ndarray) -> np.ndarray:
        """Raw-image pixels ``(..., 2)`` -> pixels of the ideal undistorted image ``(..., 2)``.

        Identity when the camera has no distortion. Uses ``cv2.undistortPointsIter`` with a
        tight stopping rule (OpenCV's default 5 iterations leave pixel-level errors at the
        image corners).
        """
        uv = np.asarray(uv, dtype=np.float64)
        if not self.has_distortion or uv.size == 0:
            return uv.copy()
        flat = uv.reshape(-1, 1, 2)
        out = np.full_like(flat, np.nan)
        ok = np.all(np.isfinite(flat), axis=-1)[:, 0]
        if ok.any():
            crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12)
            out[ok] = cv2.undistortPointsIter(flat[ok], self.K, self.dist, None, self.K, crit)
        return out.reshape(uv.shape)

    def rays(self, uv: np.ndarray, undistort: bool = True) -> np.ndarray:
        """World-space unit ray directions through pixels (paper Eq. 5-6).

        Parameters
        ----------
        uv: (..., 2) pixels.
        undistort: the pixels are raw-image pixels and are undistorted first.

        Returns
        -------
        (..., 3) unit vectors from the camera centre towards the pixel, world frame.
        ``{}^w v = R^T K^{-1} [u, v, 1]^T`` (Eq. 6 writes the same as a row vector times R).
        """
        uv = self.undistort(uv) if undistort else np.asarray(uv, dtype=np.float64)
        K = self.K
        y = (uv[..., 1] - K[1, 2]) / K[1, 1]
        x = (uv[..., 0] - K[0, 2] - K[0, 1] * y) / K[0, 0]
        v_cam = np.stack([x, y, np.ones_like(x)], axis=-1)
        v_world = v_cam @ self.R  # row-vector form of R.T @ v
        return v_world / np.linalg.norm(v_world, axis=-1, keepdims=True)

    def in_image(self, uv: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """(..., 2) pixels -> (...) bool, inside the image grown by ``margin`` pixels."""
        w, h = self.size
        uv = np.asarray(uv)
        return (
            (uv[..., 0] >= -margin) & (uv[..., 0] <= w + margin) & (uv[..., 1] >= -margin) & (uv[..., 1] <= h + margin)
        )

    def with_name(self, name: str) -> "Camera":
        return Camera(name, self.size, self.K, self.R, self.t, self.dist)

    def __repr__(self) -> str:
        c = self.centre
        return f"Camera({self.name!r}, size={self.size}, f=({self.K[0, 0]:.1f}, {self.K[1, 1]:.1f}), centre=({c[0]:.2f}, {c[1]:.2f}, {c[2]:.2f}))"


def look_at(centre: np.ndarray, target: np.ndarray, roll: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Extrinsics of a camera at ``centre`` (3,) looking at ``target`` (3,), world z up.

    Camera axes x right, y down, z forward (the image's top stays up); ``roll`` (radians) turns
    the camera about its optical axis. Returns ``(R (3, 3), t (3,))`` with ``X_cam = R X + t``.
    """
    centre = np.asarray(centre, dtype=np.float64)
    z = np.asarray(target, dtype=np.float64) - centre
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    c, s = np.cos(roll), np.sin(roll)
    R = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.stack([x, y, z])
    return R, -R @ centre


def _distort_normalised(x: np.ndarray, y: np.ndarray, dist: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """OpenCV's radial-tangential (and rational, with 8 coefficients) model on normalised coords."""
    k1, k2, p1, p2, k3 = dist[:5]
    k4, k5, k6 = (dist[5:8] if dist.size >= 8 else (0.0, 0.0, 0.0))
    r2 = x * x + y * y
    radial = (1 + k1 * r2 + k2 * r2**2 + k3 * r2**3) / (1 + k4 * r2 + k5 * r2**2 + k6 * r2**3)
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return xd, yd


class Rig(Sequence[Camera]):
    """An ordered set of cameras with unique names; index by position or by name.

    The order is the camera index used in every columnar array (``Detections.camera``...).
    """

    def __init__(self, cameras: Iterable[Camera]):
        self._cameras: tuple[Camera, ...] = tuple(cameras)
        names = [c.name for c in self._cameras]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise CalibrationError(f"camera names must be unique, repeated: {dup}", field="cameras")
        if not self._cameras:
            raise CalibrationError("a rig needs at least one camera", field="cameras")
        self._index = {n: i for i, n in enumerate(names)}

    def __len__(self) -> int:
        return len(self._cameras)

    def __iter__(self) -> Iterator[Camera]:
        return iter(self._cameras)

    def __getitem__(self, key):  # type: ignore[override]
        if isinstance(key, str):
            try:
                return self._cameras[self._index[key]]
            except KeyError:
                raise KeyError(f"no camera named {key!r}; the rig has {list(self._index)}") from None
        return self._cameras[key]

    def index(self, name: str) -> int:  # type: ignore[override]
        """Position of the camera called ``name``."""
        if name not in self._index:
            raise KeyError(f"no camera named {name!r}; the rig has {list(self._index)}")
        return self._index[name]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self._cameras)

    @property
    def centres(self) -> np.ndarray:
        """(C, 3) camera centres."""
        return np.stack([c.centre for c in self._cameras])

    @property
    def projections(self) -> np.ndarray:
        """(C, 3, 4) projection matrices of the undistorted images."""
        return np.stack([c.P for c in self._cameras])

    @cached_property
    def arrays(self) -> RigArrays:
        """The calibration as contiguous arrays for compiled kernels, built once per rig."""
        return RigArrays.from_cameras(self._cameras)

    def subset(self, names: Sequence[str]) -> "Rig":
        return Rig(self[n] for n in names)

    def __repr__(self) -> str:
        return f"Rig({list(self.names)})"
