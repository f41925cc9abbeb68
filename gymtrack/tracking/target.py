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
* :func:`buffered_boxes` -- Eq. 14. The smoothed 3D centre is projected into every view
  (raw pixels, with distortion) and gets the square box of side ``box_scale * l``: ``l`` is
  ``max(w, h)`` of the target's detection in that view at that frame; without one, the last
  ``l`` seen in that view scaled by the change of depth; in a view that never saw the target,
  the projected length of the body's top-bottom segment. A box is given when the centre is in
  front of the camera and inside the image.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.signal import savgol_coeffs

from ..formats.scene import in_box
from ..geometry.camera import Rig, _distort_normalised
from .types import INTERPOLATED

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
        Returns (b - a + 1,) the target's track id per frame (-1: none)."""
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
        ended_ids = np.fromiter(ended, np.int64, len(ended)) if ended else None
        # beyond the last point + Delta the window is empty: no target (spares long pauses a loop)
        upto = min(b, int(self._frame.max()) + self.delta - 1)
        if upto < b:
            out[upto - a + 1:] = -1
        for f in range(a, upto + 1):
            win = (self._frame > f - self.delta) & (self._frame <= f)
            if self.target >= 0:
                t = self.target
                gone = t in ended and f > ended[t]
                if gone or np.count_nonzero(win & self._inperf & (self._tid == t)) <= half:
                    self.target = -1
            if self.target < 0:
                q = win & self._ind
                if q.any():
                    ids, counts = np.unique(self._tid[q], return_counts=True)
                    if ended_ids is not None:  # an ended track gets no more points: never (re-)identify it
                        live = ~np.isin(ids, ended_ids)
                        ids, counts = ids[live], counts[live]
                    if len(counts) and counts.max() > half:
                        self.target = int(ids[np.argmax(counts)])  # first maximum = smallest id among ties
                        self.identifications += 1
                        if self.last_target >= 0 and self.target != self.last_target:
                            self.switches += 1
                        self.last_target = self.target
            out[f - a] = self.target
        if upto < b:
            self.target = -1
        return out


@lru_cache(maxsize=None)
def _smoothing_weights(left: int, right: int, order: int) -> np.ndarray:
    """Savitzky-Golay weights for a point with ``left`` / ``right`` neighbours: (left+right+1,)."""
    n = left + right + 1
    if n == 1:
        return np.ones(1)
    return savgol_coeffs(n, min(order, n - 1), pos=left, use="dot")


class TargetSmoother:
    """Gap filling and centred smoothing of the target trajectory, streaming.

    Points are pushed in frame order as ``(frame, track_id, xyz (3,), top_z, bottom_z, source,
    ell (C,))`` (``ell``: the target's ``max(w, h)`` per view, NaN where no detection).
    Emitted rows have the same layout with ``xyz`` smoothed. State: the points of the current
    segment not yet emitted plus ``half_window`` points of context.
    """

    def __init__(self, max_gap: int = 7, half_window: int = SMOOTH_HALF_WINDOW, order: int = SMOOTH_ORDER):
        self.max_gap = int(max_gap)
        self.h = int(half_window)
        self.order = int(order)
        self._buf: list[tuple] = []
        self._done = 0  # points of _buf already emitted (context)

    def __len__(self) -> int:
        return len(self._buf)

    def push(self, point: tuple) -> list[tuple]:
        out: list[tuple] = []
        if self._buf:
            last = self._buf[-1]
            gap = point[0] - last[0] - 1
            if gap > self.max_gap:
                out += self.close()
            elif gap > 0:
                a = (np.arange(1, gap + 1) / (gap + 1))[:, None]
                xyz = last[2] * (1 - a) + point[2] * a
                top = last[3] * (1 - a[:, 0]) + point[3] * a[:, 0]
                bot = last[4] * (1 - a[:, 0]) + point[4] * a[:, 0]
                nan = np.full_like(point[6], np.nan)
                for g in range(gap):
                    self._buf.append((last[0] + g + 1, point[1], xyz[g], top[g], bot[g], INTERPOLATED, nan))
        self._buf.append(point)
        out += self._emit(final=False)
        return out

    def advance(self, final_frame: int) -> list[tuple]:
        """Every frame up to ``final_frame`` is final: close the segment if its gap can no longer be filled."""
        if self._buf and final_frame - self._buf[-1][0] > self.max_gap:
            return self.close()
        return []

    def close(self) -> list[tuple]:
        out = self._emit(final=True)
        self._buf, self._done = [], 0
        return out

    def _emit(self, final: bool) -> list[tuple]:
        buf, h = self._buf, self.h
        n = len(buf)
        ready = n if final else n - h
        out = []
        if ready > self._done:
            xyz = np.stack([p[2] for p in buf])
            for i in range(self._done, ready):
                left, right = min(h, i), min(h, n - 1 - i)
                w = _smoothing_weights(left, right, self.order)
                p = buf[i]
                out.append((p[0], p[1], w @ xyz[i - left : i + right + 1], *p[3:]))
            self._done = ready
        if self._done > h:  # keep h emitted points as left context
            drop = self._done - h
            self._buf = buf[drop:]
            self._done -= drop
        return out


