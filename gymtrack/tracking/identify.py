"""Identification of the target gymnast (paper Section III-D, Eq. 13) and the back-fill.

* :func:`identify_indicator` -- the indicator of Eq. 13 per track point: in the performance
  space with the body's top above ``h_top`` and its bottom above ``h_bot``.
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
  Beyond the paper (the recipe's ``reidentify``): the held target gives way to another live
  track when, in more than Delta / 2 of the last Delta frames, that track qualified with a
  point seen in more views than the target's at that frame (:func:`point_support`; a frame
  without a target point counts as none). A phantom of association (a plane candidate of one
  view) identified while the gymnast stood on the floor is then not held while the gymnast's
  own track qualifies. It counts as a switch, and the back-fill (below) hands the new target the
  frames just before where it had a point seen in at least as many views as the target's: the
  run of them that ends at the take-over. A tie goes to the track that won: at a vault's
  take-off the run-up track went on with a coach at the board while her new track flew on, both
  seen by one view, and the take-over takes back 16 frames instead of 8. Whether a point was
  triangulated or placed on the plane does not count: two views' boxes triangulate whenever
  their rays meet short of opposite, a wrong pair as readily as the right one, so a phantom of
  a wrong pair would take the target from a gymnast seen by the same two views as an opposite
  pair.
* :class:`TargetBackfill` -- beyond the paper: Eq. 13 decides from the last Delta frames, so
  when it identifies a track, the frames it looked at are the target's too. The decisions wait
  ``backfill_frames`` frames; an identification hands its track the frames of that look-back
  after the last one whose target had a point there (see :func:`backfill`). The paper's "inevitably lost"
  frames after every (re-)identification come back, at the price of ``backfill_frames`` frames
  of latency for the target (the 3D tracks keep theirs). ``backfill_frames = 0`` is the paper.
  The recipe's ``chain`` lets the look-back go on to the track the identified one continues
  (:mod:`.chain`).

The stage that wires these with smoothing and the Eq. 14 boxes: :class:`~.target.TargetStage`.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..scene import in_box
from .chain import chain_back
from .types import TargetRows, member


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

    identify_frames: Delta; reidentify: the recipe's ``reidentify`` (False: the paper's hold until
    the target ends or leaves); counts: the tracker's counters (``target_reidentifications``).
    State: the indicator rows of the last Delta frames (bounded by Delta x the number of tracks
    in view), with each point's support only under ``reidentify``.
    """

    def __init__(self, identify_frames: int = 30, reidentify: bool = False, counts: dict | None = None):
        self.delta = int(identify_frames)
        self.reidentify = bool(reidentify)
        self.counts = {} if counts is None else counts
        self.target = -1
        self.last_target = -1
        self.switches = 0
        self.identifications = 0
        self._frame = np.zeros(0, np.int64)
        self._tid = np.zeros(0, np.int64)
        self._ind = np.zeros(0, bool)
        self._inperf = np.zeros(0, bool)
        self._support = np.zeros(0, np.int64)  # kept only under reidentify: the paper never reads it
        self.takeovers: list[int] = []  # frames where a challenger took over (reidentify), for the back-fill

    def __len__(self) -> int:
        return len(self._frame)

    def pop_takeovers(self) -> list[int]:
        """The frames where a challenger took over since the last call (for the back-fill)."""
        out, self.takeovers = self.takeovers, []
        return out

    def forget(self) -> None:
        """Drop the indicator rows (a pause longer than Delta: none of them can count again)."""
        self.target = -1
        self._frame, self._tid = self._frame[:0], self._tid[:0]
        self._ind, self._inperf, self._support = self._ind[:0], self._inperf[:0], self._support[:0]

    def rename(self, track: int, as_track: int, after: int) -> None:
        """The held rows of ``track`` after frame ``after`` count as ``as_track``'s (a handover)."""
        self._tid[(self._tid == track) & (self._frame > after)] = as_track

    def select(self, a: int, b: int, frame: np.ndarray, tid: np.ndarray, ind: np.ndarray, inperf: np.ndarray,
               ended: dict[int, int], support: np.ndarray | None = None) -> np.ndarray:
        """Final frames ``a..b`` at once: rows (n,) of their track points (frame, tid, ind, inperf;
        support: how well each point is observed, see :func:`point_support`, needed with
        ``reidentify``, ignored without). Returns (b - a + 1,) the target's track id per frame (-1: none).

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
        if self.reidentify:
            if support is None:
                raise ValueError("reidentify needs each point's support (point_support)")
            self._support = np.concatenate([self._support[keep], np.asarray(support, np.int64)])
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
            if self.reidentify:
                stop = self._challenge(t, f, stop, a, half, ended, out)
                if self.target != t:
                    return stop + 1
            out[f - a: stop - a + 1] = t
        if stop < upto:  # lost at stop + 1: re-identification may start at that same frame
            self.target = -1
        return stop + 1

    def _challenge(self, t: int, f: int, stop: int, a: int, half: float, ended: dict[int, int],
                   out: np.ndarray) -> int:
        """Beyond the paper (``reidentify``): the first frame of ``f..stop`` at which another live
        track qualified, seen in more views than the target ``t``, in more than Delta / 2 of the
        last Delta frames takes over (a switch). Returns the last frame ``t`` keeps (``stop``
        when none takes over; else the frame before the take-over, whose frame is decided)."""
        q = self._ind & (self._tid != t) & (self._frame <= stop)
        if ended:
            q &= ~member(self._tid, np.fromiter(ended, np.int64, len(ended)))
        rows = np.flatnonzero(q)
        if len(rows) == 0:
            return stop
        base = f - self.delta + 1
        mine = np.flatnonzero((self._tid == t) & (self._frame >= base) & (self._frame <= stop))
        held = np.zeros(stop - base + 1, np.int64)  # the target's support per frame (0: no point)
        np.maximum.at(held, self._frame[mine] - base, self._support[mine])
        fr = self._frame[rows] - base
        inside = fr >= 0
        rows, fr = rows[inside], fr[inside]
        rows = rows[self._support[rows] > held[fr]]
        if len(rows) == 0:
            return stop
        ids, inv = np.unique(self._tid[rows], return_inverse=True)
        mask = np.zeros(len(self._frame), bool)
        mask[rows] = True
        grp = np.full(len(self._frame), -1, np.int64)
        grp[rows] = inv
        counts = self._window_counts(mask, f, stop, grp[mask], len(ids))
        hit = np.flatnonzero(counts.max(axis=0) > half)
        if len(hit) == 0:
            return stop
        k = int(hit[0])
        self.target = self.last_target = int(ids[np.argmax(counts[:, k])])
        self.identifications += 1
        self.switches += 1
        self.counts["target_reidentifications"] = self.counts.get("target_reidentifications", 0) + 1
        self.takeovers.append(f + k)
        out[f - a: f + k - a] = t
        out[f + k - a] = self.target
        return f + k

    def _identify(self, f: int, upto: int, out: np.ndarray, a: int, half: float, ended: dict[int, int]) -> int:
        """Frames f.. while no target: the first frame a live track qualifies (Eq. 13) gets it.
        Returns the frame after the last one decided."""
        q = self._ind
        if ended:  # an ended track gets no more points: never (re-)identify it
            q = q & ~member(self._tid, np.fromiter(ended, np.int64, len(ended)))
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


def point_support(wh: np.ndarray) -> np.ndarray:
    """How well each track point is observed, for ``reidentify``: the number of views with a
    detection of it (triangulated or a plane candidate alike: see the module docstring).
    wh: (n, C, 2) detection sizes (NaN: none). Returns (n,) int64."""
    if wh.ndim != 3:
        return np.zeros(len(wh), np.int64)
    return np.count_nonzero(~np.isnan(wh[:, :, 0]), axis=1).astype(np.int64)


def backfill(decision: np.ndarray, index: np.ndarray, track_id: np.ndarray, frames: int, since: int = 0,
             before: int = -1, chain: tuple[np.ndarray, int, dict] | None = None,
             takeover: tuple[np.ndarray, np.ndarray, dict] | None = None) -> np.ndarray:
    """Hand newly identified tracks the undecided frames Eq. 13 looked back on (in place).

    decision: (F,) the target's track id per frame (-1: none); index: (n,) frame index (into
    ``decision``) of each track point; track_id: (n,) its track; frames: how far back an
    identification reaches; since: only changes of target at indices >= since are handled (the
    earlier ones were, in an earlier call); before: the decision of the frame before index 0.

    For every index ``k >= since`` where the target becomes a track ``T`` different from the
    previous frame's, the frames ``k - frames .. k - 1`` after the last frame whose target had a
    point there become ``T``'s where ``T`` has a point (a lost target is held until Eq. 13 lets
    it go, without points: those frames are open to its successor). ``chain``: the recipe's
    ``chain`` (:mod:`.chain`), (xyz (n, 3) of the points, the break's frames at most, counts):
    the look-back goes on to the tracks ``T`` continues (counted in ``target_frames_chained``).
    ``takeover``: the recipe's ``reidentify``, (indices where a challenger took the target over,
    support (n,) of each point (:func:`point_support`), counts): the frames just before a
    take-over where the new track had a point seen in at least as many views as the old target
    become the new track's -- the run of them that ends at the take-over (counted in
    ``target_frames_taken_over``).
    Returns ``decision``.
    """
    if frames <= 0 or len(decision) <= since:
        return decision
    if takeover is not None:  # first, so that the identifications below see the frames it gave
        _take_over(decision, index, track_id, frames, before, *takeover)
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
            if chain is not None:
                xyz, gap, counts = chain
                counts["target_frames_chained"] += chain_back(decision, pointed, index, track_id, xyz, int(decision[k]),
                                                              lo, gap)
    return decision


def _take_over(decision: np.ndarray, index: np.ndarray, track_id: np.ndarray, frames: int, before: int,
               at: np.ndarray, support: np.ndarray, counts: dict) -> None:
    """The take-overs' look-back of :func:`backfill` (in place)."""
    for k in np.asarray(at, np.int64).tolist():  # one per take-over: rare
        old = int(decision[k - 1]) if k > 0 else before
        new = int(decision[k])
        lo = max(0, k - frames)
        if old < 0 or new < 0 or old == new or lo >= k:
            continue
        s_old, s_new = np.zeros(k - lo, np.int64), np.zeros(k - lo, np.int64)
        for t, s in ((old, s_old), (new, s_new)):
            m = (track_id == t) & (index >= lo) & (index < k)
            np.maximum.at(s, index[m] - lo, support[m])
        beaten = (decision[lo:k] == old) & (s_new >= s_old) & (s_new > 0)
        held = np.flatnonzero(~beaten)
        first = lo + (int(held[-1]) + 1 if len(held) else 0)
        decision[first:k] = new
        counts["target_frames_taken_over"] = counts.get("target_frames_taken_over", 0) + (k - first)


