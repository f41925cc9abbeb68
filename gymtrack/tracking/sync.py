"""Camera synchronisation from the data: each camera's frame offset from its boxes.

Beyond the paper, which assumes synchronised views (Section III-A). A camera whose frame numbers
run ``o`` frames ahead sees the moving gymnast where the others saw it ``o`` frames earlier: its
boxes leave the epipolar lines of the others' (Eq. 1). For every camera pair and every shift
``d`` the cost is the mean over both views' boxes of the smallest Eq. 1 distance to the other
view's boxes ``d`` frames away (capped, so a box whose partner is missing, or matched to another
person at a wrong shift, counts the same at every shift), each box weighted by how far it moves
across its own epipolar line over a few frames: a person standing still, or moving along the
line, looks the same at every shift and says nothing. Boxes cut by the image's edge are left
out: their centre is not the person's (it lags or leads a person walking out or in). The offsets
(camera 0 the reference, 0) are the joint choice over ``+-search`` frames that minimises the sum
of the pairs' costs, each pair's curve scaled by its median and weighted by its depth, plus a
small cost per camera moved. Sub-frame: a parabola through the joint cost at the best offset
and its neighbours. Confidence per camera: how much worse its best offset two or more frames
away is, as a share of the cost's spread (0: a tie, the data cannot decide; 1: one offset
stands out).

Convention (scene.yaml ``frame_offsets``): a camera with offset ``o`` shows at its frame ``f``
what the reference shows at frame ``f - o``.

Shapes: boxes gathered per camera as (T, K, 4) undistorted centre-form boxes, NaN padded (K the
most boxes of one frame, up to ``max_boxes`` by score).
"""

from __future__ import annotations

import itertools
import warnings
from dataclasses import dataclass

import numpy as np

from ..detections import Detections
from ..geometry.camera import Rig
from ..geometry.epipolar import fundamental_matrices

__all__ = ["SyncResult", "estimate_offsets", "offsets_from_costs", "pair_costs", "cut_by_border"]

CAP = 0.3  # Eq. 1 distance a box with no partner counts for (the same person: about 0.03-0.1 in sync)
PRIOR = 0.03  # the cost of moving a camera, as a share of a pair's mean cost depth
LAG = 2  # frames either side over which a box's motion is measured
NEIGHBOUR = 0.5  # the nearest box within this share of the size is the same person
MOTION_CAP = 0.5  # most a box weighs (its motion across the line, by size)
LOW_CONFIDENCE = 0.05  # below this a camera's offset is reported as undecided
BORDER = 2.0  # pixels: a box this near the image's edge is cut by it


@dataclass(frozen=True)
class SyncResult:
    """Offsets of every camera against the reference (camera 0).

    offsets: (C,) int, frames; offsets_subframe: (C,) float; confidence: (C,) in [0, 1];
    cost: (C, 2 * search + 1) the joint cost over each camera's offset, the others at their best;
    frames: frames with boxes in at least two views that the estimate used.
    """

    names: tuple[str, ...]
    offsets: np.ndarray
    offsets_subframe: np.ndarray
    confidence: np.ndarray
    cost: np.ndarray
    search: int
    frames: int

    def undecided(self) -> list[str]:
        """Cameras (not the reference) whose offset the data cannot decide."""
        return [n for n, c in zip(self.names[1:], self.confidence[1:]) if not c >= LOW_CONFIDENCE]

    def as_dict(self) -> dict:
        return {n: {"offset": int(o), "subframe": round(float(s), 2), "confidence": round(float(c), 3)}
                for n, o, s, c in zip(self.names, self.offsets, self.offsets_subframe, self.confidence)}


def _dense(det: Detections, rig: Rig, f0: int, T: int, max_boxes: int) -> np.ndarray:
    """(C, T, K, 4) undistorted boxes per camera and frame (NaN padded), the best-scored first."""
    C = len(rig)
    order = np.lexsort((-det.score, det.frame, det.camera))
    cam, frame = det.camera[order].astype(np.int64), det.frame[order] - f0
    key = cam * T + frame
    first = np.r_[0, np.flatnonzero(np.diff(key)) + 1]
    rank = np.arange(len(key)) - np.repeat(first, np.diff(np.r_[first, len(key)]))
    K = int(min(max_boxes, rank.max() + 1)) if len(rank) else 1
    keep = rank < K
    out = np.full((C, T, K, 4), np.nan)
    box = det.box[order][keep].astype(np.float64)
    for c in range(C):  # undistorted centres (Eq. 1 is for undistorted pixels); sizes kept
        m = cam[keep] == c
        if m.any():
            box[m, :2] = rig[c].undistort(box[m, :2])
    out[cam[keep], frame[keep], rank[keep]] = box
    return out


