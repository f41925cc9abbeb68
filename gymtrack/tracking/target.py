"""The target gymnast: identification, gap filling, smoothing and pose boxes (paper Section III-D).

* :class:`TargetSelector` -- Eq. 13. While no target is assigned, a track becomes the target
  when more than Delta / 2 of the last ``identify_frames`` (Delta) frames have a point of it in
  the performance space with the body's top above ``h_top`` and its bottom above ``h_bot``
  (frames without a point count as not qualifying, as in the paper's sum; the most qualifying
  frames win, ties go to the smaller track id). The target keeps its track id until that track
  ends (it was not continued by cross-window linking) or leaves (no more than Delta / 2 of the
  last Delta frames with a point of it in the performance space). Then the same rule
  re-identifies a target -- which takes at least Delta / 2 + 1 frames of the new track, the
  frames the paper says are "inevitably lost" -- and a different track id counts as a switch.
  (Counting only a track's own points would re-identify a fresh track sooner, but in our
  simulations it also picks short-lived wrong tracks: more coverage, more switches.)
* :class:`TargetSmoother` -- gaps of at most ``max_gap`` frames (also across a switch) are
  filled by linear interpolation (source ``interpolated``); the trajectory is smoothed with a
  centred Savitzky-Golay filter (quadratic, ``2 * half_window + 1`` frames, truncated at a
  segment's ends). Streaming latency: ``half_window`` frames after the point is final, and up
  to ``max_gap + 1`` frames at the end of a segment (until it is known whether the gap closes).
* :class:`TargetBackfill` -- beyond the paper: Eq. 13 decides from the last Delta frames, so
  when it identifies a track, the frames it looked at are the target's too. The decisions wait
  ``backfill_frames`` frames; an identification hands its track the frames of that look-back
  after the last one whose target had a point there (see :func:`backfill`). The paper's "inevitably lost"
  frames after every (re-)identification come back, at the price of ``backfill_frames`` frames
  of latency for the target (the 3D tracks keep theirs). ``backfill_frames = 0`` is the paper.
* :func:`buffered_boxes` -- Eq. 14. The smoothed 3D centre is projected into every view
  (raw pixels, with distortion) and gets the square box of side ``box_scale * l``: ``l`` is
  ``max(w, h)`` of the target's detection in that view at that frame. Where the view has no
  detection of the target (a missed box, or a view that never detects it: n_cam < 4), ``l`` is
  ``max(w, h)`` of the projected *body box* (see :func:`buffered_boxes`): the body's vertical
  extent (its estimated top and bottom heights) times its horizontal extent, a rectangle aligned
  with the vertical plane -- half-length along the plane measured from the views that do see the
  target (their box widths at their depths), half-depth across it a prior
  (:data:`BODY_HALF_DEPTH`). The paper keeps the last box size, which misses a body that turns
  from upright to horizontal. A box is given when the centre is in front of the camera and
  inside the image.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Sequence

import numpy as np
from scipy.signal import savgol_coeffs

from ..scene import in_box
from ..geometry.camera import Rig
from ..geometry.plane import Plane
from ._kernels.target import BodyBox
from ._kernels.target import buffered_boxes as buffered_boxes_kernel
from ..detections import Detections
from .types import INTERPOLATED, Target

SMOOTH_HALF_WINDOW = 2  # 5-frame window: at 30 fps, ~0.17 s, keeps a twist's fast turn-around
SMOOTH_ORDER = 2


def identify_indicator(
    xyz: np.ndarray, top_z: np.ndarray, bottom_z: np.ndarray, performance_space: np.ndarray, h_top: float, h_bot: float
) -> tuple[np.ndarray, np.ndarray]:
    """The indicator of Eq. 13 per track point.

    xyz: (N, 3); top_z, bottom_z: (N,); performance_space: (6,).
    Returns (indicator (N,) bool: in S_perf and top > h_top and bottom > h_bot, in_perf (N,) bool).
    """
    inperf = in_box(xyz, performance_space)
    with np.errstate(invalid="ignore"):
        ind = inperf & (top_z > h_top) & (bottom_z > h_bot)
    return ind, inperf


class TargetSelector:
    """Eq. 13 over a stream of final track points; see the module docstring for the rule.

    identify_frames: Delta. State: the indicator rows of the last Delta frames (bounded by
    Delta x the number of tracks in view).
    """

    def __init__(self, identify_frames: int = 30):
        self.delta = int(identify_frames)
        self.target = -1
        self.last_target = -1
        self.switches = 0
        self.identifications = 0
        self._frame = np.zeros(0, np.int64)
        self._tid = np.zeros(0, np.int64)
        self._ind = np.zeros(0, bool)
        self._inperf = np.zeros(0, bool)

    def __len__(self) -> int:
        return len(self._frame)

    def step(self, frame: int, tid: np.ndarray, ind: np.ndarray, inperf: np.ndarray, ended: dict[int, int]) -> int:
        """One final frame: the track points of that frame (tid, ind, inperf all (n,)) and the
        ended tracks (id -> last frame). Returns the target's track id at this frame (-1: none)."""
        return int(self.select(frame, frame, np.full(len(tid), frame, np.int64), tid, ind, inperf, ended)[0])

    def select(self, a: int, b: int, frame: np.ndarray, tid: np.ndarray, ind: np.ndarray, inperf: np.ndarray,
               ended: dict[int, int]) -> np.ndarray:
        """Final frames ``a..b`` at once: rows (n,) of their track points (frame, tid, ind, inperf).
        Returns (b - a + 1,) the target's track id per frame (-1: none).

        The rule is applied frame by frame, but in runs: while the target stays, and while no
        track qualifies, every frame of the run is decided by one window count per frame
        (cumulative sums), so the cost is a few numpy calls per change of target rather than
        per frame.
        """
        keep = self._frame > a - self.delta
        self._frame = np.concatenate([self._frame[keep], frame])
        self._tid = np.concatenate([self._tid[keep], tid])
        self._ind = np.concatenate([self._ind[keep], ind])
        self._inperf = np.concatenate([self._inperf[keep], inperf])
        half = 0.5 * self.delta
        out = np.full(b - a + 1, -1, np.int64)
        if len(self._frame) == 0:  # nobody in the last Delta frames: no target, nothing to identify
            self.target = -1
            return out
        # beyond the last point + Delta the window is empty: no target (spares long pauses a loop)
        upto = min(b, int(self._frame.max()) + self.delta - 1)
        f = a
        while f <= upto:
            if self.target >= 0:
                f = self._keep_target(f, upto, out, a, half, ended)
            else:
                f = self._identify(f, upto, out, a, half, ended)
        if upto < b:
            self.target = -1
        return out

    def _window_counts(self, rows: np.ndarray, f0: int, f1: int, groups: np.ndarray | None = None,
                       n_groups: int = 1) -> np.ndarray:
        """Rows (mask over the state) counted in the window ``(f - Delta, f]`` of every frame
        ``f0..f1``, per group (``groups``: (n,) group index 0..n_groups-1 of the masked rows).
        Returns (n_groups, f1 - f0 + 1)."""
        base = f0 - self.delta + 1  # the earliest frame any of these windows covers
        L = f1 - base + 1
        fr = self._frame[rows] - base
        inside = (fr >= 0) & (fr < L)
        g = 0 if groups is None else groups[inside]
        hist = np.bincount(g * L + fr[inside], minlength=n_groups * L).reshape(n_groups, L)
        cum = np.zeros((n_groups, L + 1), np.int64)
        np.cumsum(hist, axis=1, out=cum[:, 1:])
        return cum[:, self.delta:] - cum[:, : L + 1 - self.delta]

    def _keep_target(self, f: int, upto: int, out: np.ndarray, a: int, half: float, ended: dict[int, int]) -> int:
        """Frames f.. while the target neither ended nor left; returns the first frame it is lost at
        (the target is then -1 there) or ``upto + 1``."""
        t = self.target
        stop = upto
        if t in ended:
            stop = min(stop, max(ended[t], f - 1))  # gone at frames after its last one
        if stop >= f:
            n = self._window_counts(self._inperf & (self._tid == t), f, stop)[0]
            lost = np.flatnonzero(n <= half)
            if len(lost):
                stop = f + int(lost[0]) - 1
            out[f - a: stop - a + 1] = t
        if stop < upto:  # lost at stop + 1: re-identification may start at that same frame
            self.target = -1
        return stop + 1

    def _identify(self, f: int, upto: int, out: np.ndarray, a: int, half: float, ended: dict[int, int]) -> int:
        """Frames f.. while no target: the first frame a live track qualifies (Eq. 13) gets it.
        Returns the frame after the last one decided."""
        q = self._ind
        if ended:  # an ended track gets no more points: never (re-)identify it
            q = q & ~np.isin(self._tid, np.fromiter(ended, np.int64, len(ended)))
        rows = np.flatnonzero(q & (self._frame <= upto))
        if len(rows) == 0:
            return upto + 1
        ids, inv = np.unique(self._tid[rows], return_inverse=True)
        mask = np.zeros(len(self._frame), bool)
        mask[rows] = True
        grp = np.full(len(self._frame), -1, np.int64)
        grp[rows] = inv
        counts = self._window_counts(mask, f, upto, grp[mask], len(ids))  # (tracks, frames)
        hit = np.flatnonzero(counts.max(axis=0) > half)
        if len(hit) == 0:
            return upto + 1
        k = int(hit[0])
        self.target = int(ids[np.argmax(counts[:, k])])  # first maximum = smallest id among ties
        self.identifications += 1
        if self.last_target >= 0 and self.target != self.last_target:
            self.switches += 1
        self.last_target = self.target
        out[f + k - a] = self.target
        return f + k + 1

