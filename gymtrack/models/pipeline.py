"""Models over a routine's videos: detections for every frame, poses in the tracker's boxes.

Paper: Section III-A (the detector on every frame of every synchronised view) and III-D (the
top-down pose model on the crops of ``b_buf`` from the full-resolution frames). The frames of
all cameras are decoded together (:class:`gymtrack.formats.video.VideoSet`, the next frame while
the model runs on this one) and go through the model as one batch. A video smaller than its
camera's calibration (same aspect) is read as is; boxes and keypoints are scaled to the
calibration's pixels (``VideoSet.pixel_scale``). Time per step is kept in a
:class:`StepTimes`; frames and boxes left out are counted, never dropped silently.
"""

from __future__ import annotations

import time
from collections import defaultdict
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..detections import Detections
from ..formats.video import VideoSet
from ..poses import Poses2D
from .detector import Detector
from .pose import PoseModel

__all__ = ["StepTimes", "DetectRun", "PoseRun", "detect_videos", "pose_videos"]

Progress = Callable[[int, int], None]


@dataclass
class StepTimes:
    """Seconds per step (decode, prepare, model, decode output...), summed over frames."""

    seconds: dict[str, float] = field(default_factory=lambda: defaultdict(float))

    def add(self, step: str, t0: float) -> float:
        t = time.perf_counter()
        self.seconds[step] += t - t0
        return t

    def ms_per_frame(self, frames: int) -> dict[str, float]:
        return {k: 1000 * v / max(frames, 1) for k, v in self.seconds.items()}


@dataclass
class DetectRun:
    """What :func:`detect_videos` made: the boxes, counts and times."""

    detections: Detections
    frames: int = 0
    skipped_frames: int = 0       # frames numbered below 1 (a camera's offset), not in MOTChallenge files
    missing_images: int = 0       # (frame, camera) pairs without an image (a shorter video, an offset)
    times: StepTimes = field(default_factory=StepTimes)
    video_faults: dict = field(default_factory=dict)  # camera -> VideoFaults: dropped, repeated, corrupt frames


@dataclass
class PoseRun:
    """What :func:`pose_videos` made: the 2D poses, counts and times."""

    poses: Poses2D
    boxes: int = 0
    no_image: int = 0             # boxes whose frame the camera's video lacks
    times: StepTimes = field(default_factory=StepTimes)


def detect_videos(videos: VideoSet, detector: Detector, frames=None, progress: Progress | None = None) -> DetectRun:
    """Run ``detector`` on every frame (default: every frame any video holds, numbered 1 or more).

    Returns the boxes as raw :class:`Detections` (centre form, ``track_id`` -1, camera = rig order).
    """
    all_frames = videos.frame_numbers if frames is None else np.asarray(frames, np.int64)
    todo = all_frames[all_frames >= 1]
    run = DetectRun(Detections.empty(videos.camera_names), skipped_frames=int((all_frames < 1).sum()))
    tm = run.times
    fr_col, cam_col, box_col, score_col = [], [], [], []
    t = time.perf_counter()
    for n, (frame, images) in enumerate(videos.iter_frames(todo)):
        t = tm.add("decode", t)
        cams = [c for c, im in enumerate(images) if im is not None]
        run.missing_images += len(images) - len(cams)
        if cams:
            ims = [images[c] for c in cams]
            blob, lbs = detector.prepare(ims)
            t = tm.add("letterbox", t)
            out = detector.infer(blob)
            t = tm.add("detector", t)
            for c, (xyxy, s) in zip(cams, detector.decode(out, lbs, [im.shape[:2] for im in ims])):
                xyxy = xyxy * videos.pixel_scale[c]  # video -> calibration pixels
                fr_col.append(np.full(len(s), frame))
                cam_col.append(np.full(len(s), c))
                box_col.append(np.column_stack([(xyxy[:, :2] + xyxy[:, 2:]) / 2, xyxy[:, 2:] - xyxy[:, :2]]))
                score_col.append(s)
            t = tm.add("output decoding", t)
        run.frames += 1
        if progress is not None:
            progress(n + 1, len(todo))
        t = time.perf_counter()  # the caller's time is not ours
    if fr_col:
        run.detections = Detections.from_arrays(np.concatenate(fr_col), np.concatenate(cam_col),
                                                np.concatenate(box_col).reshape(-1, 4), videos.camera_names,
                                                score=np.concatenate(score_col))
    run.video_faults = {c: f for c, f in videos.faults().items() if f}
    return run


def pose_videos(videos: VideoSet, model: PoseModel, boxes: Detections, progress: Progress | None = None) -> PoseRun:
    """Run the pose model on ``boxes`` (e.g. the target's b_buf, tlwh from the track outputs).

    ``boxes.camera`` must index ``videos.camera_names`` (rig order). Every frame's crops, all
    views and tracks, go through the model together.
    """
    boxes = boxes.sorted()
    run = PoseRun(Poses2D.empty(model.skeleton, videos.camera_names), boxes=len(boxes))
    tm = run.times
    frames = np.unique(boxes.frame)
    starts = np.searchsorted(boxes.frame, frames)
    ends = np.searchsorted(boxes.frame, frames, side="right")
    parts = []
    t = time.perf_counter()
    for n, (frame, images) in enumerate(videos.iter_frames(frames)):
        t = tm.add("decode", t)
        b = boxes.select(slice(starts[n], ends[n]))
        have = np.array([images[int(c)] is not None for c in b.camera], bool)
        run.no_image += int((~have).sum())
        b = b.select(have)
        if len(b):
            scale = videos.pixel_scale[b.camera.astype(np.int64)]
            blob, M = model.prepare(images, b.camera.astype(np.int64), b.tlwh / scale[:, None])  # type: ignore[arg-type]
            t = tm.add("crops", t)
            out = model.infer(blob)
            t = tm.add("pose model", t)
            kp = model.decode(out, M)
            kp[..., :2] *= scale[:, None, None]  # video -> calibration pixels
            parts.append(Poses2D(np.full(len(b), frame), b.camera, b.track_id, kp, b.tlwh, model.skeleton,
                                 videos.camera_names))
            t = tm.add("output decoding", t)
        if progress is not None:
            progress(n + 1, len(frames))
        t = time.perf_counter()
    if parts:
        run.poses = Poses2D.concat(parts)
    return run
