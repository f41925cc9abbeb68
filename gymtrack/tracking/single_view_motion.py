"""Beyond the paper (``cascade+``): a single-view tracker that predicts motion.

The paper's per-view tracker (Section III-A, :class:`.single_view.IoUTracker`) continues a 2D
track only with a box that overlaps its last one. At a low frame rate (WILDTRACK's 2 fps: a
walker moves ~0.7 m, often more than their own width, between frames) or for a fast person the
boxes of one person in consecutive frames do not overlap, and the view's 2D track breaks into
pieces of 1-3 boxes that windows drop (``min_tracklet_boxes``).

:class:`MotionIoUTracker` is SORT-like (Bewley et al. 2016, without the appearance and with a
light filter): each live 2D track keeps its last box and a smoothed image velocity of its box
centre; a track and a box of its view may be linked when
the box centre lies near the track's *predicted* centre (last centre + velocity x frames since),
in units of the box height (so one gate serves near and far people): at most
``noise + speed / fps x dt`` for a track without a velocity yet (how far a person can move),
``noise + 0.5 x speed / fps x dt`` for one with a velocity (how far they can deviate from it),
and the box heights differ by at most a factor ``exp(size_gate)``. Each frame is one assignment
(:func:`.single_view.assign`) minimising the summed offset from the prediction (plus the |log|
height ratio). Overlap with the last box is *not* a link by itself: when people move more than
their width between frames it hands tracks to neighbours (on WILDTRACK, allowing it too gave
MOTA 0.68 instead of 0.72, measured before the duplicate step of :mod:`.exclusion`).

When (:func:`needs_motion`): the gates are in body heights per second and scale with the frame
rate (``Scene.fps``). Where a person cannot move farther between frames than the prediction noise
(``speed / fps <= noise``; 30 fps: 0.03 body heights a frame) overlap is a reliable cue and the
tracker keeps the paper's :class:`~.single_view.IoUTracker`: on the simulated suite (30 fps) this
tracker used anyway raised the target's failure rate (FR, n_cam = 2 / 3 / 4: 17.8 / 7.0 / 2.4 %
-> 28.9 / 8.2 / 3.9 %; it hands the fast gymnast's track to nearby boxes). WILDTRACK (2 fps: 0.5
body heights a frame) gets it.

What it trades: a wider gate links what IoU could not (fewer broken 2D tracks) but in a crowd can
hand a track to a neighbour (an ID switch inside the 2D track that later stages see as one
person); ``speed`` sets how fast a new track may move, ``noise`` what prediction error (box jitter,
posture) is tolerated. Velocities are smoothed (``smoothing``: weight of the newest measurement).
On WILDTRACK (400 frames, seed 0, before the duplicate step) MOTA stayed within 0.70-0.73 over
speed 0.8-1.2, noise 0.07-0.15 and smoothing 0.3-0.7: the defaults are not a sharp optimum.

A frame is two compiled calls (:mod:`._kernels.single_view_motion`: ``motion_frame``,
``motion_commit``; ``keep_live`` too when a track ages out): a view's tracks are compared with
that view's boxes only, and the assignment sees only the tracks and boxes in conflict, so a frame
costs what the views' people cost (in WILDTRACK's crowd 0.2-0.26 ms a frame instead of 1.2-1.4
for every track against every box of all views).

Counted (``counts``): ``links_2d_overlap`` (links whose boxes also overlap: the paper's tracker
could have made them), ``links_2d_motion`` (the others: what the paper's tracker could not link),
``tracks_2d_started`` and ``tracks_2d_lost`` (live tracks that aged out).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ._kernels.single_view_motion import keep_live, motion_commit, motion_frame
from .single_view import with_conflicts

#: body heights per second a box centre may move (1.7 m/s for a 1.7 m person: a brisk walk)
SPEED = 1.0
#: body heights: the prediction error always tolerated (box jitter, posture changes)
NOISE = 0.1
#: |log| of the box-height ratio a link may have
SIZE_GATE = 0.3
#: weight of the newest velocity measurement
SMOOTHING = 0.5


def needs_motion(fps: float, speed: float = SPEED, noise: float = NOISE) -> bool:
    """Whether a person may move farther between frames (``speed / fps`` body heights) than the
    prediction noise: then overlap stops being a reliable cue and :class:`MotionIoUTracker` is
    used; below (30 fps: 0.03 body heights a frame) the paper's IoU tracker is kept as it is."""
    return speed / fps > noise