def backfill(decision: np.ndarray, index: np.ndarray, track_id: np.ndarray, frames: int, since: int = 0,
             before: int = -1) -> np.ndarray:
    """Hand newly identified tracks the undecided frames Eq. 13 looked back on (in place).

    decision: (F,) the target's track id per frame (-1: none); index: (n,) frame index (into
    ``decision``) of each track point; track_id: (n,) its track; frames: how far back an
    identification reaches; since: only changes of target at indices >= since are handled (the
    earlier ones were, in an earlier call); before: the decision of the frame before index 0.

    For every index ``k >= since`` where the target becomes a track ``T`` different from the
    previous frame's, the frames ``k - frames .. k - 1`` after the last frame whose target had a
    point there become ``T``'s where ``T`` has a point (a lost target is held until Eq. 13 lets
    it go, without points: those frames are open to its successor). Returns ``decision``.
    """
    if frames <= 0 or len(decision) <= since:
        return decision
    pointed = np.zeros(len(decision), bool)  # frames whose target has a point there
    pointed[index[track_id == decision[index]]] = True
    prev = np.empty(len(decision) - since, np.int64)
    prev[0] = decision[since - 1] if since > 0 else before
    prev[1:] = decision[since:-1]
    starts = since + np.flatnonzero((decision[since:] >= 0) & (decision[since:] != prev))
    for k in starts.tolist():  # one per identification: rare
        lo = max(0, k - frames)
        decided = np.flatnonzero(pointed[lo:k])
        if len(decided):
            lo += int(decided[-1]) + 1
        if lo < k:
            mine = index[(track_id == decision[k]) & (index >= lo) & (index < k)]
            decision[mine] = decision[k]
            pointed[mine] = True
    return decision


