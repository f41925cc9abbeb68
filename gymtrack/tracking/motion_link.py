"""Beyond the paper (issue 12, item 2; ``cascade+``): a view's 2D tracks linked by 3D motion.

The per-view IoU tracker (paper III-A) continues a track only with a box that overlaps its last
one. At a low frame rate (WILDTRACK's 2 fps) or for a fast person the boxes of one person in
consecutive frames do not overlap, and the view's 2D track breaks into pieces, each too short
for a window (``min_tracklet_boxes``, Section III-A) or clustered apart from the person's other
views (Eq. 1-2). Here, when a window is cut, a 2D track that is *new* in it (its first box lies
in the frames the previous window did not cover) continues the 2D track that a 3D track of the
previous window had in that view when

* that old 2D track ended before the new one starts (the view lost the person), at most
  ``max_gap`` frames before (the tracker passes ``max_age``: the gap the IoU tracker itself
  would have bridged, had the boxes overlapped; longer gaps are re-linking's, :mod:`.linking`),
  or the 3D track never had a 2D track in that view (the new one is then adopted as it is), and
* the new track's first ``FRAMES`` boxes lie close to the projection (``P``, undistorted
  pixels) of the 3D track's constant-velocity prediction (:func:`.linking.tracklet_ends`):
  the mean offset of the box centre from the projected body centre, in box widths (x) and
  heights (y), at most ``gate``;

one-to-one, by a linear assignment (:func:`.linking.link`). The new id is renamed to the old
one in the boxes not yet final and in the IoU tracker, so this window and every later one cut
one 2D track: Eq. 2 clustering, cross-window linking (Eq. 10-11) and the one-view plane
continuation all see the person's view as one track.

Counted in ``counts``: ``links_3d_motion`` (new 2D tracks continued by 3D motion) and
``new_2d_tracks_unlinked`` (new 2D tracks no 3D track's motion explained: what neither the
per-view tracker nor this stage could link).
"""

from __future__ import annotations

import numpy as np

from ._kernels import motion_link as kernels
from .linking import link
from .single_view import IoUTracker
from .types import WindowTracklets, WindowTracklets3D

FRAMES = 3  #: boxes of a new 2D track compared with the prediction (it drifts with time)
GATE = 1.0  #: mean box-centre offset from the projected prediction, in box widths / heights
COUNTS = ("links_3d_motion", "new_2d_tracks_unlinked")