def pair_costs(det: Detections, rig: Rig, shifts: np.ndarray, max_boxes: int = 12,
               frames: tuple[int, int] | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """(C, C, S) cost of every camera pair (i < j filled) at every shift ``d`` of ``shifts`` (S,):
    view j's frame ``t + d`` against view i's frame ``t``; (C, C, S) how many moving boxes it weighed;
    the number of frames with boxes in two views or more."""
    C = len(rig)
    if frames is not None:
        det = det.select(np.flatnonzero((det.frame >= frames[0]) & (det.frame <= frames[1])))
    det = det.select(np.flatnonzero(~_at_border(det, rig)))
    if not len(det):
        return np.full((C, C, len(shifts)), np.nan), np.zeros((C, C, len(shifts))), 0
    f0 = int(det.frame.min())
    T = int(det.frame.max()) - f0 + 1
    B = _dense(det, rig, f0, T, max_boxes)
    has = np.isfinite(B[..., 0]).any(axis=2)  # (C, T)
    F = fundamental_matrices(rig)
    cost = np.full((C, C, len(shifts)), np.nan)
    count = np.zeros((C, C, len(shifts)))
    X = np.concatenate([B[..., :2], np.ones(B.shape[:-1] + (1,))], -1)  # (C, T, K, 3) homogeneous
    size = B[..., 2] + B[..., 3]
    for i, j in itertools.combinations(range(C), 2):
        num, den = np.zeros(len(shifts)), np.zeros(len(shifts))
        for u, v, sign in ((i, j, 1), (j, i, -1)):  # view u's boxes against view v's, both ways
            Fuv = F[u, v]
            lv = _unit_lines(X[u] @ Fuv.T)  # view u's boxes as lines in view v (T, K, 3)
            lu = _unit_lines(X[v] @ Fuv)  # view v's boxes as lines in view u
            w = _across_motion(X[u], B[u], np.linalg.svd(Fuv)[2][-1])
            for s, d in enumerate(sign * shifts):
                a, b = max(0, -d), min(T, T - d)  # frames t of view u with t + d inside
                if b <= a:
                    continue
                both = np.flatnonzero(has[u, a:b] & has[v, a + d:b + d]) + a
                if not len(both):
                    continue
                # Eq. 1 of every box pair (n, K, K): each point's distance to the other's line, by box size
                du = np.abs(np.einsum("nac,nbc->nab", X[u, both], lu[both + d])) / size[u, both][:, :, None]
                dv = np.abs(np.einsum("nac,nbc->nab", lv[both], X[v, both + d])) / size[v, both + d][:, None, :]
                D = np.fmin(np.where(np.isfinite(du + dv), du + dv, np.inf).min(axis=2), CAP)
                ws = w[both]
                num[s] += (ws * D).sum()
                den[s] += ws.sum()
                count[i, j, s] += np.count_nonzero(ws)
        with np.errstate(invalid="ignore", divide="ignore"):
            cost[i, j] = np.where(den > 0, num / den, np.nan)
    return cost, count, int((has.sum(axis=0) >= 2).sum())


def _at_border(det: Detections, rig: Rig) -> np.ndarray:
    """(N,) boxes that touch the image's edge (raw pixels). The border cuts them: their centre is
    not the person's but moves at about half its speed as the person walks in or out, as if that
    view ran early or late, and leans the pair's curve by a frame or more."""
    return cut_by_border(np.array([cam.size for cam in rig], np.float64)[det.camera], det.box)


def cut_by_border(size: np.ndarray, box: np.ndarray) -> np.ndarray:
    """(n, 2) each box's image size (width, height), (n, 4) centre-form boxes (raw pixels) -> (n,)
    bool, those within :data:`BORDER` of the image's edge."""
    lo, hi = box[:, :2] - box[:, 2:] / 2, box[:, :2] + box[:, 2:] / 2
    return ((lo <= BORDER) | (hi >= size - BORDER)).any(axis=1)


def _across_motion(X: np.ndarray, B: np.ndarray, epipole: np.ndarray) -> np.ndarray:
    """(T, K) how far each box moves across its epipolar line between frames ``t - LAG`` and
    ``t + LAG`` (its nearest box there, same view), by its size, capped at ``MOTION_CAP``; 0 where
    it has no neighbour. A box that moves along its line (or stands still) looks the same at
    every shift: it weighs nothing in the pair's cost."""
    T = len(X)
    size = B[..., 2] + B[..., 3]
    near = []
    for lag in (-LAG, LAG):
        Y = np.full_like(X[..., :2], np.nan)
        a, b = max(0, -lag), min(T, T - lag)
        P, Q = X[a:b, :, None, :2], X[a + lag:b + lag, None, :, :2]
        dist = np.linalg.norm(P - Q, axis=-1) / size[a:b, :, None]  # (n, K, K)
        dist = np.where(np.isfinite(dist), dist, np.inf)
        k = dist.argmin(axis=2)
        got = np.take_along_axis(dist, k[..., None], 2)[..., 0] < NEIGHBOUR
        Y[a:b] = np.where(got[..., None], np.take_along_axis(X[a + lag:b + lag, :, :2], k[..., None], 1), np.nan)
        near.append(Y)
    move = near[1] - near[0]
    normal = np.cross(X, epipole)[..., :2]  # the epipolar line through the box (it meets the epipole)
    with np.errstate(invalid="ignore", divide="ignore"):  # (a box on the epipole: no line, no weight)
        w = np.abs((move * normal).sum(-1)) / np.linalg.norm(normal, axis=-1) / size
    return np.where(np.isfinite(w), np.fmin(w, MOTION_CAP), 0.0)


def _unit_lines(lines: np.ndarray) -> np.ndarray:
    """(..., 3) lines scaled so that ``l1^2 + l2^2 = 1`` (a point's product is then its distance)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return lines / np.hypot(lines[..., 0], lines[..., 1])[..., None]


def estimate_offsets(det: Detections, rig: Rig, search: int = 10, max_boxes: int = 12,
                     frames: tuple[int, int] | None = None) -> SyncResult:
    """Every camera's frame offset against camera 0, searched over ``+-search`` frames.

    det: boxes of all cameras (raw pixels, as read); rig: their cameras; frames: an optional
    (first, last) range to use. Cameras sharing no frames with the others get confidence 0.
    """
    shifts = np.arange(-2 * search, 2 * search + 1)
    cost, _, n_frames = pair_costs(det, rig, shifts, max_boxes, frames)
    return offsets_from_costs(cost, rig.names, search, n_frames)


def offsets_from_costs(cost: np.ndarray, names: tuple[str, ...], search: int, n_frames: int = 0) -> SyncResult:
    """The joint offsets from (C, C, 4 * search + 1) pair costs (:func:`pair_costs` at shifts
    ``-2 search .. 2 search``)."""
    C = len(names)
    # a pair with no common frames adds nothing; each pair's curve scaled by its median (equal say)
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # (the lower triangle: all NaN)
        scale = np.nanmedian(cost, axis=2, keepdims=True)
        norm = cost / scale
        # each pair weighted by its curve's depth: a pair whose boxes barely tell the shifts apart
        # (static people, an opposite pair along its epipolar lines) says little
        norm = np.nan_to_num(norm * (1.0 - np.nanmin(norm, axis=2, keepdims=True)), nan=0.0)
    cand = np.arange(-search, search + 1)
    grids = np.stack(np.meshgrid(*([cand] * (C - 1)), indexing="ij"), -1).reshape(-1, C - 1)
    offs = np.concatenate([np.zeros((len(grids), 1), np.int64), grids], axis=1)  # (G, C)
    total = np.zeros(len(offs))
    for i, j in itertools.combinations(range(C), 2):
        total += norm[i, j, offs[:, j] - offs[:, i] + 2 * search]
    # a small cost for every camera moved: most cameras of a venue are in sync, and a pair's curve
    # can lean a frame off by how its views see the same people (box centres are not one 3D point)
    depth = np.array([norm[i, j].max() - norm[i, j].min() for i, j in itertools.combinations(range(C), 2)])
    total += PRIOR * depth.mean() * np.count_nonzero(offs, axis=1)
    best = offs[int(np.argmin(total))]
    curves = np.zeros((C, len(cand)))
    for c in range(1, C):  # the joint cost over camera c's offset, the others at their best
        trial = np.repeat(best[None], len(cand), 0)
        trial[:, c] = cand
        for i, j in itertools.combinations(range(C), 2):
            curves[c] += norm[i, j, trial[:, j] - trial[:, i] + 2 * search]
    sub = best.astype(np.float64)
    conf = np.ones(C)
    for c in range(1, C):
        k = best[c] + search
        g = curves[c]
        if 0 < k < len(cand) - 1:  # parabola through the best and its neighbours
            den = g[k - 1] - 2 * g[k] + g[k + 1]
            sub[c] += 0.5 * (g[k - 1] - g[k + 1]) / den if den > 0 else 0.0
        far = g[np.abs(cand - best[c]) >= 2]  # the neighbours differ little when people move slowly
        spread = np.median(far) - g[k]
        conf[c] = np.clip((far.min() - g[k]) / spread, 0, 1) if spread > 0 else 0.0
        if not np.isfinite(cost[:, c]).any() and not np.isfinite(cost[c]).any():
            conf[c] = 0.0
    return SyncResult(tuple(names), best.astype(np.int64), sub, conf, curves, search, n_frames)