_RIG_ARRAYS: dict[int, tuple] = {}


def _rig_arrays(rig: Rig) -> tuple:
    """(R (C,3,3), t (C,3), K (C,3,3), dist (C,8)) of a rig, cached per rig object."""
    hit = _RIG_ARRAYS.get(id(rig))
    if hit is not None and hit[0] is rig:
        return hit[1]
    dist = np.zeros((len(rig), 8))
    for i, c in enumerate(rig):
        dist[i, : c.dist.size] = c.dist[:8]
    arrays = (np.stack([c.R for c in rig]), np.stack([c.t for c in rig]), np.stack([c.K for c in rig]), dist)
    if len(_RIG_ARRAYS) > 16:
        _RIG_ARRAYS.clear()
    _RIG_ARRAYS[id(rig)] = (rig, arrays)
    return arrays


def project_all(rig: Rig, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Project points into every camera at once (raw pixels, with distortion).

    X: (N, 3) world points. Returns (uv (N, C, 2), depth (N, C)); uv is NaN behind a camera.
    Same model as :meth:`Camera.project`, vectorised over the cameras.
    """
    R, t, K, dist = _rig_arrays(rig)
    Xc = np.einsum("cij,nj->nci", R, np.asarray(X, dtype=np.float64)) + t  # (N, C, 3)
    z = Xc[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.where(z > 1e-12, Xc[..., 0] / z, np.nan)
        y = np.where(z > 1e-12, Xc[..., 1] / z, np.nan)
    x, y = _distort_normalised(x, y, dist.T)
    u = K[:, 0, 0] * x + K[:, 0, 1] * y + K[:, 0, 2]
    v = K[:, 1, 1] * y + K[:, 1, 2]
    return np.stack([u, v], axis=-1), z


def buffered_boxes(
    rig: Rig,
    xyz: np.ndarray,
    top_z: np.ndarray,
    bottom_z: np.ndarray,
    ell: np.ndarray,
    box_scale: float,
    memory: dict,
) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 14 boxes of the target in every view, for rows in frame order.

    xyz: (N, 3) smoothed centres; top_z, bottom_z: (N,); ell: (N, C) ``max(w, h)`` of the
    target's detection per view (NaN: none); box_scale: alpha; memory: dict carried between
    calls (``"ell"`` and ``"depth"``: (C,) last seen size and the depth it was seen at).

    Returns (box (N, C, 4) centre-form raw-pixel squares, ok (N, C) bool).
    """
    N, C = ell.shape
    box = np.full((N, C, 4), np.nan)
    ok = np.zeros((N, C), bool)
    if N == 0:
        return box, ok
    mem_ell = memory.setdefault("ell", np.full(C, np.nan))
    mem_depth = memory.setdefault("depth", np.full(C, np.nan))
    uv, depth = project_all(rig, xyz)
    seen = np.isfinite(ell)
    # carry the last seen size forward, scaled by depth (apparent size ~ 1 / depth)
    last = np.maximum.accumulate(np.where(seen, np.arange(N)[:, None], -1), axis=0)
    prev = np.maximum(last, 0)
    cols = np.arange(C)
    src_ell = np.where(last >= 0, ell[prev, cols], mem_ell)
    src_depth = np.where(last >= 0, depth[prev, cols], mem_depth)
    with np.errstate(invalid="ignore", divide="ignore"):
        size = np.where(seen, ell, src_ell * src_depth / depth)
    never = ~np.isfinite(size)
    if never.any():  # a view that never saw the target: the projected top-bottom extent
        n, c = np.nonzero(never)
        tops, _ = project_all(rig, np.column_stack([xyz[n, :2], top_z[n]]))
        bots, _ = project_all(rig, np.column_stack([xyz[n, :2], bottom_z[n]]))
        size[n, c] = np.linalg.norm(tops[np.arange(len(n)), c] - bots[np.arange(len(n)), c], axis=1)
    side = box_scale * size
    box[..., :2] = uv
    box[..., 2] = box[..., 3] = side
    sizes = np.array([cam.size for cam in rig], dtype=np.float64)  # (C, 2) width, height
    with np.errstate(invalid="ignore"):
        ok = (depth > 0) & (size > 0) & np.all((uv >= 0) & (uv <= sizes), axis=-1)
    has = seen.any(axis=0)
    if has.any():
        i = N - 1 - np.argmax(seen[::-1], axis=0)  # last row with a detection, per camera
        mem_ell[has] = ell[i[has], cols[has]]
        mem_depth[has] = depth[i[has], cols[has]]
    return box, ok
