"""Numpy reference of cascade+'s motion-predicting single-view tracker (the dense version before
its kernel): every track against every box of all views, one full assignment per frame."""

from __future__ import annotations

import numpy as np

from gymtrack.tracking.single_view import assign, corners, iou_corners


def motion_costs(tbox, tvel, has_vel, dt, box, speed_per_frame, noise, size_gate):
    """(T, N) offsets from the tracks' predictions (box heights) plus |log| height ratio, and the gate."""
    pred = tbox[:, :2] + np.where(has_vel[:, None], tvel, 0.0) * dt[:, None]
    h_t, h_n = tbox[:, 3][:, None], box[:, 3][None, :]
    off = np.hypot(pred[:, 0][:, None] - box[:, 0], pred[:, 1][:, None] - box[:, 1]) / np.sqrt(h_t * h_n)
    size = np.abs(np.log(h_n / h_t))
    reach = noise + np.where(has_vel, 0.5, 1.0) * speed_per_frame * dt
    return off + size, (off <= reach[:, None]) & (size <= size_gate)


class MotionIoUTrackerNumpy:
    """The tracker's state and update in numpy (defaults of :mod:`gymtrack.tracking.single_view_motion`)."""

    def __init__(self, fps, iou_threshold=0.1, max_age=2, speed=1.0, noise=0.1, size_gate=0.3, smoothing=0.5):
        self.iou_threshold, self.max_age, self.speed_per_frame = iou_threshold, max_age, speed / fps
        self.noise, self.size_gate, self.smoothing = noise, size_gate, smoothing
        self.counts = dict.fromkeys(("links_2d_overlap", "links_2d_motion", "tracks_2d_started", "tracks_2d_lost"), 0)
        self.box, self.vel, self.has_vel = np.zeros((0, 4)), np.zeros((0, 2)), np.zeros(0, bool)
        self.camera, self.last, self.track_id, self.next_id = np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64), 0

    def update(self, frame, camera, box):
        camera, box = np.asarray(camera, np.int64), np.asarray(box, np.float64).reshape(-1, 4)
        alive = frame - self.last <= self.max_age + 1
        self.counts["tracks_2d_lost"] += int(np.count_nonzero(~alive))
        self.box, self.vel, self.has_vel = self.box[alive], self.vel[alive], self.has_vel[alive]
        self.camera, self.last, self.track_id = self.camera[alive], self.last[alive], self.track_id[alive]
        ids = np.full(len(box), -1, np.int64)
        if len(self.track_id) and len(box):
            same = self.camera[:, None] == camera[None, :]
            dt = (frame - self.last).astype(np.float64)
            overlap = same & (iou_corners(corners(self.box, self.camera), corners(box, camera)) >= self.iou_threshold)
            cost, inside = motion_costs(self.box, self.vel, self.has_vel, dt, box, self.speed_per_frame, self.noise,
                                        self.size_gate)
            r, c = assign(1.0 / (1.0 + cost), same & inside)
            if len(r):
                n_overlap = int(np.count_nonzero(overlap[r, c]))
                self.counts["links_2d_overlap"] += n_overlap
                self.counts["links_2d_motion"] += len(r) - n_overlap
                v = (box[c, :2] - self.box[r, :2]) / dt[r][:, None]
                a = np.where(self.has_vel[r], self.smoothing, 1.0)[:, None]
                self.vel[r] = a * v + (1.0 - a) * self.vel[r]
                self.has_vel[r] = True
                self.box[r], self.last[r] = box[c], frame
                ids[c] = self.track_id[r]
        new = np.flatnonzero(ids < 0)
        ids[new] = self.next_id + np.arange(len(new))
        self.next_id += len(new)
        self.counts["tracks_2d_started"] += len(new)
        self.box = np.concatenate([self.box, box[new]])
        self.vel = np.concatenate([self.vel, np.zeros((len(new), 2))])
        self.has_vel = np.concatenate([self.has_vel, np.zeros(len(new), bool)])
        self.camera = np.concatenate([self.camera, camera[new]])
        self.last = np.concatenate([self.last, np.full(len(new), frame, np.int64)])
        self.track_id = np.concatenate([self.track_id, ids[new]])
        return ids
