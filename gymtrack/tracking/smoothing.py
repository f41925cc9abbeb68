"""Gap filling and smoothing of the target's trajectory (paper Section III-D).

:class:`TargetSmoother` -- gaps of at most ``max_gap`` frames (also across a switch) are filled
by linear interpolation (source ``interpolated``; the paper: "spatiotemporal interpolation ...
if it is within 7 frames"); the trajectory is smoothed with a centred Savitzky-Golay filter
(quadratic, ``2 * half_window + 1`` frames, truncated at a segment's ends). Streaming latency:
``half_window`` frames after the point is final, and up to ``max_gap + 1`` frames at the end of
a segment (until it is known whether the gap closes). Rows: :class:`~.types.TargetRows`
(xyz (n, 3)).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.signal import savgol_coeffs

from .types import INTERPOLATED, TargetRows

SMOOTH_HALF_WINDOW = 2  # 5-frame window: at 30 fps, ~0.17 s, keeps a twist's fast turn-around
SMOOTH_ORDER = 2


@lru_cache(maxsize=None)
def _smoothing_weights(left: int, right: int, order: int) -> np.ndarray:
    """Savitzky-Golay weights for a point with ``left`` / ``right`` neighbours: (left+right+1,)."""
    n = left + right + 1
    if n == 1:
        return np.ones(1)
    return savgol_coeffs(n, min(order, n - 1), pos=left, use="dot")



class TargetSmoother:
    """Gap filling and centred smoothing of the target trajectory, streaming.

    The target's points are pushed in frame order (:class:`~.types.TargetRows`); emitted rows
    are the same points, gaps filled and ``xyz`` smoothed. State: the points of the current
    segment not yet emitted plus ``half_window`` points of context.
    """

    def __init__(self, max_gap: int = 7, half_window: int = SMOOTH_HALF_WINDOW, order: int = SMOOTH_ORDER):
        self.max_gap = int(max_gap)
        self.h = int(half_window)
        self.order = int(order)
        self._buf: TargetRows | None = None  # the current segment's kept points
        self._done = 0  # points of _buf already emitted (context)

    def __len__(self) -> int:
        return 0 if self._buf is None else len(self._buf)

    def push(self, new: TargetRows) -> TargetRows | None:
        """Push n points in increasing frame order.

        Returns the emitted rows, or None when nothing is emitted. Same result as
        pushing the points one by one: gaps of at most ``max_gap`` frames are filled by
        linear interpolation, longer gaps end the segment (all its points are emitted)."""
        if len(new) == 0:
            return None
        done = self._done
        seq = new if self._buf is None else TargetRows.concat([self._buf, new])
        gap = np.diff(seq.frame) - 1
        ends = []
        if len(gap) and gap.max() > 0:  # (rare) gaps: filled, or ending the segment
            fill = np.flatnonzero((gap > 0) & (gap <= self.max_gap))
            if len(fill):  # interpolated points, then everything back in frame order
                seq = TargetRows.concat([seq, self._interpolate(seq, fill, gap[fill])])
                seq = seq.take(np.argsort(seq.frame, kind="stable"))
                gap = np.diff(seq.frame) - 1
            ends = (np.flatnonzero(gap > self.max_gap) + 1).tolist()  # segment boundaries
        out = []
        start = 0
        for end in ends:  # every segment but the last is complete
            out.append(self._smooth(seq.take(slice(start, end)), done, end - start))
            start, done = end, 0
        last = seq.take(slice(start, None)) if start else seq
        n = len(last)
        ready = max(done, n - self.h)
        out.append(self._smooth(last, done, ready))
        drop = max(ready - self.h, 0)  # keep h emitted points as left context
        self._buf, self._done = (last.take(slice(drop, None)) if drop else last), ready - drop
        out = [o for o in out if o is not None]
        return TargetRows.concat(out) if out else None

    def advance(self, final_frame: int) -> TargetRows | None:
        """Every frame up to ``final_frame`` is final: close the segment if its gap can no longer be filled."""
        if self._buf is not None and final_frame - int(self._buf.frame[-1]) > self.max_gap:
            return self.close()
        return None

    def close(self) -> TargetRows | None:
        """End the current segment: emit all its points not yet emitted (None: nothing)."""
        buf, done = self._buf, self._done
        self._buf, self._done = None, 0
        if buf is None or len(buf) <= done:
            return None
        return self._smooth(buf, done, len(buf))

    def _interpolate(self, seq: TargetRows, after: np.ndarray, gap: np.ndarray) -> TargetRows:
        """Rows filling the gaps after points ``after`` (gaps of ``gap`` frames): linear in xyz and
        heights, the next point's track id, source interpolated, no detections."""
        i = np.repeat(after, gap)
        k = np.arange(len(i)) - np.repeat(np.cumsum(gap) - gap, gap) + 1  # 1..gap within each gap
        a = k / np.repeat(gap + 1, gap)
        fr, tid, xyz, top, bot, wh = seq.frame, seq.track_id, seq.xyz, seq.top_z, seq.bottom_z, seq.wh
        a1 = a[:, None]
        return TargetRows(fr[i] + k, tid[i + 1], xyz[i] * (1 - a1) + xyz[i + 1] * a1,
                          top[i] * (1 - a) + top[i + 1] * a, bot[i] * (1 - a) + bot[i + 1] * a,
                          np.full(len(i), INTERPOLATED, np.int8), np.full((len(i), *wh.shape[1:]), np.nan))

    def _smooth(self, seg: TargetRows, lo: int, hi: int) -> TargetRows | None:
        """Rows lo..hi-1 of a segment's points (``seg``, starting with its context) with xyz
        smoothed over the centred window, truncated at the segment's ends: points before ``lo``
        are context, points after the segment's last one do not exist (yet)."""
        if hi <= lo:
            return None
        h = self.h
        X = seg.xyz
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
        return seg.take(slice(lo, hi)).with_xyz(xyz)

