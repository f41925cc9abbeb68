"""Cross-window linking of 3D tracklets (paper Section III-B, Eq. 10-12).

Consecutive windows overlap by half a window. A 3D tracklet of the new window continues a
track of the previous window when their mean distance over the overlapping frames where both
are valid (Eq. 10) wins a linear assignment (Eq. 11, ``linear_sum_assignment``) and is at
most ``link_3d`` metres (paper: 0.6; larger bridges noisier estimates but may swap two people
standing close). Unlinked tracklets start new tracks. The merge of Eq. 12 -- the overlap
averaged -- happens when the frames are made final (:mod:`.tracker`), where every frame's
estimates of one track from the two windows covering it are averaged.

Beyond the paper: re-linking across short gaps. The paper links only consecutive windows, so
a person missing from one window's 3D tracklets (a few frames seen by one view only, or an
outlier window) comes back under a new track id, and the target must then be re-identified
by Eq. 13, which costs at least ``identify_frames / 2`` frames. A track that was not continued
stays *lost* for ``relink_frames`` frames; an unlinked new tracklet whose first point lies
within ``link_3d`` of the lost track's constant-velocity prediction continues it (again a
linear assignment, :func:`relink_distances` + :func:`link`). ``relink_frames = 0`` is the
paper's behaviour.

:class:`WindowLinker` applies this to a stream of windows and owns its state: the previous
window's linked tracklets and the 2D tracks they were made of, the live tracks' last frames,
the lost tracks (may still be re-linked) and the ended ones (for the target stage, Eq. 13).
Beyond the paper, a cascade here too: candidates of several views link first; one-view plane
tracklets only to what is left, and only to continue a track (never to start one). ``keep_older``
(beyond the paper): a duplicate track born beside an older one hands the older id on when linking
continued the duplicate instead (:meth:`WindowLinker._keep_older`).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from ._kernels import linking as kernels
from .types import Tracks3D, WindowTracklets3D, member


def link_distances(
    prev_xyz: np.ndarray,
    prev_valid: np.ndarray,
    new_xyz: np.ndarray,
    new_valid: np.ndarray,
    offset: int,
) -> np.ndarray:
    """Eq. 10: mean 3D distance of every (previous, new) tracklet pair over the overlap.

    prev_xyz: (Mp, W, 3), prev_valid: (Mp, W): the previous window's tracklets;
    new_xyz: (Mn, W, 3), new_valid: (Mn, W): the new window's, which starts ``offset`` frames
    later (the step). Returns (Mp, Mn) metres; NaN where the pair shares no valid frame.
    """
    c = np.ascontiguousarray
    return kernels.link_distances(c(prev_xyz, dtype=np.float64), c(prev_valid), c(new_xyz, dtype=np.float64),
                                  c(new_valid), int(offset))  # pairs x frames: a compiled loop


def link(D: np.ndarray, gate: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 11: minimum-cost one-to-one assignment of rows to columns among pairs with ``D <= gate``.

    D: (Mp, Mn), NaN = cannot link. Returns (rows, cols) of the links.
    """
    allowed = np.isfinite(D) & (D <= gate)
    if not allowed.any():
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    per_row, per_col = allowed.sum(axis=1), allowed.sum(axis=0)
    # a pair that is the only option of its row and of its column is in every optimum: linked
    # directly; the assignment only sees the rows and columns in conflict (usually none)
    lone = allowed & (per_row[:, None] == 1) & (per_col[None, :] == 1)
    r0, c0 = np.nonzero(lone)
    if len(r0) == np.count_nonzero(per_row):
        return r0, c0
    rows = np.flatnonzero(per_row > 0)
    rows = rows[~lone[rows].any(axis=1)]
    cols = np.flatnonzero(per_col > 0)
    cols = cols[~lone[:, cols].any(axis=0)]
    sub = allowed[rows][:, cols]  # (two takes: cheaper than np.ix_ on small matrices)
    # a disallowed pair costs more than any set of allowed ones could save
    big = 2.0 * gate * (min(len(rows), len(cols)) + 1) + 1.0
    cost = np.where(sub, D[rows][:, cols], big)
    r, c = linear_sum_assignment(cost)
    keep = sub[r, c]
    r, c = np.concatenate([r0, rows[r[keep]]]), np.concatenate([c0, cols[c[keep]]])
    order = np.argsort(r, kind="stable")
    return r[order], c[order]


