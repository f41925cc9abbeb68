"""The target handed over to the track that takes up where its track ended (the recipe's ``handover``).

Paper: Section III-D, Eq. 13. When the target's track ends (linking did not continue it), the
paper re-identifies a target by Eq. 13: more than Delta / 2 of the last Delta frames in the
performance space with the body's top above ``h_top`` *and its bottom above* ``h_bot``. A gymnast
who lost their track while standing -- a vault's landing, where the floor hypothesis or a broken
2D track starts a new track -- never passes the bottom rule again, and the target is lost for
the rest of the performance although a track follows the gymnast.

Handover: a track born between ``Delta / 2`` frames before the target track's end and ``Delta /
2`` frames after it, one of whose points of its first ``Delta / 2`` frames lies within
:data:`RADIUS` of the target track's last point, continues the target (the nearest such). Its
early points, not its first alone: a new track's first point can be off by a wrong cluster -- a
vault's landing track at n_cam = 2 was born 1.3 m off the gymnast, a third view's coach in her
cluster, and was on her 12 frames later (seed-3 suite, r2: target FR 24.1 -> 3.3 %).
For the selector, the new track's points after the old track's end carry the old track's id (an
*alias*), so Eq. 13's counts run on; the target's output rows keep the real track ids (a
handover shows as a track id change of the target, never hidden). Only the target changes:
the 3D tracks are the same with or without it. Counted in ``target_handovers``. The rows of
the new track the selector already holds (after the old track's end) are renamed too, so that
they count for the target at once.

With the recipe's ``ballistic`` (:mod:`.ballistic`): when the target's track ended in the air,
the new track is sought where the flight's parabola puts the target at the new track's early
frames (within :data:`RADIUS`), among the tracks born up to the prediction's reach; until then
(or until the reach passes) the target is held (its track is not reported ended to the
selector), and the held frames get the predicted points. Counted in ``ballistic_handovers``.

State (bounded): the points of the first ``Delta / 2`` frames of the tracks born in the last
``2 Delta`` frames, the last points of the tracks seen in that time,
the aliases of tracks seen in that time, the target track's last point.
"""

from __future__ import annotations

import numpy as np

__all__ = ["RADIUS", "TargetHandover"]

RADIUS = 1.0  #: metres: one of the new track's early points from the target track's last one, at most


