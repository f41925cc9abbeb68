"""Person boxes from 2D poses, for a routine that has poses but no ``detections/`` (a Pose2Sim user).

Paper: the tracker's input is one box per person and view (Section III-A); a pose model that
ran on whole frames (OpenPose, RTMPose through Pose2Sim) found every person's joints, which bound
the person. Rule (``shared/formats.md``, routine folder): the boxes are derived from each pose's
confident joints, padded, and the summary says so.

A box spans the joints with score >= ``min_score`` (at least ``min_joints`` of them), grown by
``pad`` x its larger side left, right and up (the head's top lies above the eyes and ears, the
hands past the wrists) and by ``pad / 2`` down (the soles lie just below the ankles or heels).
Its score is the mean of those joints' scores, clipped to 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..detections import Detections
from ..poses import Poses2D
from .motchallenge import ReadReport

__all__ = ["PoseBoxes", "boxes_from_poses"]


@dataclass(frozen=True, eq=False)
class PoseBoxes:
    """Boxes made from poses; ``poses``: poses read, ``boxes``: boxes made, ``too_few_joints``:
    poses skipped for fewer than ``min_joints`` confident joints."""

    detections: Detections
    poses: int
    boxes: int
    too_few_joints: int
    min_score: float
    pad: float

    def describe(self) -> str:
        return (f"no detections/: {self.boxes} person boxes derived from the 2D poses' joints with score >= "
                f"{self.min_score:g}, padded by {self.pad:.0%}" + (f"; {self.too_few_joints} poses with fewer "
                                                                    "confident joints gave no box" if self.too_few_joints else ""))

    def reports(self, paths) -> tuple[ReadReport, ...]:
        """One :class:`ReadReport` per camera (``paths``: camera -> the poses' file or folder)."""
        d, out = self.detections, []
        for c, name in enumerate(d.camera_names):
            f = d.frame[d.camera == c]
            out.append(ReadReport(path=paths.get(name, name), camera=name, lines=int(f.size), boxes=int(f.size),
                                  frames=int(np.unique(f).size), frame_range=(int(f.min()), int(f.max())) if f.size else None,
                                  frame_zero_lines=int((f == 0).sum())))
        return tuple(out)


def boxes_from_poses(poses: Poses2D, min_score: float = 0.3, min_joints: int = 3, pad: float = 0.1) -> PoseBoxes:
    """Centre-form boxes ``[x, y, w, h]`` (raw pixels) of every pose with enough confident joints."""
    kp = poses.keypoints
    ok = (kp[..., 2] >= min_score) & np.isfinite(kp[..., 0]) & np.isfinite(kp[..., 1])
    keep = ok.sum(axis=1) >= min_joints
    x = np.where(ok, kp[..., 0], np.nan)[keep]
    y = np.where(ok, kp[..., 1], np.nan)[keep]
    lo_x, hi_x, lo_y, hi_y = np.nanmin(x, 1), np.nanmax(x, 1), np.nanmin(y, 1), np.nanmax(y, 1)
    s = np.maximum(np.maximum(hi_x - lo_x, hi_y - lo_y), 1.0)
    left, right, top, bottom = lo_x - pad * s, hi_x + pad * s, lo_y - pad * s, hi_y + 0.5 * pad * s
    box = np.column_stack([(left + right) / 2, (top + bottom) / 2, right - left, bottom - top])
    score = np.clip(np.nanmean(np.where(ok, kp[..., 2], np.nan)[keep], axis=1), 0.0, 1.0)
    det = Detections.from_arrays(poses.frame[keep], poses.camera[keep], box, poses.camera_names, score=score).sorted()
    return PoseBoxes(det, len(poses), int(keep.sum()), int((~keep).sum()), min_score, pad)
