"""Numpy reference of the single-view IoU tracker's kernels (paper Section III-A)."""

from __future__ import annotations

import numpy as np

from gymtrack.tracking.single_view import assign, corners, iou_corners


class IoUTrackerNumpy:
    """The IoU tracker before compilation: full IoU matrix over all cameras, one assignment."""

    def __init__(self, iou_threshold=0.1, max_age=2):
        self.iou_threshold, self.max_age = iou_threshold, max_age
        self.box, self.last, self.track_id, self.next_id = np.zeros((5, 0)), np.zeros(0, np.int64), np.zeros(0, np.int64), 0

    def update(self, frame, camera, box):
        if len(self.last) and self.last.min() < frame - self.max_age - 1:
            alive = frame - self.last <= self.max_age + 1
            self.box, self.last, self.track_id = self.box[:, alive], self.last[alive], self.track_id[alive]
        n = len(camera)
        cb = corners(box, camera)
        ids = np.full(n, -1, np.int64)
        if len(self.track_id) and n:
            iou = iou_corners(self.box, cb)
            r, c = assign(iou, iou >= self.iou_threshold)
            ids[c] = self.track_id[r]
            self.box[:, r] = cb[:, c]
            self.last[r] = frame
        new = np.flatnonzero(ids < 0)
        if len(new):
            new_ids = self.next_id + np.arange(len(new))
            self.next_id += len(new)
            ids[new] = new_ids
            self.box = np.concatenate([self.box, cb[:, new]], axis=1)
            self.last = np.concatenate([self.last, np.full(len(new), frame, np.int64)])
            self.track_id = np.concatenate([self.track_id, new_ids])
        return ids
