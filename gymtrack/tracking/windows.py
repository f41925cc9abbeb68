"""Sliding windows: cutting live 2D tracks into overlapping segments (paper Section III-A).

Every ``step = window // 2`` frames the 2D tracks are cut into the current window of
``window`` frames (windows overlap by half). Inside a window a segment is kept when it has at
least ``min_tracklet_boxes`` boxes, and its missing frames are filled:

* between two observed frames: linear interpolation of ``[x, y, w, h]`` (gaps inside one 2D
  track are at most ``max_age`` frames, the IoU tracker cuts longer ones);
* before the first / after the last observed frame: the nearest box is held for at most
  ``max_extrapolate`` frames (the tracker uses ``max_age``: as long as the IoU tracker itself
  would still believe in the track). Holding rather than extending the motion linearly never
  overshoots; longer extrapolation would invent a person who has left (or not yet arrived).

Frames outside that are not valid (NaN): a segment that ends mid-window gives a 3D tracklet
that ends there too, and cross-window linking only uses frames both windows really have.
"""

from __future__ import annotations

import numpy as np

from .types import WindowTracklets


def window_starts(first_frame: int, step: int, upto: int) -> np.ndarray:
    """Start frames ``first_frame + k * step`` of the windows that begin at or before ``upto``."""
    if upto < first_frame:
        return np.zeros(0, np.int64)
    return first_frame + step * np.arange((upto - first_frame) // step + 1)


def fill_missing(box: np.ndarray, observed: np.ndarray, max_extrapolate: int) -> tuple[np.ndarray, np.ndarray]:
    """Interpolate / extrapolate the missing boxes of K segments at once.

    box: (K, W, 4) boxes, anything where not observed; observed: (K, W) bool, each row with at
    least one True; max_extrapolate: frames the first/last box is held beyond the observations.

    Returns (filled (K, W, 4) with NaN where not valid, valid (K, W) bool).
    """
    K, W = observed.shape
    t = np.arange(W)
    prev = np.maximum.accumulate(np.where(observed, t, -1), axis=1)  # last observed index <= t
    nxt = np.minimum.accumulate(np.where(observed, t, W)[:, ::-1], axis=1)[:, ::-1]  # first observed >= t
    inside = (prev >= 0) & (nxt < W)
    before = (prev < 0) & (nxt - t <= max_extrapolate)
    after = (nxt >= W) & (t - prev <= max_extrapolate)
    valid = inside | before | after
    k = np.arange(K)[:, None]
    lo = np.where(prev >= 0, prev, nxt)  # 'before' frames hold the first box
    hi = np.where(nxt < W, nxt, prev)  # 'after' frames hold the last box
    lo = np.clip(lo, 0, W - 1)
    hi = np.clip(hi, 0, W - 1)
    span = hi - lo
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(span > 0, (t - lo) / np.where(span > 0, span, 1), 0.0)
    a = np.where(inside, a, 0.0)[..., None]
    filled = box[k, lo] * (1.0 - a) + box[k, hi] * a
    filled[~valid] = np.nan
    return filled, valid


def build_window(
    start: int,
    width: int,
    frame: np.ndarray,
    camera: np.ndarray,
    track2d: np.ndarray,
    box: np.ndarray,
    det: np.ndarray,
    min_boxes: int,
    max_extrapolate: int,
) -> tuple[WindowTracklets, int]:
    """Cut the 2D tracks' boxes into the segments of one window.

    Parameters
    ----------
    start, width: the window covers frames ``start .. start + width - 1``.
    frame, camera, track2d, det: (N,) per box: frame number, camera, 2D track id, detection row id.
    box: (N, 4) centre-form boxes (undistorted pixels).
        Rows outside the window are ignored; a (track, frame) pair must occur at most once.
    min_boxes: a segment needs at least this many boxes inside the window (paper: 5).
    max_extrapolate: see :func:`fill_missing`.

    Returns the window's segments (sorted by camera, then 2D track id) and the number of segments dropped
    for having too few boxes.
    """
    inwin = (frame >= start) & (frame < start + width)
    f, c, tid, b, d = frame[inwin], camera[inwin], track2d[inwin], box[inwin], det[inwin]
    uniq, first, inv, counts = np.unique(tid, return_index=True, return_inverse=True, return_counts=True)
    keep = counts >= min_boxes
    dropped = int(np.count_nonzero(~keep))
    K = int(keep.sum())
    # segments ordered by (camera, 2D track id): each camera's segments are contiguous
    kept = np.flatnonzero(keep)
    kept = kept[np.argsort(c[first[kept]], kind="stable")]
    remap = np.full(len(uniq), -1)
    remap[kept] = np.arange(K)
    rows = keep[inv]
    k = remap[inv[rows]]
    t = f[rows] - start
    boxes = np.full((K, width, 4), np.nan)
    observed = np.zeros((K, width), bool)
    dets = np.full((K, width), -1, np.int64)
    boxes[k, t] = b[rows]
    observed[k, t] = True
    dets[k, t] = d[rows]
    filled, valid = fill_missing(boxes, observed, max_extrapolate)
    segs = WindowTracklets(
        start=int(start), camera=c[first[kept]].astype(np.int64), track2d=uniq[kept].astype(np.int64),
        box=filled, observed=observed, valid=valid, det=dets,
    )
    return segs, dropped
