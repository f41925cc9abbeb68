"""Filtering joint tracks the way fast sport motion needs: per support segment, never across a
take-off or a landing, with a cut-off high enough for a 3 rev/s twist.

Paper: Section III-D, last paragraph (the 3D pose the judging layer reads). Rule: a zero-phase
2nd-order Butterworth low-pass (``scipy.signal.filtfilt``) at ``min(CUTOFF_HZ, 0.4 fps)``, run
separately inside every run of frames with one support (floor, apparatus, airborne) and no frame
gap over :data:`MAX_GAP` frames. A take-off or landing is a jump in acceleration that a filter
across it would smear into the neighbouring frames (a flight would start early and end late).
The 8 Hz cut-off keeps 98 % of a 3 Hz oscillation (a 3 rev/s twist); a 6 Hz walking filter
would flatten the fastest twists' joint paths and the take-off's impulse.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import butter, filtfilt

CUTOFF_HZ = 8.0
MAX_GAP = 2  #: frames: a larger gap between rows ends a segment
MIN_LEN = 10  #: frames: shorter segments are left as they are (filtfilt needs some padding)


def segments(frame: np.ndarray, support: np.ndarray) -> list[tuple[int, int]]:
    """[(start, stop)] row ranges of equal support without a frame gap over MAX_GAP."""
    if len(frame) == 0:
        return []
    cut = np.flatnonzero((np.diff(support) != 0) | (np.diff(frame) > MAX_GAP)) + 1
    edges = np.concatenate([[0], cut, [len(frame)]])
    return list(zip(edges[:-1].tolist(), edges[1:].tolist()))


def filter_joints(X: np.ndarray, segs: list[tuple[int, int]], fps: float, cutoff_hz: float | None = CUTOFF_HZ) -> np.ndarray:
    """X (..., M, K, 3) low-passed along M inside each segment; a joint with a gap (NaN) in a
    segment is left unfiltered there. ``cutoff_hz`` None: no filtering."""
    if cutoff_hz is None or cutoff_hz <= 0:
        return X
    wn = min(cutoff_hz, 0.4 * fps) / (fps / 2)
    b, a = butter(2, wn)
    out = X.copy()
    for s0, s1 in segs:
        if s1 - s0 < MIN_LEN:
            continue
        part = X[..., s0:s1, :, :]
        ok = np.isfinite(part).all(axis=-1).reshape(-1, part.shape[-2]).all(axis=0)  # (K,)
        if not ok.any():
            continue
        sub = part[..., ok, :]
        pad = min(3 * max(len(a), len(b)), s1 - s0 - 1)
        out[..., s0:s1, ok, :] = filtfilt(b, a, sub, axis=-3, padlen=pad)
    return out