class TargetBackfill:
    """The target decisions of the last ``frames`` final frames, held back for :func:`backfill`.

    :meth:`push` takes the decisions of a run of final frames and the track points of those
    frames (columns, :data:`ROW_FIELDS`, all tracks); :meth:`pop` releases the target's points of
    the frames up to a given one. State: the points of at most ``frames`` + one call's frames.
    """

    def __init__(self, frames: int):
        self.frames = int(frames)
        self._first: int | None = None  # first frame not yet released
        self._decision = np.zeros(0, np.int64)
        self._rows: tuple | None = None
        self._last = -1  # decision of the last released frame

    def __len__(self) -> int:
        return 0 if self._rows is None else len(self._rows[0])

    def push(self, a: int, decision: np.ndarray, rows: tuple) -> None:
        """Final frames ``a .. a + len(decision) - 1``: their decisions (track id or -1) and the
        track points of those frames in frame order (columns, :data:`ROW_FIELDS`)."""
        if self._first is None:
            self._first = a
        if a != self._first + len(self._decision):
            raise ValueError(f"frames must follow on: got {a}, expected {self._first + len(self._decision)}")
        since = len(self._decision)
        self._decision = np.concatenate([self._decision, np.asarray(decision, np.int64)])
        rows = _rows(*rows)
        self._rows = rows if self._rows is None else concat_rows([self._rows, rows])
        backfill(self._decision, self._rows[0] - self._first, self._rows[1], self.frames, since, self._last)

    def pop(self, upto: int | None = None) -> tuple | None:
        """Release the frames up to ``upto`` (None: all): the target's points among them (columns,
        :data:`ROW_FIELDS`, frame order), or None when it has none."""
        if self._first is None or len(self._decision) == 0:
            return None
        n = len(self._decision) if upto is None else min(max(upto - self._first + 1, 0), len(self._decision))
        if n == 0:
            return None
        fr, tid = self._rows[0], self._rows[1]
        done = fr < self._first + n
        off = fr[done] - self._first
        take = np.flatnonzero(done)[tid[done] == self._decision[off]]
        out = _take(self._rows, take) if len(take) else None
        self._rows = _take(self._rows, ~done)
        self._last = int(self._decision[n - 1])
        self._decision = self._decision[n:]
        self._first += n
        return out