def tracklet_ends(xyz: np.ndarray, valid: np.ndarray, start: int, max_speed: float) -> tuple[np.ndarray, ...]:
    """Where each 3D tracklet of a window ends, and how fast it was moving.

    xyz: (M, W, 3), valid: (M, W) (every row has a valid point), start: the window's first frame;
    max_speed: metres per frame, the velocity is clipped to it.
    Returns last_frame (M,), last_xyz (M, 3) and velocity (M, 3) in metres per frame, from the
    last valid point and the earliest valid point at most 4 frames before it (zero if none).
    """
    M, W = valid.shape
    t = np.arange(W)
    last = W - 1 - np.argmax(valid[:, ::-1], axis=1)
    early = np.where(valid & (t >= (last - 4)[:, None]), t, W).min(axis=1)
    rows = np.arange(M)
    dt = np.maximum(last - early, 1)
    vel = (xyz[rows, last] - xyz[rows, early]) / dt[:, None]
    speed = np.linalg.norm(vel, axis=1)
    vel *= np.minimum(1.0, max_speed / np.maximum(speed, 1e-12))[:, None]
    return start + last, xyz[rows, last].copy(), vel


def relink_distances(
    lost_frame: np.ndarray,
    lost_xyz: np.ndarray,
    lost_velocity: np.ndarray,
    new_xyz: np.ndarray,
    new_valid: np.ndarray,
    start: int,
    max_gap: int,
) -> np.ndarray:
    """Distance of every (lost track, new tracklet) pair for re-linking across a gap.

    lost_frame: (L,) last frame of each lost track; lost_xyz, lost_velocity: (L, 3) its last
    point and velocity (metres per frame); new_xyz: (Mn, W, 3), new_valid: (Mn, W): the new
    window's unlinked tracklets, starting at frame ``start``. The distance is between the new
    tracklet's first valid point and the lost track's constant-velocity prediction for that
    frame. Returns (L, Mn) metres; NaN where the gap (frames strictly between) is negative
    (the two overlap: plain linking already refused them) or longer than ``max_gap``.
    """
    L, Mn = len(lost_frame), len(new_xyz)
    if L == 0 or Mn == 0:
        return np.full((L, Mn), np.nan)
    first = np.argmax(new_valid, axis=1)
    f0 = start + first  # (Mn,)
    x0 = new_xyz[np.arange(Mn), first]  # (Mn, 3)
    dt = f0[None, :] - lost_frame[:, None]  # (L, Mn)
    pred = lost_xyz[:, None, :] + lost_velocity[:, None, :] * dt[..., None]
    D = np.linalg.norm(x0[None] - pred, axis=-1)
    D[(dt < 1) | (dt > max_gap + 1)] = np.nan
    return D


def merge_overlaps(
    frame: np.ndarray,
    track_id: np.ndarray,
    xyz: np.ndarray,
    top_z: np.ndarray,
    bottom_z: np.ndarray,
    source: np.ndarray,
    n_views: np.ndarray,
    best_only: bool = False,
) -> Tracks3D:
    """Eq. 12: one point per (frame, track) from the estimates of the windows covering it.

    All arguments are (N,) rows (``xyz`` (N, 3)), one per window estimate; estimates of the same
    (frame, track) -- a frame in the overlap of two linked tracklets -- are averaged (heights
    over the known ones). The merged source is the best of the parts (triangulation <
    plane < interpolated), ``n_views`` the largest. Returns rows sorted by (frame, track_id).

    ``best_only`` (the recipe's ``best_estimates``, beyond the paper): where one window's estimate is an
    over-determined triangulation (three or more views) it is the estimate; the rest are
    averaged as in Eq. 12. When one window triangulated three views of a person and the next
    had only an opposite pair on the plane or two views (a view's segment lost to a wrong
    cluster), the plain average carries half the weaker estimate's error into frames the
    triangulation had right (measured: the target's AED at n_cam = 3, 1.165 -> 1.15 x the
    oracle's). Trade: a wrong three-view cluster (an opposite pair plus a third view of someone
    else, which the pair's degenerate epipolar geometry cannot refuse) now wins over the pair's
    plane estimate instead of being averaged with it -- at n_cam = 2, where the target has no
    true third view, its AED rises by about 1 %; and a step between the windows' estimates is
    not smoothed over the overlap.
    """
    if len(frame) == 0:
        return Tracks3D.empty()
    return Tracks3D(*kernels.merge_overlaps(  # one compiled pass (numpy: tests/reference/linking.py)
        np.ascontiguousarray(frame, np.int64), np.ascontiguousarray(track_id, np.int64), np.ascontiguousarray(xyz, np.float64),
        np.ascontiguousarray(top_z, np.float64), np.ascontiguousarray(bottom_z, np.float64),
        np.ascontiguousarray(source, np.int8), np.ascontiguousarray(n_views, np.int8), bool(best_only)))