class MotionLinker:
    """The 2D tracks a view's IoU tracker broke, joined again by 3D motion (module docstring).

    P: (C, 3, 4) undistorted projections; step: frames between window starts; width: frames
    per window; max_gap: frames the view may have lost the person; max_speed: metres per frame
    (clips the velocity); counts: counter dict; gate: see :data:`GATE`.

    Use: ``step(start, rows, iou, seen)`` when a window is cut (before its segments are built),
    ``remember(linked, segs)`` once it is linked. State: one entry per (3D tracklet, view) of
    the previous window (bounded by the people in view).
    """

    def __init__(self, P: np.ndarray, step: int, width: int, max_gap: int, max_speed: float, counts: dict,
                 gate: float = GATE):
        self.P, self.step_frames, self.width = np.ascontiguousarray(P, np.float64), int(step), int(width)
        self.max_gap, self.max_speed, self.counts, self.gate = int(max_gap), float(max_speed), counts, float(gate)
        self.start: int | None = None  # the previous window's start
        # the previous window's tracklets (M): the views C, per (tracklet, view) the view's 2D
        # track (-1: none yet) and its last observed frame (M, C), the 3D track, and the
        # tracklet's end: frame, xyz, velocity
        self.ends: tuple = ()
        # the previous window's 3D tracks (P,) and per view their 2D track (P, C) (-1: none)
        self.view_ids, self.view_track = np.zeros(0, np.int64), np.zeros((0, 0), np.int64)

    def __len__(self) -> int:
        return (self.ends[1].size if self.ends else 0) + len(self.view_track)

    def remember(self, cur: WindowTracklets3D, segs: WindowTracklets) -> None:
        """The linked tracklets (M, W) of a window and its segments (``members`` index them)."""
        self.start = cur.start
        M, C = cur.members.shape
        if not M:
            self.ends, self.view_ids, self.view_track = (), np.zeros(0, np.int64), np.zeros((0, C), np.int64)
            return
        # (compiled, one call: tracklet_ends, the last observed frames, the views' 2D tracks and
        # what a view without a member keeps, :func:`._kernels.motion_link.remember`)
        lf, lx, lv, last_obs, ids, tid = kernels.remember(
            cur.xyz, cur.valid, cur.start, self.max_speed, cur.members, segs.observed, segs.start, segs.track2d,
            cur.track_id, self.view_ids, self.view_track)
        self.view_ids, self.view_track = tid, ids
        self.ends = (C, ids, last_obs, tid, lf, lx, lv)  # (spread per view only when a link is tried)

    def step(self, start: int, rows: dict, iou: IoUTracker, seen: np.ndarray) -> None:
        """Before the window at ``start`` is cut: its new 2D tracks that continue a 3D track's
        lost view are renamed (in ``rows``, the :class:`~.records.BoxTable` columns, and in the
        IoU tracker). ``seen``: the 2D tracks of the previous window's segments."""
        frame, track2d = rows["frame"], rows["track2d"]
        cam, ubox = rows["camera"], rows["ubox"]  # (int64, float64, C order: the BoxTable's columns)
        fresh_from = start + self.width - self.step_frames  # frames no earlier window covered
        # (compiled, one call: the rows are in frame order, a track's first row in the window its
        # first box; then the first round's costs, when the ends are the previous window's)
        ends_apply = bool(self.ends) and self.start == start - self.step_frames
        new, near = kernels.new_near(*(self.ends or self._no_ends(len(self.P))), frame, track2d, cam, ubox, start,
                                     start + self.width, fresh_from, np.ascontiguousarray(seen, np.int64), self.P,
                                     FRAMES, self.max_gap, self.gate, ends_apply)
        linked = self._link(new, frame, track2d, cam, ubox, iou) if near else 0  # (usually nothing is near)
        self.counts["links_3d_motion"] += linked
        self.counts["new_2d_tracks_unlinked"] += len(new) - linked

    @staticmethod
    def _no_ends(C: int) -> tuple:
        i = np.zeros(0, np.int64)
        return C, np.zeros((0, C), np.int64), np.zeros((0, C), np.int64), i, i, np.zeros((0, 3)), np.zeros((0, 3))

    def _link(self, new: np.ndarray, frame: np.ndarray, track2d: np.ndarray, cam: np.ndarray, ubox: np.ndarray,
              iou: IoUTracker) -> int:
        # one entry per old 2D track: its view, 2D track, last frame seen, 3D track and end (compiled)
        cam_o, t_o, last_o, tid, lf, lx, lv = kernels.old_entries(*self.ends)
        linked = 0
        for _ in range(self.step_frames):  # a track broken again in one window: the next piece joins in the next round
            # the old tracks' last boxes, the new ones' first boxes, the prediction's offset and
            # the view / gap gates: one compiled call (:func:`._kernels.motion_link.link_costs`)
            D = kernels.link_costs(frame, track2d, cam, ubox, new, cam_o, t_o, last_o, lf, lx, lv, self.P, FRAMES,
                                   self.max_gap)
            if not (D <= self.gate).any():  # nothing within the gate (NaN compares False): no link
                break
            r, c = link(D, self.gate)
            if not len(r):
                break
            old = t_o[r]
            adopt = old < 0  # the view's first 2D track of this 3D track: kept as it is
            for k in np.flatnonzero(adopt).tolist():
                t_o[r[k]] = new[c[k]]
                row = np.flatnonzero(self.view_ids == tid[r[k]])[-1]  # (its last row: as a dict of the rows)
                self.view_track[row, cam_o[r[k]]] = new[c[k]]
            ren = ~adopt
            for o, nw in zip(old[ren].tolist(), new[c[ren]].tolist()):
                track2d[track2d == nw] = o
            if ren.any():
                iou.rename(new[c[ren]], old[ren])
            linked += len(r)
            new = np.delete(new, c)
            if not len(new):
                break
        return linked