@lru_cache(maxsize=None)
def _smoothing_weights(left: int, right: int, order: int) -> np.ndarray:
    """Savitzky-Golay weights for a point with ``left`` / ``right`` neighbours: (left+right+1,)."""
    n = left + right + 1
    if n == 1:
        return np.ones(1)
    return savgol_coeffs(n, min(order, n - 1), pos=left, use="dot")


#: columns of the target's rows, in order: frame (n,) int64, track_id (n,) int64, xyz (n, 3),
#: top_z (n,), bottom_z (n,), source (n,) int8, wh (n, C, 2) width and height of the track's
#: detection per view (raw pixels; NaN where none)
ROW_FIELDS = ("frame", "track_id", "xyz", "top_z", "bottom_z", "source", "wh")


def _rows(frame, track_id, xyz, top_z, bottom_z, source, wh) -> tuple:
    """Columns with the smoother's dtypes (see :data:`ROW_FIELDS`)."""
    return (np.asarray(frame, np.int64), np.asarray(track_id, np.int64), np.asarray(xyz, np.float64),
            np.asarray(top_z, np.float64), np.asarray(bottom_z, np.float64), np.asarray(source, np.int8),
            np.asarray(wh, np.float64))


def concat_rows(parts: list) -> tuple:
    """Row-wise concatenation of column tuples (:data:`ROW_FIELDS`), e.g. what the smoother emitted."""
    return parts[0] if len(parts) == 1 else tuple(np.concatenate(c) for c in zip(*parts))


def _take(rows: tuple, index) -> tuple:
    return tuple(c[index] for c in rows)


