"""``Poses2D`` and ``Poses3D``: the columnar types of the pose stage.

The paper (Yang et al.) tracks the gymnast as a box and a 3D centre (Sections III-A to III-D);
the pose stage adds the joints: 2D poses a pose model finds in each view (inside the target's
expanded box ``b_buf`` of Eq. 14, or read from ``keypoints/<camera>.json``), and the 3D pose
lifted from them per (frame, track). One row per pose, one numpy array per column, like
:class:`gymtrack.detections.Detections`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Sequence

import numpy as np

from .skeletons import Skeleton

HOW_NONE, HOW_TRIANGULATED, HOW_PLANE, HOW_FUSED = 0, 1, 2, 3
#: names of the ``Poses3D.how`` codes, indexed by code
HOW_NAMES = ("none", "triangulated", "plane", "fused")


def _check_rows(obj, n: int, columns: Sequence[str]) -> None:
    for name in columns:
        if len(getattr(obj, name)) != n:
            raise ValueError(f"{type(obj).__name__} column {name!r} has {len(getattr(obj, name))} rows, frame has {n}")


def _check_parts(parts, what: str, key) -> None:
    if not parts:
        raise ValueError(f"concat needs at least one {what}")
    for p in parts[1:]:
        if key(p) != key(parts[0]):
            raise ValueError(f"cannot concat {what} of {key(parts[0])} and {key(p)}")


@dataclass(eq=False)
class Poses2D:
    """N 2D poses found by a pose model, each in one view.

    Attributes
    ----------
    frame: (N,) int64, the input's frame numbers.
    camera: (N,) int64, index into ``camera_names``.
    track_id: (N,) int64, the 3D track the pose belongs to; -1 = not assigned.
    keypoints: (N, J, 3) float64 ``[x, y, score]`` in raw (distorted) pixels; score 0 or NaN x/y =
        joint not found.
    bbox: (N, 4) float64 ``[left, top, w, h]``, the box the model ran on; a NaN row if unknown.
    skeleton: the joint layout (J joints).
    camera_names: names of the cameras, in rig order.
    """

    frame: np.ndarray
    camera: np.ndarray
    track_id: np.ndarray
    keypoints: np.ndarray
    bbox: np.ndarray
    skeleton: Skeleton
    camera_names: tuple[str, ...]

    def __post_init__(self) -> None:
        self.frame = np.asarray(self.frame, dtype=np.int64).reshape(-1)
        n = len(self.frame)
        self.camera = np.asarray(self.camera, dtype=np.int64).reshape(-1)
        self.track_id = np.asarray(self.track_id, dtype=np.int64).reshape(-1)
        self.keypoints = np.asarray(self.keypoints, dtype=np.float64)
        self.bbox = np.asarray(self.bbox, dtype=np.float64)
        self.camera_names = tuple(self.camera_names)
        _check_rows(self, n, ("camera", "track_id", "keypoints", "bbox"))
        J = len(self.skeleton.joints)
        if self.keypoints.shape != (n, J, 3):
            raise ValueError(f"Poses2D.keypoints must be (N, {J}, 3), got {self.keypoints.shape}")
        if self.bbox.shape != (n, 4):
            raise ValueError(f"Poses2D.bbox must be (N, 4), got {self.bbox.shape}")

    @classmethod
    def empty(cls, skeleton: Skeleton, camera_names: Sequence[str]) -> "Poses2D":
        J = len(skeleton.joints)
        z = np.zeros(0, np.int64)
        return cls(z, z.copy(), z.copy(), np.zeros((0, J, 3)), np.zeros((0, 4)), skeleton, tuple(camera_names))

    @classmethod
    def concat(cls, parts: Sequence["Poses2D"]) -> "Poses2D":
        """Rows of all ``parts`` in order; they must share skeleton and cameras."""
        _check_parts(parts, "Poses2D", lambda p: (p.skeleton, p.camera_names))
        cols = ("frame", "camera", "track_id", "keypoints", "bbox")
        return cls(*(np.concatenate([getattr(p, c) for p in parts]) for c in cols),
                   parts[0].skeleton, parts[0].camera_names)

    def __len__(self) -> int:
        return len(self.frame)

    def subset(self, index) -> "Poses2D":
        """Rows by boolean mask or integer index."""
        return Poses2D(self.frame[index], self.camera[index], self.track_id[index], self.keypoints[index],
                       self.bbox[index], self.skeleton, self.camera_names)

    def sorted(self) -> "Poses2D":
        """Rows ordered by (frame, camera), stable."""
        return self.subset(np.lexsort((self.camera, self.frame)))

    def found(self) -> np.ndarray:
        """(N, J) bool: the joint was found (score > 0 and finite x, y)."""
        k = self.keypoints
        return (k[..., 2] > 0) & np.isfinite(k[..., 0]) & np.isfinite(k[..., 1])

    def __repr__(self) -> str:
        fr = f"frames {self.frame.min()}..{self.frame.max()}" if len(self) else "empty"
        return f"Poses2D({len(self)} poses, {self.skeleton.name}, {len(self.camera_names)} cameras, {fr})"


@dataclass(eq=False)
class Poses3D:
    """M 3D poses, one per (frame, track).

    Attributes
    ----------
    frame: (M,) int64.
    track_id: (M,) int64.
    xyz: (M, J, 3) float64 world metres; NaN = not estimated.
    score: (M, J) float64 in [0, 1].
    n_views: (M, J) int64, the views that contributed.
    reproj_px: (M, J) float64, mean reprojection error over those views (NaN if none).
    how: (M, J) int8, one of ``HOW_NONE`` (0), ``HOW_TRIANGULATED`` (1), ``HOW_PLANE`` (2, ray-plane
        only), ``HOW_FUSED`` (3, rays and plane weighted by uncertainty); names in ``HOW_NAMES``.
    skeleton: the joint layout (J joints).
    """

    frame: np.ndarray
    track_id: np.ndarray
    xyz: np.ndarray
    score: np.ndarray
    n_views: np.ndarray
    reproj_px: np.ndarray
    how: np.ndarray
    skeleton: Skeleton

    HOW_NAMES: ClassVar[tuple[str, ...]] = HOW_NAMES

    def __post_init__(self) -> None:
        self.frame = np.asarray(self.frame, dtype=np.int64).reshape(-1)
        n = len(self.frame)
        self.track_id = np.asarray(self.track_id, dtype=np.int64).reshape(-1)
        self.xyz = np.asarray(self.xyz, dtype=np.float64)
        self.score = np.asarray(self.score, dtype=np.float64)
        self.n_views = np.asarray(self.n_views, dtype=np.int64)
        self.reproj_px = np.asarray(self.reproj_px, dtype=np.float64)
        self.how = np.asarray(self.how, dtype=np.int8)
        _check_rows(self, n, ("track_id", "xyz", "score", "n_views", "reproj_px", "how"))
        J = len(self.skeleton.joints)
        if self.xyz.shape != (n, J, 3):
            raise ValueError(f"Poses3D.xyz must be (M, {J}, 3), got {self.xyz.shape}")
        for name in ("score", "n_views", "reproj_px", "how"):
            if getattr(self, name).shape != (n, J):
                raise ValueError(f"Poses3D.{name} must be (M, {J}), got {getattr(self, name).shape}")

    @classmethod
    def empty(cls, skeleton: Skeleton) -> "Poses3D":
        J = len(skeleton.joints)
        z = np.zeros(0, np.int64)
        return cls(z, z.copy(), np.zeros((0, J, 3)), np.zeros((0, J)), np.zeros((0, J), np.int64),
                   np.zeros((0, J)), np.zeros((0, J), np.int8), skeleton)

    @classmethod
    def concat(cls, parts: Sequence["Poses3D"]) -> "Poses3D":
        """Rows of all ``parts`` in order; they must share the skeleton."""
        _check_parts(parts, "Poses3D", lambda p: p.skeleton)
        cols = ("frame", "track_id", "xyz", "score", "n_views", "reproj_px", "how")
        return cls(*(np.concatenate([getattr(p, c) for p in parts]) for c in cols), parts[0].skeleton)

    def __len__(self) -> int:
        return len(self.frame)

    def subset(self, index) -> "Poses3D":
        """Rows by boolean mask or integer index."""
        return Poses3D(self.frame[index], self.track_id[index], self.xyz[index], self.score[index],
                       self.n_views[index], self.reproj_px[index], self.how[index], self.skeleton)

    def sorted(self) -> "Poses3D":
        """Rows ordered by (frame, track_id), stable."""
        return self.subset(np.lexsort((self.track_id, self.frame)))

    def __repr__(self) -> str:
        fr = f"frames {self.frame.min()}..{self.frame.max()}" if len(self) else "empty"
        return f"Poses3D({len(self)} poses, {self.skeleton.name}, {fr})"
