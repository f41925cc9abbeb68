"""``Detections``: the columnar type of the first level, person boxes from all views.

Paper: Section III-A, a box ``b_{t,c,i} = [x, y, w, h]`` (centre form) at frame ``t`` in view
``c``. One row per box, one numpy array per column; no Python object per box.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np


@dataclass(frozen=True, eq=False)
class Detections:
    """N boxes from one or more cameras, as parallel arrays.

    Attributes
    ----------
    frame: (N,) int64, the frame numbers of the input files.
    camera: (N,) int16, index into ``camera_names``.
    box: (N, 4) float64, centre form ``[x, y, w, h]`` in pixels.
    score: (N,) float32, detector confidence (1 where the file gives none).
    track_id: (N,) int64, a tracklet or track id; -1 for raw detections.
    camera_names: names of the cameras, in rig order.
    """

    frame: np.ndarray
    camera: np.ndarray
    box: np.ndarray
    score: np.ndarray
    track_id: np.ndarray
    camera_names: tuple[str, ...]

    def __post_init__(self) -> None:
        n = len(self.frame)
        for name in ("camera", "box", "score", "track_id"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"Detections column {name!r} has {len(getattr(self, name))} rows, frame has {n}")
        if self.box.ndim != 2 or self.box.shape[1] != 4:
            raise ValueError(f"Detections.box must be (N, 4), got {self.box.shape}")

    # ---------------------------------------------------------------- construction
    @classmethod
    def empty(cls, camera_names: Sequence[str]) -> "Detections":
        return cls(
            np.zeros(0, np.int64), np.zeros(0, np.int16), np.zeros((0, 4)), np.zeros(0, np.float32),
            np.zeros(0, np.int64), tuple(camera_names),
        )

    @classmethod
    def of_columns(cls, frame, camera, box, score, track_id, camera_names: tuple[str, ...]) -> "Detections":
        """Detections from columns already of the dtypes and lengths above (rows selected from a
        valid ``Detections``, the tracker's own outputs): no conversion, no check (hot paths)."""
        new = object.__new__(cls)
        # (a frozen dataclass's __init__ sets each field through object.__setattr__: slower)
        new.__dict__.update(frame=frame, camera=camera, box=box, score=score, track_id=track_id,
                            camera_names=camera_names)
        return new

    @classmethod
    def from_arrays(
        cls,
        frame,
        camera,
        box,
        camera_names: Sequence[str],
        score=None,
        track_id=None,
    ) -> "Detections":
        frame = np.asarray(frame, dtype=np.int64).reshape(-1)
        n = frame.size
        return cls(
            frame,
            np.asarray(camera, dtype=np.int16).reshape(-1) if np.ndim(camera) else np.full(n, camera, np.int16),
            np.asarray(box, dtype=np.float64).reshape(n, 4),
            np.ones(n, np.float32) if score is None else np.asarray(score, dtype=np.float32).reshape(-1),
            np.full(n, -1, np.int64) if track_id is None else np.asarray(track_id, dtype=np.int64).reshape(-1),
            tuple(camera_names),
        )

    @classmethod
    def concat(cls, parts: Sequence["Detections"]) -> "Detections":
        if not parts:
            raise ValueError("concat needs at least one Detections")
        names = parts[0].camera_names
        for p in parts[1:]:
            if p.camera_names != names:
                raise ValueError(f"cannot concat Detections of cameras {names} and {p.camera_names}")
        return cls(
            np.concatenate([p.frame for p in parts]),
            np.concatenate([p.camera for p in parts]),
            np.concatenate([p.box for p in parts]),
            np.concatenate([p.score for p in parts]),
            np.concatenate([p.track_id for p in parts]),
            names,
        )

    # ---------------------------------------------------------------- access
    def __len__(self) -> int:
        return len(self.frame)

    def select(self, index) -> "Detections":
        """Rows by boolean mask, integer index or slice."""
        # every column indexed alike keeps the row counts equal: nothing to check again
        return Detections.of_columns(
            self.frame[index], self.camera[index], self.box[index], self.score[index], self.track_id[index], self.camera_names
        )

    def sorted(self) -> "Detections":
        """Rows ordered by (frame, camera), stable."""
        order = np.lexsort((self.camera, self.frame))
        return self.select(order)

    def for_camera(self, camera: int | str) -> "Detections":
        c = self.camera_names.index(camera) if isinstance(camera, str) else camera
        return self.select(self.camera == c)

    @property
    def frames(self) -> np.ndarray:
        """Sorted unique frame numbers."""
        return np.unique(self.frame)

    @property
    def tlwh(self) -> np.ndarray:
        """(N, 4) ``[left, top, width, height]`` (MOTChallenge form)."""
        b = self.box
        return np.column_stack([b[:, 0] - b[:, 2] / 2, b[:, 1] - b[:, 3] / 2, b[:, 2], b[:, 3]])

    @property
    def centre(self) -> np.ndarray:
        return self.box[:, :2]

    @property
    def top(self) -> np.ndarray:
        """(N, 2) top-centre points."""
        return np.column_stack([self.box[:, 0], self.box[:, 1] - self.box[:, 3] / 2])

    @property
    def bottom(self) -> np.ndarray:
        """(N, 2) bottom-centre points."""
        return np.column_stack([self.box[:, 0], self.box[:, 1] + self.box[:, 3] / 2])

    def counts_per_camera(self) -> dict[str, int]:
        c = np.bincount(self.camera.astype(np.int64), minlength=len(self.camera_names))
        return {n: int(c[i]) for i, n in enumerate(self.camera_names)}

    def __repr__(self) -> str:
        fr = f"frames {self.frame.min()}..{self.frame.max()}" if len(self) else "empty"
        return f"Detections({len(self)} boxes, {len(self.camera_names)} cameras, {fr})"


def tlwh_to_xywh(tlwh: np.ndarray) -> np.ndarray:
    """(..., 4) ``[left, top, w, h]`` -> (..., 4) centre form ``[x, y, w, h]``."""
    tlwh = np.asarray(tlwh, dtype=np.float64)
    out = tlwh.copy()
    out[..., 0] += tlwh[..., 2] / 2
    out[..., 1] += tlwh[..., 3] / 2
    return out


def xywh_to_tlwh(xywh: np.ndarray) -> np.ndarray:
    """(..., 4) centre form -> (..., 4) ``[left, top, w, h]``."""
    xywh = np.asarray(xywh, dtype=np.float64)
    out = xywh.copy()
    out[..., 0] -= xywh[..., 2] / 2
    out[..., 1] -= xywh[..., 3] / 2
    return out