class TargetSmoother:
    """Gap filling and centred smoothing of the target trajectory, streaming.

    Points are pushed in frame order, either as columns (:meth:`push_rows`: ``frame (n,),
    track_id (n,), xyz (n, 3), top_z (n,), bottom_z (n,), source (n,), wh (n, C, 2)``, see
    :data:`ROW_FIELDS`) or one at a time as a tuple ``(frame, track_id, xyz (3,), top_z,
    bottom_z, source, wh (C, 2))`` (:meth:`push`). ``wh``: width and height of the target's
    detection per view, NaN where none. Emitted rows have the same layout with ``xyz`` smoothed. State: the
    points of the current segment not yet emitted plus ``half_window`` points of context.
    """

    def __init__(self, max_gap: int = 7, half_window: int = SMOOTH_HALF_WINDOW, order: int = SMOOTH_ORDER):
        self.max_gap = int(max_gap)
        self.h = int(half_window)
        self.order = int(order)
        self._buf: tuple | None = None  # columns of the current segment's kept points
        self._done = 0  # points of _buf already emitted (context)

    def __len__(self) -> int:
        return 0 if self._buf is None else len(self._buf[0])

    # ------------------------------------------------------------ tuple interface
    def push(self, point: tuple) -> list[tuple]:
        """Push one point (tuple); returns the emitted points as tuples."""
        f, tid, xyz, top, bot, src, wh = point
        wh = np.asarray(wh, np.float64)
        return _tuples(self.push_rows([f], [tid], np.reshape(xyz, (1, 3)), [top], [bot], [src], wh[None]))

    def advance(self, final_frame: int) -> list[tuple]:
        """Every frame up to ``final_frame`` is final: close the segment if its gap can no longer be filled."""
        return _tuples(self.advance_rows(final_frame))

    def close(self) -> list[tuple]:
        """End the current segment: emit all its points (as tuples)."""
        return _tuples(self.close_rows())

    # ------------------------------------------------------------ column interface
    def push_rows(self, frame, track_id, xyz, top_z, bottom_z, source, wh) -> tuple | None:
        """Push n points in increasing frame order (columns, see the class docstring).

        Returns the emitted rows as columns, or None when nothing is emitted. Same result as
        pushing the points one by one: gaps of at most ``max_gap`` frames are filled by
        linear interpolation, longer gaps end the segment (all its points are emitted)."""
        if len(frame) == 0:
            return None
        new = _rows(frame, track_id, xyz, top_z, bottom_z, source, wh)
        done = self._done
        seq = new if self._buf is None else tuple(np.concatenate(c) for c in zip(self._buf, new))
        gap = np.diff(seq[0]) - 1
        ends = []
        if len(gap) and gap.max() > 0:  # (rare) gaps: filled, or ending the segment
            fill = np.flatnonzero((gap > 0) & (gap <= self.max_gap))
            if len(fill):  # interpolated points, then everything back in frame order
                seq = concat_rows([seq, self._interpolate(seq, fill, gap[fill])])
                seq = _take(seq, np.argsort(seq[0], kind="stable"))
                gap = np.diff(seq[0]) - 1
            ends = (np.flatnonzero(gap > self.max_gap) + 1).tolist()  # segment boundaries
        out = []
        start = 0
        for end in ends:  # every segment but the last is complete
            out.append(self._smooth(_take(seq, slice(start, end)), done, end - start))
            start, done = end, 0
        last = _take(seq, slice(start, None)) if start else seq
        n = len(last[0])
        ready = max(done, n - self.h)
        out.append(self._smooth(last, done, ready))
        drop = max(ready - self.h, 0)  # keep h emitted points as left context
        self._buf, self._done = (_take(last, slice(drop, None)) if drop else last), ready - drop
        out = [o for o in out if o is not None]
        return concat_rows(out) if out else None

    def advance_rows(self, final_frame: int) -> tuple | None:
        """Column form of :meth:`advance`."""
        if self._buf is not None and final_frame - int(self._buf[0][-1]) > self.max_gap:
            return self.close_rows()
        return None

    def close_rows(self) -> tuple | None:
        """Column form of :meth:`close`."""
        buf, done = self._buf, self._done
        self._buf, self._done = None, 0
        if buf is None or len(buf[0]) <= done:
            return None
        return self._smooth(buf, done, len(buf[0]))

    def _interpolate(self, seq: tuple, after: np.ndarray, gap: np.ndarray) -> tuple:
        """Rows filling the gaps after points ``after`` (gaps of ``gap`` frames): linear in xyz and
        heights, the next point's track id, source interpolated, no detections."""
        i = np.repeat(after, gap)
        k = np.arange(len(i)) - np.repeat(np.cumsum(gap) - gap, gap) + 1  # 1..gap within each gap
        a = k / np.repeat(gap + 1, gap)
        fr, tid, xyz, top, bot, _, wh = seq
        a1 = a[:, None]
        return (fr[i] + k, tid[i + 1], xyz[i] * (1 - a1) + xyz[i + 1] * a1, top[i] * (1 - a) + top[i + 1] * a,
                bot[i] * (1 - a) + bot[i + 1] * a, np.full(len(i), INTERPOLATED, np.int8),
                np.full((len(i), *wh.shape[1:]), np.nan))

    def _smooth(self, seg: tuple, lo: int, hi: int) -> tuple | None:
        """Rows lo..hi-1 of a segment's points (``seg``, starting with its context) with xyz
        smoothed over the centred window, truncated at the segment's ends: points before ``lo``
        are context, points after the segment's last one do not exist (yet)."""
        if hi <= lo:
            return None
        h = self.h
        X = seg[2]
        n = len(X)
        xyz = np.empty((hi - lo, 3))
        a, b = max(lo, h), min(hi, n - h)  # points a..b-1 have their whole window: one set of weights
        if b > a:  # (m, 2h + 1, 3) windows gathered at once (sliding_window_view costs more on a few rows)
            win = X[np.arange(a, b)[:, None] + np.arange(-h, h + 1)]
            xyz[a - lo: b - lo] = _smoothing_weights(h, h, self.order) @ win
        else:
            a = b = hi
        for c in [*range(lo, a), *range(b, hi)]:  # a few points near the segment's ends
            left, right = min(h, c), min(h, n - 1 - c)
            xyz[c - lo] = _smoothing_weights(left, right, self.order) @ X[c - left: c + right + 1]
        rows = _take(seg, slice(lo, hi))
        return rows[:2] + (xyz,) + rows[3:]


