"""Checks of a routine's detection stream: silent cameras, gaps, boxes outside the image.

Paper: the input of Section III-A is synchronised boxes from every view; these checks find
what silently degrades it: a view that stops delivering boxes (the cascade then works with
fewer views), frame ranges where no view has a box (tracks break there), and boxes that lie
outside the calibrated image (the image size or the camera order of the calibration does not
match the detections). Cost is O(N log N) in the boxes and never depends on the frame range.

Frames are the input's numbers; a silence or gap ``first..last`` (inclusive) is a run of
frames without boxes inside the routine's range ``[min frame, max frame]`` of all cameras.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..detections import Detections
from ..geometry.camera import Rig

#: Default for "goes silent": no boxes for more than this many seconds.
SILENT_SECONDS = 5.0
#: A box edge this many pixels beyond the image border counts as "partly outside".
EDGE_TOLERANCE_PX = 2.0
#: Warn when more than this share of a camera's boxes is partly outside its image.
PARTLY_OUTSIDE_WARN = 0.10


@dataclass(frozen=True)
class Span:
    """Frames ``first..last`` (inclusive) without boxes; ``camera`` None = no camera has any."""

    first: int
    last: int
    camera: str | None = None

    @property
    def frames(self) -> int:
        return self.last - self.first + 1


@dataclass(frozen=True)
class StreamChecks:
    """What :func:`check_detections` found.

    Attributes
    ----------
    frame_range: (first, last) frame of all boxes, or None without boxes.
    frames_with_data: number of distinct frames carrying at least one box.
    silences: per-camera spans longer than the threshold (not inside a common gap).
    gaps: spans longer than the threshold where no camera has a box.
    outside: camera -> share of its boxes lying wholly outside its image.
    partly_outside: camera -> share of its boxes reaching more than ``EDGE_TOLERANCE_PX`` beyond the border.
    boxes: camera -> number of boxes.
    fps: frames per second the spans are converted to seconds with.
    """

    frame_range: tuple[int, int] | None
    frames_with_data: int
    silences: tuple[Span, ...]
    gaps: tuple[Span, ...]
    outside: dict[str, float]
    partly_outside: dict[str, float]
    boxes: dict[str, int]
    fps: float

    def warnings(self) -> list[str]:
        """One-line messages for everything worth a warning."""
        out = []
        for g in self.gaps:
            out.append(f"no camera has detections in frames {g.first}..{g.last} ({g.frames} frames, "
                       f"{g.frames / self.fps:.1f} s): tracks break there")
        for s in self.silences:
            out.append(f"camera {s.camera} goes silent: no detections in frames {s.first}..{s.last} ({s.frames} frames, "
                       f"{s.frames / self.fps:.1f} s)")
        for cam, share in self.outside.items():
            if share > 0:
                out.append(f"{share:.1%} of camera {cam}'s boxes lie wholly outside its image: check the image size "
                           "and camera names of the calibration")
            elif self.partly_outside[cam] > PARTLY_OUTSIDE_WARN:
                out.append(f"{self.partly_outside[cam]:.1%} of camera {cam}'s boxes reach beyond its image border: "
                           "check the image size of the calibration")
        return out


def _spans(frames: np.ndarray, lo: int, hi: int, min_frames: float) -> list[tuple[int, int]]:
    """Runs of missing frames in ``lo..hi`` between the sorted unique ``frames``, longer than ``min_frames``."""
    edges = np.concatenate([[lo - 1], frames, [hi + 1]])
    d = np.diff(edges)
    k = np.flatnonzero(d - 1 > min_frames)
    return [(int(edges[i] + 1), int(edges[i + 1] - 1)) for i in k]


def check_detections(detections: Detections, rig: Rig, fps: float, silent_seconds: float = SILENT_SECONDS) -> StreamChecks:
    """Silences, gaps and boxes outside the image of every camera of ``rig``.

    ``detections.camera`` indexes ``rig``; a camera is silent when it has no box for more than
    ``silent_seconds`` (``fps`` frames a second) while the routine goes on.
    """
    names = rig.names
    min_frames = silent_seconds * fps
    boxes = {n: 0 for n in names}
    outside = {n: 0.0 for n in names}
    partly = {n: 0.0 for n in names}
    if len(detections) == 0:
        return StreamChecks(None, 0, (), (), outside, partly, boxes, fps)
    frame = detections.frame
    lo, hi = int(frame.min()), int(frame.max())
    all_frames = np.unique(frame)
    gaps = [Span(a, b) for a, b in _spans(all_frames, lo, hi, min_frames)]
    silences = []
    for c, name in enumerate(names):
        sel = detections.camera == c
        boxes[name] = int(sel.sum())
        for a, b in _spans(np.unique(frame[sel]), lo, hi, min_frames):
            if not any(g.first <= a and b <= g.last for g in gaps):
                silences.append(Span(a, b, name))
        if not boxes[name]:
            continue
        w, h = rig[c].size
        x, y, bw, bh = detections.box[sel].T
        left, right, top, bottom = x - bw / 2, x + bw / 2, y - bh / 2, y + bh / 2
        wholly = (right < 0) | (left > w) | (bottom < 0) | (top > h)
        t = EDGE_TOLERANCE_PX
        beyond = (left < -t) | (top < -t) | (right > w + t) | (bottom > h + t)
        outside[name] = float(wholly.mean())
        partly[name] = float(beyond.mean())
    return StreamChecks((lo, hi), int(all_frames.size), tuple(silences), tuple(gaps), outside, partly, boxes, fps)
