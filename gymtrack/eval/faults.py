"""A venue's faults, made from a clean routine's detections (the benchmark's fault section, tests).

Beyond the paper. Each function takes the boxes (N,) of a routine and returns the boxes a
faulty venue would have given, with what it did; the ground truth stays the clean one.

- :func:`desync_camera`: one camera's frame numbers run ``frames`` ahead (it shows at frame
  ``f`` what the others show at ``f - frames``): a camera that started late, or whose clock is
  off. ``gymtrack sync`` should find ``frame_offsets = frames`` for it.
- :func:`knock_camera`: one camera turned by ``degrees`` about an axis through its centre from
  frame ``from_frame`` on (knocked, its calibration now wrong). A rotation about the centre moves
  every image point by the homography ``K R K^-1`` (Hartley & Zisserman 8.4.2), applied to the
  box centres in undistorted pixels (sizes kept: a degree changes them by well under 1 %).
- :func:`drop_frames`: a capture card dropping ``share`` of one camera's frames at random, the
  frame numbers of the rest kept (frames numbered by timestamp).
- :func:`.dropout.silence_camera`: a camera gone silent from a frame on.
"""

from __future__ import annotations

import cv2
import numpy as np

from ..detections import Detections
from ..geometry.camera import Camera
from ..tracking.drift import turn_pixels

__all__ = ["desync_camera", "knock_camera", "knock_rotation", "drop_frames"]


def desync_camera(det: Detections, camera: int, frames: int) -> Detections:
    """(N,) boxes with camera ``camera``'s frame numbers moved by ``+frames``; boxes moved before
    frame 1 are left out (the camera had not started). Sorted by (frame, camera)."""
    frame = det.frame + np.where(det.camera == camera, int(frames), 0)
    keep = np.flatnonzero(frame >= 1)
    out = Detections(frame, det.camera, det.box, det.score, det.track_id, det.camera_names)
    return out.select(keep).sorted()


def knock_rotation(degrees: float, seed: int = 0) -> np.ndarray:
    """(3, 3) a rotation by ``degrees`` about a random axis mostly across the optical axis (camera
    coordinates: a knock pans and tilts the camera more than it rolls it)."""
    rng = np.random.default_rng(seed)
    ang = rng.uniform(0, 2 * np.pi)
    axis = np.array([np.cos(ang), np.sin(ang), rng.uniform(-0.3, 0.3)])
    axis /= np.linalg.norm(axis)
    return cv2.Rodrigues(axis * np.radians(degrees))[0]


def knock_camera(det: Detections, cam: Camera, camera: int, from_frame: int, rotation: np.ndarray) -> Detections:
    """(N,) boxes with camera ``camera`` (``cam``, its calibration) turned by ``rotation`` (3, 3,
    camera coordinates) from ``from_frame`` on: the box centres moved by ``K R K^-1``."""
    m = np.flatnonzero((det.camera == camera) & (det.frame >= from_frame))
    box = det.box.copy()
    box[m, :2] = turn_pixels(cam, det.box[m, :2], rotation)
    return Detections(det.frame, det.camera, box, det.score, det.track_id, det.camera_names)


def drop_frames(det: Detections, camera: int, share: float, seed: int = 0) -> tuple[Detections, int]:
    """(N,) boxes without camera ``camera``'s boxes of a random ``share`` of its frames (frame
    numbers of the rest unchanged), and how many frames were dropped."""
    rng = np.random.default_rng(seed)
    frames = np.unique(det.frame[det.camera == camera])
    gone = rng.choice(frames, size=int(round(share * len(frames))), replace=False)
    drop = (det.camera == camera) & np.isin(det.frame, gone)
    return det.select(np.flatnonzero(~drop)), len(gone)
