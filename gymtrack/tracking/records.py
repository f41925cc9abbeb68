"""What the streaming tracker holds until frames are final (paper Section III-A/B, Eq. 12).

* :class:`BoxTable` -- the boxes received (stage 1): buffered per frame, undistorted once per
  window (:mod:`.undistort`; the geometric stages work in undistorted pixels, the outputs keep
  the raw boxes), and kept, one row per detection, until their frames are final.
* :class:`WindowRecords` -- every window's linked 3D points and the detections of their member
  segments. When frames become final, Eq. 12 averages the estimates of the windows covering a
  frame (:func:`~.linking.merge_overlaps`) and every detection goes to the track of the latest
  window that used it. Beyond the paper (the recipe's ``exclusion``, ``superseded=True``): a
  window's estimate of a frame whose detections there all went to *other* tracks of later
  windows is *superseded* (:func:`superseded`): the later window re-assigned that person's
  boxes, so a point with nothing but such estimates duplicates another track's
  (:meth:`WindowRecords.tracks_superseded` flags it; the tracker leaves it out of the reported
  tracks, :mod:`.exclusion`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry.camera import Rig
from ._kernels import records as kernels
from .linking import merge_overlaps
from .sync import cut_by_border
from .types import Tracks3D, WindowTracklets, WindowTracklets3D
from .undistort import UndistortTables


class BoxTable:
    """The boxes of the frames not yet final, in arrival (frame) order.

    Columns of :attr:`rows`: frame (n,) int64, camera (n,) int64, track2d (n,) int64 (the 2D
    track), raw (n, 4) and ubox (n, 4) centre-form boxes in raw and undistorted pixels, score
    (n,) float32, det (n,) int64 the detection's row id (a tracker-wide counter), cut (n,) bool the
    image's edge cuts the box (:func:`~.sync.cut_by_border`: its centre is not the person's).
    """

    def __init__(self, rig: Rig):
        self._undist = UndistortTables(rig) if any(cam.has_distortion for cam in rig) else None
        self._size = np.array([cam.size for cam in rig], np.float64)  # (C, 2) the images' width, height
        self._pending: list[tuple] = []  # chunks received since the last window, not yet undistorted
        self.rows = self._empty()
        self._det_counter = 0

    def __len__(self) -> int:
        return sum(len(c[1]) for c in self._pending) + len(self.rows["frame"])

    def idle(self, start: int) -> bool:
        """No box that a window starting at ``start`` could use."""
        return not self._pending and not np.any(self.rows["frame"] >= start)

    def add(self, frame: int, camera: np.ndarray, track2d: np.ndarray, box: np.ndarray, score: np.ndarray) -> None:
        """One frame's boxes (n,): cameras, 2D track ids, raw boxes (n, 4), scores."""
        self._pending.append((frame, camera, track2d, box, score))  # frame numbers and ids added per window

    @staticmethod
    def _empty() -> dict:
        return {"frame": np.zeros(0, np.int64), "camera": np.zeros(0, np.int64), "track2d": np.zeros(0, np.int64),
                "raw": np.zeros((0, 4)), "score": np.zeros(0, np.float32), "det": np.zeros(0, np.int64),
                "ubox": np.zeros((0, 4)), "cut": np.zeros(0, bool)}

    def _undistort(self, camera: np.ndarray, box: np.ndarray) -> np.ndarray:
        """Boxes to undistorted pixels: the top-left and bottom-right corners are undistorted
        (:class:`~.undistort.UndistortTables`, OpenCV-exact to 0.05 px) and the box rebuilt from
        them, so it keeps the person's extent in the ideal image."""
        if self._undist is None or len(box) == 0:
            return box.copy()
        n = len(box)
        centre, half = box[:, :2], box[:, 2:] / 2
        und = self._undist(np.concatenate([camera, camera]), np.concatenate([centre - half, centre + half]))
        tl, br = und[:n], und[n:]
        out = np.empty((n, 4))  # written in place: no concatenation of the halves
        np.add(tl, br, out=out[:, :2])
        out[:, :2] /= 2
        np.subtract(br, tl, out=out[:, 2:])
        return out

    def flush(self, start: int) -> np.ndarray | None:
        """Undistort the boxes received since the last window and drop the boxes of frames before
        ``start`` (final). Returns the cameras (n,) of the boxes added, None when none were."""
        t = self.rows
        # the table is in arrival (frame) order: the rows kept are a suffix, sliced without a copy
        cut = int(np.searchsorted(t["frame"], start))
        if self._pending:
            frames, cams, tids, raws, scores = zip(*self._pending)
            self._pending = []
            c, tid, raw = np.concatenate(cams), np.concatenate(tids), np.concatenate(raws)
            f = np.repeat(np.array(frames, np.int64), [len(x) for x in cams])
            det = self._det_counter + np.arange(len(c))  # detection row ids, in arrival order
            self._det_counter += len(c)
            new = {"frame": f, "camera": c, "track2d": tid, "raw": raw,
                   "score": np.concatenate(scores).astype(np.float32), "det": det, "ubox": self._undistort(c, raw),
                   "cut": cut_by_border(self._size[c], raw)}
            self.rows = {k: np.concatenate([v[cut:], new[k]]) for k, v in t.items()}
            return c
        if cut:
            self.rows = {k: v[cut:] for k, v in t.items()}
        return None

    def lookup(self, det: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(raw box (n, 4), score (n,)) of the detections ``det`` (n,) (row ids still held)."""
        row = self._row(det)
        return self.rows["raw"][row], self.rows["score"][row]

    def cut(self, det: np.ndarray) -> np.ndarray:
        """(...) bool: the detections ``det`` (row ids still held; -1 none: False) whose box the image's
        edge cuts (:func:`~.sync.cut_by_border`)."""
        if not len(self.rows["det"]):
            return np.zeros(det.shape, bool)
        return (det >= 0) & self.rows["cut"].take(self._row(det), mode="clip")  # (-1: clipped to a row, masked)

    def _row(self, det: np.ndarray) -> np.ndarray:
        """The rows of the detections ``det`` (ids still held): the ids held are consecutive,
        counted on arrival and dropped from the front, so a row is the id less the first's."""
        held = self.rows["det"]
        return det - held[0] if len(held) else det


@dataclass(frozen=True, eq=False)
class MemberRows:
    """The detections a window's linked 3D tracklets used, one row per (detection, window).

    det (n,) int64 detection row id (:class:`BoxTable`), frame (n,) int64, camera (n,) int64,
    track_id (n,) int64 the 3D track, window (n,) int64 the window's index.
    """

    det: np.ndarray
    frame: np.ndarray
    camera: np.ndarray
    track_id: np.ndarray
    window: np.ndarray

    def __len__(self) -> int:
        return len(self.det)

    @classmethod
    def concat(cls, parts: list["MemberRows"]) -> "MemberRows":
        if len(parts) == 1:
            return parts[0]
        cat = np.concatenate  # (the columns spelled out: fields() per call cost more than the work)
        return cls(cat([p.det for p in parts]), cat([p.frame for p in parts]), cat([p.camera for p in parts]),
                   cat([p.track_id for p in parts]), cat([p.window for p in parts]))

    def select(self, index) -> "MemberRows":
        return MemberRows(self.det[index], self.frame[index], self.camera[index], self.track_id[index],
                          self.window[index])


def _concat_estimates(parts: list[Tracks3D]) -> Tracks3D:
    return parts[0] if len(parts) == 1 else Tracks3D.concat(parts)


def superseded(frame: np.ndarray, track_id: np.ndarray, window: np.ndarray, members: MemberRows,
               order: np.ndarray | None = None) -> np.ndarray:
    """(n,) bool: estimates (frame, track_id, window) (n,) that had member detections in their
    frame and lost all of them to another track (each detection goes to the latest window's
    track, as in :meth:`WindowRecords.boxes`). Estimates without detections in their frame
    (interpolated or held boxes) are never superseded. ``order``: ``np.lexsort((-window, det))``
    of the members when the caller has it. One compiled call (:func:`._kernels.records.superseded`)."""
    if not len(members) or not len(frame):
        return np.zeros(len(frame), bool)
    if order is None:
        order = np.lexsort((-members.window, members.det))  # per detection, the latest window first
    i64 = np.ascontiguousarray
    return kernels.superseded(i64(frame, np.int64), i64(track_id, np.int64), i64(window, np.int64),
                              i64(members.det, np.int64), i64(members.frame, np.int64),
                              i64(members.track_id, np.int64), i64(members.window, np.int64), i64(order, np.int64))


class WindowRecords:
    """The windows' linked 3D points and member detections until their frames are final.

    The 3D points are kept as :class:`~.types.Tracks3D` rows, one per window estimate (a frame
    in the overlap of two windows has two until Eq. 12 merges them); the detections as
    :class:`MemberRows`.
    """

    def __init__(self, superseded: bool = False, best_only: bool = False):
        self.superseded = bool(superseded)  # exclusion: drop the estimates whose boxes later windows took
        self.dropped = 0  # points flagged that way
        self.best_only = best_only  # best_estimates: Eq. 12 over the best-observed estimates only (merge_overlaps)
        self._estimates: list[Tracks3D] = []
        self._windows: list[np.ndarray] = []  # the window index of every estimate (parallel to _estimates)
        self._members: list[MemberRows] = []
        self._sorted: tuple | None = None  # (members, upto, final, final rows, their sort): shared with boxes()

    def __len__(self) -> int:
        return sum(len(r) for r in self._estimates) + sum(len(r) for r in self._members)

    def add(self, cur: WindowTracklets3D, segs: WindowTracklets, window_index: int) -> None:
        """Keep the window's 3D points and member boxes until their frames are final."""
        m, t = np.nonzero(cur.valid)
        if len(m):
            self._estimates.append(Tracks3D(cur.start + t, cur.track_id[m], cur.xyz[m, t], cur.top_z[m, t],
                                            cur.bottom_z[m, t], cur.source[m, t], cur.n_views[m, t]))
            self._windows.append(np.full(len(m), window_index, np.int64))
        tm, tc = np.nonzero(cur.members >= 0)
        if len(tm):
            k = cur.members[tm, tc]
            dets = segs.det[k]  # (n, W)
            i, tt = np.nonzero(dets >= 0)
            n = len(i)
            self._members.append(MemberRows(dets[i, tt], cur.start + tt, tc[i], cur.track_id[tm[i]],
                                            np.full(n, window_index, np.int64)))

    def tracks(self, upto: int) -> Tracks3D:
        """Eq. 12: every (frame, track) estimate from the windows covering the frame, averaged,
        for the frames up to ``upto`` (then forgotten)."""
        return self.tracks_superseded(upto)[0]

    def tracks_superseded(self, upto: int) -> tuple[Tracks3D, np.ndarray]:
        """:meth:`tracks` and (N,) bool: the points whose every estimate is :func:`superseded`
        (all False unless ``superseded``); the points themselves are Eq. 12's, unchanged."""
        if not self._estimates:
            return Tracks3D.empty(), np.zeros(0, bool)
        rows = _concat_estimates(self._estimates)
        win = np.concatenate(self._windows) if len(self._windows) != 1 else self._windows[0]
        done = rows.frame <= upto
        self._estimates = [rows.select(~done)] if not done.all() else []
        self._windows = [win[~done]] if not done.all() else []
        r = rows.select(done)
        out = merge_overlaps(r.frame, r.track_id, r.xyz, r.top_z, r.bottom_z, r.source, r.n_views, self.best_only)
        gone = np.zeros(len(out), bool)
        if self.superseded and self._members and len(out):
            mem = MemberRows.concat(self._members)
            self._members = [mem]  # (boxes() would concatenate them again)
            final = mem.frame <= upto
            sel = mem.select(final)
            order = np.lexsort((-sel.window, sel.det))  # per detection, the latest window first
            self._sorted = (mem, upto, final, sel, order)  # boxes(upto) next needs the same rows and sort
            # (:func:`superseded`'s kernel straight away: these columns are int64 and C order already)
            est = kernels.superseded(r.frame, r.track_id, win[done], sel.det, sel.frame, sel.track_id, sel.window, order)
            if est.any():  # a point is gone when none of its estimates kept a detection
                span = int(out.track_id.max()) + 1
                gone = ~np.isin(out.frame * span + out.track_id, r.frame[~est] * span + r.track_id[~est])
                self.dropped += int(gone.sum())
        return out, gone

    def boxes(self, upto: int, n_cameras: int, n_tracks: int) -> tuple[np.ndarray, ...] | None:
        """The tracks' detections of the frames up to ``upto`` (then forgotten): per detection the
        latest window's track wins; one per (frame, view, track), the smallest detection id.
        n_tracks: more than the largest track id. Returns (det, frame, camera, track_id), each
        (n,) in (frame, view, track) order, or None when nothing is held."""
        if not self._members:
            return None
        rows = MemberRows.concat(self._members)
        cached, self._sorted = self._sorted, None
        if cached is not None and cached[0] is rows and cached[1] == upto:  # tracks_superseded sorted them
            done, r, order = cached[2], cached[3], cached[4]
        else:
            done = rows.frame <= upto
            r, order = rows.select(done), None
        self._members = [rows.select(~done)] if not done.all() else []
        det, frame, cam, tid, win = r.det, r.frame, r.camera, r.track_id, r.window

        def group_starts(keys):  # sorted keys -> True at the first row of every run of equal keys
            starts = np.ones(len(keys), bool)
            np.not_equal(keys[1:], keys[:-1], out=starts[1:])
            return starts

        # two stable sorts, each keeping the first row of every group (cheaper than np.unique):
        # per detection the latest window (ties: the earlier record) ...
        if order is None:
            order = np.lexsort((-win, det))
        first = order[group_starts(det[order])]
        det, frame, cam, tid = det[first], frame[first], cam[first], tid[first]
        # ... then per (frame, view, track) the smallest detection; the result is in
        # (frame, view, track) order, the output order
        key = (frame * n_cameras + cam) * n_tracks + tid
        order = np.lexsort((det, key))
        first = order[group_starts(key[order])]
        return det[first], frame[first], cam[first], tid[first]