class WindowLinker:
    """Cross-window linking of a stream of windows (Eq. 10-11, re-linking, the two-pass cascade).

    window_step: frames between window starts; link_3d: the gate, metres; relink_frames: how
    long a lost track may be re-linked (0: the paper); max_speed: metres per frame, clips a lost
    track's velocity; counts: counter dict the links are counted in (``links``, ``relinks``,
    ``plane_single_view``, ``plane_single_view_unlinked``: the one-view tracklets, of the plane
    and, with the floor hypothesis, of the floor, that continued a track or were dropped).

    Use: ``linked = linker.step(tracklets, track2d, solo)`` once per window, in order.
    State: the previous window's tracklets (M, W), and one entry per live, lost or ended track
    (ended ones until the target stage forgets them).
    """

    def __init__(self, window_step: int, link_3d: float, relink_frames: int, max_speed: float, counts: dict,
                 floor_by_2d: bool = False, keep_older: bool = False):
        self.window_step, self.link_3d = int(window_step), float(link_3d)
        # a floor tracklet whose views' 2D tracks all belonged to one track of the previous window
        # continues it whatever its 3D distance (the hypothesis changed -- plane to floor after a
        # landing -- not the person)
        self.floor_by_2d = floor_by_2d
        self.keep_older = keep_older  # a young duplicate's continuation takes the older track's id
        self.prev_owner = np.zeros(0, np.int64)  # the track of each of prev_2d
        self.relink_frames, self.max_speed = int(relink_frames), max_speed
        self.counts = counts
        self.prev: WindowTracklets3D | None = None  # the previous window's linked tracklets
        self.next_track_id = 0
        self.track_last: dict[int, int] = {}  # live track -> last valid frame
        self.ended: dict[int, int] = {}  # ended track -> last frame (the target stage forgets them)
        # lost tracks (not continued, may still be re-linked): id -> (last frame, last xyz, velocity,
        # (C,) bool the views of its last tracklet)
        self.lost: dict[int, tuple[int, np.ndarray, np.ndarray, np.ndarray]] = {}
        # 2D track ids that were members of the previous window's 3D tracklets (single-view continuation)
        self.prev_2d = np.zeros(0, np.int64)
        self.prev_seen = np.zeros(0, np.int64)  # 2D tracks of the previous window's segments
        self._prev_first_new = 0  # the first track id the previous window started (younger ids: born there)

    def __len__(self) -> int:
        """Stored items: the previous window's (tracklet, frame) cells and the tracks' entries."""
        n = 0 if self.prev is None else self.prev.valid.size
        return n + len(self.track_last) + len(self.lost) + len(self.ended)

    @property
    def idle(self) -> bool:
        """No tracklet of the previous window to link to."""
        return self.prev is None or len(self.prev) == 0

    def break_chain(self) -> None:
        """The next window does not follow on the last one (a pause jumped over)."""
        self.prev = None

    def may_continue_alone(self, track2d: np.ndarray) -> np.ndarray:
        """(n,) bool: the 2D tracks (n,) that may continue a 3D track on the plane from one view:
        members of the previous window's 3D tracklets, or new in this window (a view's track broke)."""
        return member(track2d, self.prev_2d) | ~member(track2d, self.prev_seen)

    def step(self, cur: WindowTracklets3D, track2d: np.ndarray, solo: np.ndarray,
             floor: np.ndarray | None = None, own: np.ndarray | None = None) -> WindowTracklets3D:
        """Link one window's 3D tracklets to the tracks.

        cur: (M, W) the window's tracklets (``members`` index ``track2d``); track2d: (K,) the 2D
        track ids of the window's segments; solo: (M,) bool, one-view plane tracklets (they may
        only continue a track); floor: (M,) bool, tracklets that continue the track their 2D
        tracks belonged to whatever their 3D distance (``floor_by_2d``: the floor tracklets, and
        the recipe's ``rejoin``: the regrouped pairs); own: (M,)
        bool, one-view tracklets that may only continue the track their 2D track belonged to,
        within the gate (the recipe's ``rejoin``), after the tracklets of several views. Returns
        the linked tracklets, ``track_id`` set (new ids for the unlinked), unlinked one-view
        tracklets removed.
        """
        self._track2d, self._floor, self._own = track2d, floor, own
        ids = self._link(cur, solo)
        if self.keep_older and self.prev is not None and len(self.prev) and self.prev.start == cur.start - self.window_step:
            self._keep_older(ids)
        first_new = self.next_track_id
        new = ids < 0
        if solo.any():
            drop = solo & new
            self.counts["plane_single_view"] += int(np.count_nonzero(solo & ~new))
            self.counts["plane_single_view_unlinked"] += int(np.count_nonzero(drop))
            if drop.any():
                cur, ids, new = cur.subset(~drop), ids[~drop], new[~drop]
        ids[new] = self.next_track_id + np.arange(int(new.sum()))
        self.next_track_id += int(new.sum())
        cur = cur.with_track_id(ids)
        has = cur.members >= 0
        self.prev_2d = track2d[cur.members[has]]
        # (row-major, as prev_2d; cheaper than broadcast_to; the ghost test's confirmation reads it too)
        self.prev_owner = np.repeat(cur.track_id, has.sum(1))
        self.prev_seen = track2d
        self._prev_first_new = first_new
        self._end_tracks(cur)
        self.prev = cur
        return cur

    def _link(self, cur: WindowTracklets3D, solo: np.ndarray) -> np.ndarray:
        """(M,) the track each tracklet continues (-1: none): the two passes, each linking to the
        previous window (Eq. 10-11), then re-linking lost tracks."""
        start = cur.start
        ids = np.full(len(cur), -1, np.int64)
        prev = self.prev
        chained = prev is not None and len(prev) > 0 and prev.start == start - self.window_step
        if self.floor_by_2d and chained and self._floor is not None and self._floor.any() and len(self.prev_2d):
            self._link_by_2d(cur, ids)
        # a cascade here too: candidates of several views link first, one-view ones only to what is left
        own = np.zeros(len(cur), bool) if self._own is None else self._own
        for k, group in enumerate((~solo, solo) if solo.any() else (None,)):
            if k == 1 and own.any() and chained:  # one view of a dropped cluster: its own track or none
                self._link_own(cur, np.flatnonzero(own & (ids < 0)), ids)
            cols = np.flatnonzero((ids < 0) & ~own) if group is None else np.flatnonzero(group & (ids < 0) & ~own)
            # the first pass may link any previous tracklet, the second only those still free
            # (floor_by_2d: only once a link by 2D tracks took one)
            free = (np.flatnonzero(~member(prev.track_id, ids)) if k or (self.floor_by_2d and (ids >= 0).any())
                    else np.arange(len(prev))) if chained else []
            if len(cols) and len(free):
                r, c = link(link_distances(prev.xyz[free], prev.valid[free], cur.xyz[cols], cur.valid[cols],
                                           self.window_step), self.link_3d)
                ids[cols[c]] = prev.track_id[free[r]]
                self.counts["links"] += len(r)
                cols = cols[ids[cols] < 0]
            if self.lost and len(cols) and self.relink_frames > 0:  # beyond the paper: bridge short gaps
                self._relink(cur, cols, ids)
        return ids

    def _link_own(self, cur: WindowTracklets3D, rows: np.ndarray, ids: np.ndarray) -> None:
        """The ``own`` tracklets ``rows`` continue the previous window's track their 2D tracks
        belonged to, where it is within ``link_3d`` (Eq. 10) and still free (nearest first;
        written into ``ids``). A handful per window: a plain loop."""
        prev, taken, found = self.prev, set(ids[ids >= 0].tolist()), []
        for r in rows.tolist():
            m = cur.members[r]
            owner = np.unique(self.prev_owner[member(self.prev_2d, self._track2d[m[m >= 0]])])
            if len(owner) != 1 or int(owner[0]) in taken:
                continue
            i = np.flatnonzero(prev.track_id == owner[0])
            d = link_distances(prev.xyz[i], prev.valid[i], cur.xyz[r:r + 1], cur.valid[r:r + 1], self.window_step)[0, 0]
            if d <= self.link_3d:  # (NaN: no shared frame, no link)
                found.append((float(d), r, int(owner[0])))
        for _, r, owner in sorted(found):
            if owner not in taken:
                ids[r] = owner
                taken.add(owner)
                self.counts["links_own"] += 1

    def _keep_older(self, ids: np.ndarray) -> None:
        """``keep_older``: a track born in the previous window beside an older track (their tracklets
        there within ``link_3d``, Eq. 10 over the whole window) is a duplicate of it -- Algorithm 1
        split one person's views into two clusters. When linking continued the young duplicate
        and not the older track, the continuation takes the older id (written into ``ids``); the
        young one is lost. Trade: two people who really met within ``link_3d`` of each other while
        one of them had just appeared may swap ids."""
        prev = self.prev
        older = prev.track_id < self._prev_first_new
        if older.all() or not older.any():  # no young track, or none older: nothing to merge
            return
        on = member(prev.track_id, ids[ids >= 0])
        old, young = np.flatnonzero(~on & older), np.flatnonzero(on & ~older)
        if not len(old) or not len(young):
            return
        r, c = link(link_distances(prev.xyz[old], prev.valid[old], prev.xyz[young], prev.valid[young], 0), self.link_3d)
        for o, y in zip(prev.track_id[old[r]].tolist(), prev.track_id[young[c]].tolist()):
            ids[ids == y] = o
        self.counts["links_older"] += len(r)

    def _link_by_2d(self, cur: WindowTracklets3D, ids: np.ndarray) -> None:
        """Floor tracklets of two or more views whose 2D tracks all belonged to one previous track
        (one tracklet per track: the first) continue it (written into ``ids``)."""
        rows = np.flatnonzero(self._floor & ((cur.members >= 0).sum(1) >= 2))
        if len(rows):  # one compiled loop (numpy: tests/reference/linking.py)
            self.counts["links_2d"] += kernels.link_by_2d(
                rows, np.ascontiguousarray(cur.members, np.int64), np.ascontiguousarray(self._track2d, np.int64),
                np.ascontiguousarray(self.prev_2d, np.int64), np.ascontiguousarray(self.prev_owner, np.int64), ids)

    def _relink(self, cur: WindowTracklets3D, cols: np.ndarray, ids: np.ndarray) -> None:
        """Lost tracks continued by the tracklets ``cols`` (written into ``ids``)."""
        lost_ids = np.fromiter(self.lost, np.int64, len(self.lost))
        lf, lx, lv = (np.array(v) for v in list(zip(*self.lost.values()))[:3])
        r, c = link(relink_distances(lf, lx, lv, cur.xyz[cols], cur.valid[cols], cur.start, self.relink_frames),
                    self.link_3d)
        ids[cols[c]] = lost_ids[r]
        for tid in lost_ids[r].tolist():
            del self.lost[tid]
        self.counts["relinks"] += len(r)

    def _end_tracks(self, cur: WindowTracklets3D) -> None:
        """Tracks not continued by ``cur`` become lost; lost ones beyond re-linking reach, ended."""
        prev, start, W = self.prev, cur.start, cur.valid.shape[1]
        live = set(cur.track_id.tolist())
        gone = [k for k in self.track_last if k not in live]
        if gone:  # not continued: lost, and ended once it can no longer be re-linked
            at = np.flatnonzero(member(prev.track_id, np.array(gone, np.int64)))
            lf, lx, lv = tracklet_ends(prev.xyz[at], prev.valid[at], prev.start, self.max_speed)
            for k, tid in enumerate(prev.track_id[at].tolist()):
                self.track_last.pop(tid)
                self.lost[tid] = (int(lf[k]), lx[k], lv[k], prev.members[at[k]] >= 0)
        horizon = start + self.window_step - self.relink_frames - 1  # a lost track ending before this is beyond reach
        for tid in [k for k, v in self.lost.items() if v[0] < horizon]:
            self.ended[tid] = self.lost.pop(tid)[0]
        last = start + W - 1 - np.argmax(cur.valid[:, ::-1], axis=1)
        self.track_last.update(zip(cur.track_id.tolist(), last.tolist()))