def _tuples(rows: tuple | None) -> list[tuple]:
    """Columns -> list of point tuples ``(frame, track_id, xyz, top_z, bottom_z, source, wh)``."""
    if rows is None:
        return []
    fr, tid, xyz, top, bot, src, wh = rows
    return [(int(fr[k]), int(tid[k]), xyz[k], float(top[k]), float(bot[k]), int(src[k]), wh[k])
            for k in range(len(fr))]


def track_box_sizes(tracks, boxes: Detections, n_cameras: int) -> np.ndarray:
    """Width and height of every track point's detection per view: (n, C, 2), NaN where none.

    tracks: rows with ``frame`` and ``track_id`` (n,), sorted by (frame, track_id), one per pair;
    boxes: the tracks' boxes (``track_id`` = the 3D track), at most one per (frame, view, track).
    Boxes of a (frame, track) without a point are not used.
    """
    wh = np.full((len(tracks.frame), n_cameras, 2), np.nan)
    if len(tracks.frame) == 0 or len(boxes) == 0:
        return wh
    span = int(max(tracks.track_id.max(), boxes.track_id.max())) + 1
    key = tracks.frame * span + tracks.track_id  # increasing: tracks are sorted
    bkey = boxes.frame.astype(np.int64) * span + boxes.track_id
    row = np.minimum(np.searchsorted(key, bkey), len(key) - 1)
    hit = key[row] == bkey
    wh[row[hit], boxes.camera[hit].astype(np.int64)] = boxes.box[hit, 2:]
    return wh


def target_and_boxes(rig: Rig, rows: tuple, box_scale: float, memory: dict,
                     planes: Sequence[Plane] = ()) -> tuple[Target, Detections]:
    """Smoothed target rows (columns, :data:`ROW_FIELDS`) -> the :class:`Target` and its Eq. 14
    boxes in every view (:func:`buffered_boxes`; ``memory`` carries the body box's half-length
    between calls; ``planes``: the scene's vertical planes, the body box follows the nearest)."""
    frame, tid, xyz, top, bot, src, wh = rows
    box, ok = buffered_boxes(rig, xyz, top, bot, wh, box_scale, memory, nearest_normals(planes, xyz))
    n, c = np.nonzero(ok)
    return Target(frame, tid, xyz, src), Detections.from_arrays(frame[n], c, box[n, c], rig.names, track_id=tid[n])