class TargetBackfill:
    """The target decisions of the last ``frames`` final frames, held back for :func:`backfill`.

    :meth:`push` takes the decisions of a run of final frames and the track points of those
    frames (:class:`~.types.TargetRows`, all tracks); :meth:`pop` releases the target's points of
    the frames up to a given one. State: the points of at most ``frames`` + one call's frames.
    """

    def __init__(self, frames: int, chain: tuple[int, dict] | None = None, takeover: dict | None = None):
        self.frames = int(frames)
        self.chain = chain  # the recipe's chain (.chain): (the break's frames at most, counts)
        self.takeover = takeover  # the recipe's reidentify: its counts
        self._first: int | None = None  # first frame not yet released
        self._decision = np.zeros(0, np.int64)
        self._rows: TargetRows | None = None
        self._last = -1  # decision of the last released frame

    def __len__(self) -> int:
        return 0 if self._rows is None else len(self._rows)

    def push(self, a: int, decision: np.ndarray, rows: TargetRows, takeovers: Sequence[int] = ()) -> None:
        """Final frames ``a .. a + len(decision) - 1``: their decisions (track id or -1) and the
        track points of those frames in frame order; ``takeovers``: the frames among them where a
        challenger took the target over (:meth:`TargetSelector.pop_takeovers`)."""
        if self._first is None:
            self._first = a
        if a != self._first + len(self._decision):
            raise ValueError(f"frames must follow on: got {a}, expected {self._first + len(self._decision)}")
        since = len(self._decision)
        self._decision = np.concatenate([self._decision, np.asarray(decision, np.int64)])
        self._rows = rows if self._rows is None else TargetRows.concat([self._rows, rows])
        chain = None if self.chain is None else (self._rows.xyz, *self.chain)
        take = None
        if self.takeover is not None and len(takeovers):
            take = (np.asarray(takeovers, np.int64) - self._first, point_support(self._rows.wh), self.takeover)
        backfill(self._decision, self._rows.frame - self._first, self._rows.track_id, self.frames, since, self._last, chain,
                 take)

    def restart(self) -> None:
        """After every decision was released: the next :meth:`push` may start at any later frame."""
        self._first, self._decision, self._rows = None, self._decision[:0], None

    def pop(self, upto: int | None = None) -> TargetRows | None:
        """Release the frames up to ``upto`` (None: all): the target's points among them (frame
        order), or None when it has none."""
        if self._first is None or len(self._decision) == 0:
            return None
        n = len(self._decision) if upto is None else min(max(upto - self._first + 1, 0), len(self._decision))
        if n == 0:
            return None
        fr, tid = self._rows.frame, self._rows.track_id
        done = fr < self._first + n
        off = fr[done] - self._first
        take = np.flatnonzero(done)[tid[done] == self._decision[off]]
        out = self._rows.take(take) if len(take) else None
        self._rows = self._rows.take(~done)
        self._last = int(self._decision[n - 1])
        self._decision = self._decision[n:]
        self._first += n
        return out