class TargetHandover:
    """Aliases for :class:`~.identify.TargetSelector` (see the module docstring).

    delta: Eq. 13's Delta (frames); counts: the tracker's counters (``target_handovers``);
    flights: a :class:`~.ballistic.FlightKeeper` (the recipe's ``ballistic``) or None; plain: the
    handover where the track ended (the recipe's ``handover``; False: only flights are handed over).
    Use per run of final frames: ``sel_tid, ended_sel = h.step(frame, tid, xyz, ended, selector)``,
    then the selector on ``sel_tid`` / ``ended_sel``, then ``h.actual(a, target, frame, tid, sel_tid)``.
    """

    def __init__(self, delta: int, counts: dict, radius: float = RADIUS, flights=None, plain: bool = True):
        self.plain = plain  # hand over where the track ended (the recipe's handover); else only flights
        self.flights = flights  # a .ballistic.FlightKeeper (the recipe's ballistic) or None
        self.pending: dict[int, tuple[int, int, object]] = {}  # root -> (old live track, its end, flight)
        self.delta, self.half, self.radius, self.counts = int(delta), max(1, int(delta) // 2), float(radius), counts
        self.alias: dict[int, tuple[int, int]] = {}  # track -> (root, from frame: its rows after this carry root)
        self.live: dict[int, int] = {}  # root -> the track carrying it now
        # track -> (frames (n,), points (n, 3)) of its first Delta / 2 frames, recent births
        self.first: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self.last: dict[int, tuple[int, np.ndarray]] = {}  # root -> (frame, point) of its live track's last row
        self.ends: dict[int, tuple[int, np.ndarray]] = {}  # track -> (frame, point) of its last row, recent tracks
        self.seen_max = -1

    def __len__(self) -> int:
        return len(self.alias) + len(self.first) + len(self.last) + len(self.ends) + len(self.pending)

    def _rename(self, frame: np.ndarray, tid: np.ndarray) -> np.ndarray:
        sel = tid.copy()
        for n, (root, since) in self.alias.items():
            sel[(tid == n) & (frame > since)] = root
        return sel

    def step(self, frame: np.ndarray, tid: np.ndarray, xyz: np.ndarray, ended: dict[int, int], selector
             ) -> tuple[np.ndarray, dict[int, int]]:
        """Rows (n,) of final track points: their ids as the selector sees them, and ``ended`` as it sees it."""
        if len(tid) and int(tid.max()) > self.seen_max:  # births: rows are in frame order, first row first
            new = np.flatnonzero(tid > self.seen_max)
            ids, at = np.unique(tid[new], return_index=True)
            for k, i in zip(ids.tolist(), new[at].tolist()):
                self.first[k] = (frame[i:i + 1].copy(), xyz[i:i + 1].copy())
            self.seen_max = int(ids[-1])
        if len(tid) and self.first:  # the points of the young tracks' first Delta / 2 frames
            self._keep_early(frame, tid, xyz)
        if len(tid):  # every track's last point (a target identified after its track ended needs it)
            ids, at = np.unique(tid[::-1], return_index=True)
            for k, i in zip(ids.tolist(), (len(tid) - 1 - at).tolist()):
                self.ends[k] = (int(frame[i]), xyz[i])
        root = selector.target if selector.target >= 0 else selector.last_target
        if root >= 0:
            live = self.live.get(root, root)
            if live in self.ends:
                self.last[root] = self.ends[live]
            if live in ended and root in self.last and root not in self.pending:
                self.selector = selector
                self._hand_over(root, live, ended[live])
        self.selector = selector
        for r, (live, end, fl) in list(self.pending.items()):  # flights awaiting the track that resumes them
            if self.live.get(r, r) != live or self._hand_over(r, live, end, fl):
                self.pending.pop(r)
            elif len(frame) and int(frame.max()) > fl.reach():
                self.pending.pop(r)
        sel = self._rename(frame, tid) if self.alias else tid
        ended_sel = ended
        if self.live:
            ended_sel = {k: v for k, v in ended.items() if k not in self.live}
            for r, live in self.live.items():
                if live in ended:
                    ended_sel[r] = ended[live]
        if self.pending:  # held through the flight
            ended_sel = {k: v for k, v in ended_sel.items() if k not in self.pending}
        self._forget(int(frame.max()) if len(frame) else None)
        return sel, ended_sel

    def _keep_early(self, frame: np.ndarray, tid: np.ndarray, xyz: np.ndarray) -> None:
        """Append to ``first`` the rows (n,) of tracks born less than Delta / 2 frames before them
        (after the rows kept already); a track past that age is no longer collected."""
        for k, (f, p) in list(self.first.items()):
            if int(frame[0]) >= f[0] + self.half:
                continue
            m = (tid == k) & (frame > f[-1]) & (frame < f[0] + self.half)
            if m.any():
                self.first[k] = (np.r_[f, frame[m]], np.r_[p, xyz[m]])

    def flying(self, selector) -> int:
        """The track whose flight the target stage predicts: the live track of the target, or of a
        flight awaiting its resuming track (-1: none)."""
        root = selector.target if selector.target >= 0 else next(iter(self.pending), -1)
        return -1 if root < 0 else self.live.get(root, root)

    def _hand_over(self, root: int, live: int, end: int, flight=None) -> bool:
        """The new track that continues ``root`` (its live track ``live`` ended at ``end``), if
        any; a flight in the air at ``end`` is held pending instead (:mod:`.ballistic`)."""
        f_last, p_last = self.last[root]
        if flight is None and self.flights is not None:
            flight = self.flights.airborne(live, end)
        if flight is None and not self.plain:
            return False
        best, best_d = -1, self.radius
        hi = end + self.half if flight is None else max(end + self.half, flight.reach())
        for k, (f, q) in self.first.items():
            if k == live or k in self.alias or k == root or not (end - self.half <= f[0] <= hi):
                continue
            # the nearest of its first Delta / 2 frames: a first point off by a wrong cluster (a
            # third view's coach) still hands over once the track is on the gymnast
            ref = p_last[None] if flight is None else flight.predict(f)
            d = float(np.linalg.norm(q - ref, axis=1).min())
            if d <= best_d:
                best, best_d = k, d
        if best < 0:
            if flight is not None:
                self.pending[root] = (live, end, flight)
            return False
        self.alias[best] = (root, end)
        self.live[root] = best
        self.counts["target_handovers"] += 1
        if flight is not None:
            self.counts["ballistic_handovers"] += 1
        sel = self.selector
        sel.rename(best, root, end)  # the new track's rows it holds already count for the target
        if sel.target < 0 and sel.last_target == root:  # lost at the old track's end: resumed
            sel.target = root
        return True

    def actual(self, a: int, target: np.ndarray, frame: np.ndarray, tid: np.ndarray, sel: np.ndarray) -> np.ndarray:
        """The selector's target per frame ``a..`` (alias ids) as the real track ids of those frames."""
        moved = np.flatnonzero(sel != tid)
        if not len(moved):
            return target
        out = target.copy()
        i = frame[moved] - a
        ok = (i >= 0) & (i < len(out))
        hit = moved[ok][out[i[ok]] == sel[moved[ok]]]
        out[frame[hit] - a] = tid[hit]
        return out

    def _forget(self, now: int | None) -> None:
        if now is None:
            return
        old = now - 2 * self.delta
        self.first = {k: v for k, v in self.first.items() if v[0][0] >= old}
        if len(self.ends) > 2 * len(self.first) + 16:  # (rarely: the dict is rebuilt)
            self.ends = {k: v for k, v in self.ends.items() if v[0] >= old}
        for r in [r for r, (f, _) in self.last.items() if f < old]:
            self.last.pop(r)
            self.live.pop(r, None)
            self.pending.pop(r, None)
            self.alias = {k: v for k, v in self.alias.items() if v[0] != r}