def nearest_normals(planes: Sequence[Plane], xyz: np.ndarray) -> np.ndarray | None:
    """(N, 3) the normal of the plane nearest to each point (xyz (N, 3)); None without planes."""
    if not planes:
        return None
    normals = np.stack([pl.normal for pl in planes])
    if len(planes) == 1:
        return np.broadcast_to(normals[0], (len(xyz), 3))
    dist = np.abs(np.stack([pl.signed_distance(xyz) for pl in planes], axis=1))  # (N, P)
    return normals[np.argmin(dist, axis=1)]


#: metres: half the body's extent across the vertical plane. Views facing the plane cannot
#: measure it; a gymnast's trunk is ~0.25 m deep and limbs leave the plane in twists and circles.
BODY_HALF_DEPTH = 0.25
#: metres: the smallest half-length along the plane (a tucked body seen side-on).
MIN_HALF_LENGTH = 0.1
#: metres: half an upright body's height, where the top/bottom heights are unknown.
DEFAULT_HALF_HEIGHT = 0.9
#: views that see the plane this obliquely (|cos| between their x-axis and the plane's direction)
#: tell little about the body's length along it and are not used to measure it.
MIN_LENGTH_COS = 0.3


def buffered_boxes(
    rig: Rig,
    xyz: np.ndarray,
    top_z: np.ndarray,
    bottom_z: np.ndarray,
    wh: np.ndarray,
    box_scale: float,
    memory: dict,
    normal: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 14 boxes of the target in every view, for rows in frame order (see the module docstring).

    xyz: (N, 3) smoothed centres; top_z, bottom_z: (N,) heights of the body's top and bottom
    (NaN: unknown, then ``z +- DEFAULT_HALF_HEIGHT``); wh: (N, C, 2) width and height of the
    target's detection per view (NaN: none); box_scale: alpha; memory: dict carried between calls
    (``"half_length"``: the body box's last measured half-length); normal: (N, 3) or (3,) normal of
    the vertical plane the body box is aligned with, or None (no plane: a box as deep as long,
    aligned with the world axes).

    The body box: its half-length ``a`` along the plane is measured in every view with a
    detection -- a box of width ``w`` at depth ``z`` spans ``w z / f`` metres across the view's
    x-axis ``r``, which the body box fills as ``2 (a |r . along| + b |r . across|)``; views that
    see the plane more obliquely than :data:`MIN_LENGTH_COS` are not used; the largest wins (a
    cut or occluded box only shrinks) and rows without a measurement keep the last one. In a view
    without a detection ``l`` is ``max(w, h)`` of the rectangle bounding its 8 projected corners.
    One compiled loop (:func:`._kernels.target.buffered_boxes`) per call.

    Returns (box (N, C, 4) centre-form raw-pixel squares, ok (N, C) bool).
    """
    N, C = wh.shape[:2]
    if N == 0:
        return np.full((N, C, 4), np.nan), np.zeros((N, C), bool)
    if normal is None:
        across = np.broadcast_to(np.array([0.0, 1.0, 0.0]), (N, 3))
    else:
        across = np.array(np.broadcast_to(normal, (N, 3)), dtype=np.float64)
        across[:, 2] = 0
        flat = np.linalg.norm(across, axis=1)
        across = np.where(flat[:, None] > 1e-9, across / np.maximum(flat, 1e-12)[:, None], [0.0, 1.0, 0.0])
    box, ok, last = buffered_boxes_kernel(
        np.ascontiguousarray(xyz, dtype=np.float64), np.ascontiguousarray(top_z, dtype=np.float64),
        np.ascontiguousarray(bottom_z, dtype=np.float64), np.ascontiguousarray(wh, dtype=np.float64),
        np.ascontiguousarray(across), float(memory.get("half_length", BODY_HALF_DEPTH)), rig.arrays,
        BodyBox(float(box_scale), BODY_HALF_DEPTH, normal is None, MIN_LENGTH_COS, MIN_HALF_LENGTH,
                DEFAULT_HALF_HEIGHT))
    memory["half_length"] = float(last)
    return box, ok
