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

from .linking import link, member, tracklet_ends
from .single_view import IoUTracker
from .types import WindowTracklets, WindowTracklets3D

FRAMES = 3  #: boxes of a new 2D track compared with the prediction (it drifts with time)
GATE = 1.0  #: mean box-centre offset from the projected prediction, in box widths / heights
COUNTS = ("links_3d_motion", "new_2d_tracks_unlinked")


def first_boxes(frame: np.ndarray, track2d: np.ndarray, box: np.ndarray, ids: np.ndarray, n: int
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The first ``n`` boxes of each 2D track ``ids`` (T,) among rows frame (N,), track2d (N,),
    box (N, 4) (centre form). Returns frames (T, n), boxes (T, n, 4), valid (T, n) bool."""
    T = len(ids)
    f_out, b_out, ok = np.zeros((T, n), np.int64), np.full((T, n, 4), np.nan), np.zeros((T, n), bool)
    rows = np.flatnonzero(member(track2d, ids))
    rows = rows[np.lexsort((frame[rows], track2d[rows]))]  # by track, then frame
    which = np.searchsorted(ids, track2d[rows])  # ids sorted
    rank = np.arange(len(rows)) - np.searchsorted(track2d[rows], track2d[rows])  # position within its track
    use = rank < n
    which, rank, rows = which[use], rank[use], rows[use]
    f_out[which, rank], b_out[which, rank], ok[which, rank] = frame[rows], box[rows], True
    return f_out, b_out, ok


def motion_distances(P: np.ndarray, old_camera: np.ndarray, old_frame: np.ndarray, old_xyz: np.ndarray,
                     old_velocity: np.ndarray, frames: np.ndarray, boxes: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """(L, T) mean normalised offset between the new tracks' boxes and the old tracks' projected
    predictions. P: (C, 3, 4); old_camera, old_frame: (L,) the view and last frame of each 3D
    track's end point old_xyz (L, 3), moving at old_velocity (L, 3) metres per frame; frames
    (T, n), boxes (T, n, 4) centre form, ok (T, n): the new tracks' first boxes. NaN where a
    prediction falls behind the camera."""
    dt = frames[None] - old_frame[:, None, None]  # (L, T, n)
    X = old_xyz[:, None, None, :] + old_velocity[:, None, None, :] * dt[..., None]  # (L, T, n, 3)
    Pc = P[old_camera]  # (L, 3, 4)
    h = np.einsum("lij,ltnj->ltni", Pc[..., :3], X) + Pc[:, None, None, :, 3]  # (L, T, n, 3)
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = h[..., :2] / h[..., 2:3]
        off = (uv - boxes[None, ..., :2]) / boxes[None, ..., 2:]
        d = np.linalg.norm(off, axis=-1)  # (L, T, n)
        d = np.where(ok[None] & (h[..., 2] > 0), d, np.nan)
        bad = (np.isnan(d) & ok[None]).any(axis=-1)  # a box with no prediction in front of the camera
        out = np.nansum(np.where(ok[None], d, 0.0), axis=-1) / ok.sum(axis=-1)[None]
    out[bad | ~ok.any(axis=-1)[None]] = np.nan
    return out


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
        self.P, self.step_frames, self.width = np.asarray(P, np.float64), int(step), int(width)
        self.max_gap, self.max_speed, self.counts, self.gate = int(max_gap), float(max_speed), counts, float(gate)
        self.start: int | None = None  # the previous window's start
        # per (tracklet, view) of the previous window: camera, the view's 2D track (-1: none
        # yet), its last observed frame, the 3D track, and the tracklet's end: frame, xyz, velocity
        self.ends: tuple[np.ndarray, ...] = ()
        self.view_track: dict[int, np.ndarray] = {}  # live 3D track -> (C,) its 2D track per view

    def __len__(self) -> int:
        return (len(self.ends[0]) if self.ends else 0) + len(self.view_track)

    def remember(self, cur: WindowTracklets3D, segs: WindowTracklets) -> None:
        """The linked tracklets (M, W) of a window and its segments (``members`` index them)."""
        self.start = cur.start
        M, C = cur.members.shape
        if not M:
            self.ends, self.view_track = (), {}
            return
        lf, lx, lv = tracklet_ends(cur.xyz, cur.valid, cur.start, self.max_speed)
        has = cur.members >= 0
        s = np.maximum(cur.members, 0)
        obs = segs.observed[s] if len(segs) else np.zeros((M, C, cur.valid.shape[1]), bool)  # (M, C, W)
        last_obs = np.where(has, segs.start + obs.shape[-1] - 1 - np.argmax(obs[..., ::-1], axis=-1), -1 << 40)
        ids = segs.track2d[s] if len(segs) else np.zeros((M, C), np.int64)
        # a view without a member keeps the 2D track it had (or adopted) before
        before = np.stack([self.view_track.get(t, np.full(C, -1, np.int64)) for t in cur.track_id.tolist()])
        ids = np.where(has, ids, before)
        self.view_track = dict(zip(cur.track_id.tolist(), ids))
        m = np.repeat(np.arange(M), C)
        self.ends = (np.tile(np.arange(C), M), ids.ravel(), last_obs.ravel(), cur.track_id[m], lf[m], lx[m], lv[m])

    def step(self, start: int, rows: dict, iou: IoUTracker, seen: np.ndarray) -> None:
        """Before the window at ``start`` is cut: its new 2D tracks that continue a 3D track's
        lost view are renamed (in ``rows``, the :class:`~.records.BoxTable` columns, and in the
        IoU tracker). ``seen``: the 2D tracks of the previous window's segments."""
        frame, track2d = rows["frame"], rows["track2d"]
        fresh_from = start + self.width - self.step_frames  # frames no earlier window covered
        inwin = (frame >= start) & (frame < start + self.width)
        ids, first_at = np.unique(track2d[inwin], return_index=True)  # rows are in frame order
        new = ids[(frame[inwin][first_at] >= fresh_from) & ~member(ids, seen)]
        linked = 0
        if len(new) and self.ends and self.start == start - self.step_frames:
            linked = self._link(new, frame, track2d, rows, iou)
        self.counts["links_3d_motion"] += linked
        self.counts["new_2d_tracks_unlinked"] += len(new) - linked

    def _link(self, new: np.ndarray, frame: np.ndarray, track2d: np.ndarray, rows: dict, iou: IoUTracker) -> int:
        t_all = self.ends[1]
        _, keep = np.unique(np.where(t_all >= 0, t_all, -1 - np.arange(len(t_all))), return_index=True)
        cam_o, t_o, last_o, tid, lf, lx, lv = (a[keep] for a in self.ends)  # one entry per old 2D track
        linked = 0
        for _ in range(self.step_frames):  # a track broken again in one window: the next piece joins in the next round
            # the old track's last box: in the rows still held, else where the previous window saw it
            last = last_o.copy()
            held = member(track2d, t_o[t_o >= 0])
            if held.any():
                known = np.flatnonzero(t_o >= 0)
                order = known[np.argsort(t_o[known])]
                np.maximum.at(last, order[np.searchsorted(t_o[order], track2d[held])], frame[held])
            frames, boxes, ok = first_boxes(frame, track2d, rows["ubox"], new, FRAMES)
            cam_n = np.zeros(len(new), np.int64)
            at = member(track2d, new)
            cam_n[np.searchsorted(new, track2d[at])] = rows["camera"][at]
            D = motion_distances(self.P, cam_o, lf, lx, lv, frames, boxes, ok)
            gap = frames[:, 0][None, :] - last[:, None]  # (L, T); a view with no 2D track yet: any
            late = ((gap < 1) | (gap > self.max_gap + 1)) & (t_o >= 0)[:, None]
            D[(cam_o[:, None] != cam_n[None, :]) | late] = np.nan
            r, c = link(D, self.gate)
            if not len(r):
                break
            old = t_o[r]
            adopt = old < 0  # the view's first 2D track of this 3D track: kept as it is
            for k in np.flatnonzero(adopt).tolist():
                t_o[r[k]] = new[c[k]]
                self.view_track[int(tid[r[k]])][cam_o[r[k]]] = new[c[k]]
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
