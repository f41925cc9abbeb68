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

from ._kernels import windows as kernels
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

    Returns (filled (K, W, 4) with NaN where not valid, valid (K, W) bool). One compiled loop
    (:func:`._kernels.windows.fill_missing`; numpy reference in ``tests/reference/windows.py``).
    """
    return kernels.fill_missing(np.ascontiguousarray(box, dtype=np.float64), np.ascontiguousarray(observed, dtype=bool),
                                int(max_extrapolate))


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
    inwin = np.flatnonzero((frame >= start) & (frame < start + width))
    c, tid = camera[inwin], track2d[inwin]
    # group the boxes by 2D track without sorting them: ids are small integers, so counts and
    # the segment of every box are table lookups over the id range (np.unique sorts, and its
    # extra outputs cost several passes more)
    lo = int(tid.min()) if len(tid) else 0
    rel = tid - lo
    span = int(rel.max()) + 1 if len(rel) else 0
    ids = None
    if span > 64 * len(rel) + 4096:  # ids too spread out for lookup tables: compact them first
        ids, rel = np.unique(tid, return_inverse=True)
        span = len(ids)
    counts = np.bincount(rel, minlength=span)
    cam_of = np.zeros(span, np.int64)
    cam_of[rel] = c
    keep = counts >= min_boxes
    present = np.flatnonzero(counts)
    kept = np.flatnonzero(keep)
    dropped = len(present) - len(kept)
    kept = kept[np.argsort(cam_of[kept], kind="stable")]  # segments ordered by (camera, 2D track id)
    K = len(kept)
    remap = np.full(span, -1, np.int64)
    remap[kept] = np.arange(K)
    k = remap[rel]
    use = k >= 0
    k, rows = k[use], inwin[use]
    t = frame[rows] - start
    boxes = np.full((K, width, 4), np.nan)
    observed = np.zeros((K, width), bool)
    dets = np.full((K, width), -1, np.int64)
    kt = k * width + t  # flat (segment, frame) cells: faster than 2D fancy indexing
    boxes.reshape(-1, 4)[kt] = box[rows]
    observed.ravel()[kt] = True
    dets.ravel()[kt] = det[rows]
    filled, valid = kernels.fill_missing(boxes, observed, int(max_extrapolate))
    segs = WindowTracklets(
        start=int(start), camera=cam_of[kept], track2d=(kept + lo) if ids is None else ids[kept].astype(np.int64),
        box=filled, observed=observed, valid=valid, det=dets,
    )
    return segs, dropped