COUNTS = ("links_2d_overlap", "links_2d_motion", "tracks_2d_started", "tracks_2d_lost")


class MotionIoUTracker:
    """Per-view 2D tracks of all cameras linked by predicted motion (module docstring).

    Same interface as :class:`.single_view.IoUTracker` (``update``, ``len``, ``next_id``).

    Parameters
    ----------
    fps: frames per second of the video (``Scene.fps``); the motion gate scales with 1 / fps.
    iou_threshold: the paper's overlap test, here only to count the links it could have made;
    max_age: frames a track survives without a box (as the paper's tracker).
    speed, noise, size_gate, smoothing: see the module constants.
    counts: counter dict (``COUNTS``), or None.
    """

    def __init__(self, fps: float, iou_threshold: float = 0.1, max_age: int = 2, speed: float = SPEED,
                 noise: float = NOISE, size_gate: float = SIZE_GATE, smoothing: float = SMOOTHING,
                 counts: dict | None = None):
        for name, v in (("fps", fps), ("speed", speed), ("noise", noise), ("size_gate", size_gate)):
            if not np.isfinite(v) or v <= 0:
                raise InputError(f"{name} must be a positive number, got {v!r}", field=name)
        if not 0 < iou_threshold < 1:
            raise InputError(f"iou_threshold must lie in (0, 1), got {iou_threshold!r}", field="iou_threshold")
        if not 0 < smoothing <= 1:
            raise InputError(f"smoothing must lie in (0, 1], got {smoothing!r}", field="smoothing")
        if int(max_age) < 0:
            raise InputError(f"max_age must be >= 0, got {max_age!r}", field="max_age")
        self.iou_threshold, self.max_age = float(iou_threshold), int(max_age)
        self.speed_per_frame = float(speed) / float(fps)
        self.noise, self.size_gate, self.smoothing = float(noise), float(size_gate), float(smoothing)
        self.counts = counts if counts is not None else dict.fromkeys(COUNTS, 0)
        self.box = np.zeros((0, 4))
        self.vel = np.zeros((0, 2))
        self.has_vel = np.zeros(0, bool)
        self.camera = np.zeros(0, np.int64)
        self.last = np.zeros(0, np.int64)
        self.track_id = np.zeros(0, np.int64)
        self.next_id = 0

    def __len__(self) -> int:
        return len(self.track_id)

    def update(self, frame: int, camera: np.ndarray, box: np.ndarray) -> np.ndarray:
        """Link one frame's boxes to tracks. frame: increasing; camera: (N,) camera index; box:
        (N, 4) centre-form boxes. Returns (N,) int64 2D track ids."""
        camera = np.ascontiguousarray(camera, dtype=np.int64)
        box = np.ascontiguousarray(np.asarray(box, dtype=np.float64).reshape(-1, 4))
        state = (self.box, self.vel, self.has_vel, self.camera, self.last, self.track_id)
        if len(self.last) and self.last.min() < frame - self.max_age - 1:
            state = keep_live(*state, int(frame), self.max_age)
            self.counts["tracks_2d_lost"] += len(self.last) - len(state[5])
        r = c = np.zeros(0, np.int64)
        if len(state[5]) and len(box):
            r, c, crow, ccol, cost, sub, overlap = motion_frame(
                state[0], state[1], state[2], state[3], (frame - state[4]).astype(np.float64), camera, box,
                self.speed_per_frame, self.noise, self.size_gate, self.iou_threshold)
            r, c = with_conflicts(r, c, crow, ccol, cost, sub)  # the least summed offset, on the conflicts only
            by_overlap = int(np.count_nonzero(overlap[r, c]))
            self.counts["links_2d_overlap"] += by_overlap
            self.counts["links_2d_motion"] += len(r) - by_overlap
        *state, ids, self.next_id = motion_commit(*state, self.next_id, int(frame), camera, box, r, c, self.smoothing)
        self.box, self.vel, self.has_vel, self.camera, self.last, self.track_id = state
        self.counts["tracks_2d_started"] += len(box) - len(r)
        return ids
