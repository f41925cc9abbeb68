"""Filtering joint tracks the way fast sport motion needs: per support segment, never across a
take-off or a landing, with a cut-off high enough for a 3 rev/s twist.

Paper: Section III-D, last paragraph (the 3D pose the judging layer reads). Rule: a zero-phase
2nd-order Butterworth low-pass (``scipy.signal.filtfilt``) at ``min(CUTOFF_HZ, 0.4 fps)``, run
separately inside every run of frames with one support (floor, apparatus, airborne) and no frame
gap over :data:`MAX_GAP` frames. A take-off or landing is a jump in acceleration that a filter
across it would smear into the neighbouring frames (a flight would start early and end late).
The 8 Hz cut-off keeps 98 % of a 3 Hz oscillation (a 3 rev/s twist); a 6 Hz walking filter
would flatten the fastest twists' joint paths and the take-off's impulse. So airborne segments
take :data:`CUTOFF_HZ`; segments on the floor or the apparatus take :data:`SUPPORT_CUTOFF_HZ`,
6 Hz, the cut-off Winter's residual analysis gives for body markers in walking and widely used
for human movement (Winter, Biomechanics and Motor Control of Human Movement, 4th ed., 2009,
ch. 2): on support the joints move with the body's own muscles and the apparatus (giants and
circles turn at 1-1.5 rev/s), not with a free twist, and a measured skeleton's joint noise there
is what the knee and hip angles read.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy.signal import butter, filtfilt

CUTOFF_HZ = 8.0  #: airborne segments (twists up to 3-4 rev/s)
SUPPORT_CUTOFF_HZ = 6.0  #: segments on the floor or the apparatus (Winter's 6 Hz, residual analysis)
MAX_GAP = 2  #: frames: a larger gap between rows ends a segment
MIN_LEN = 10  #: frames: shorter segments are left as they are (filtfilt needs some padding)


def segments(frame: np.ndarray, support: np.ndarray) -> list[tuple[int, int]]:
    """[(start, stop)] row ranges of equal support without a frame gap over MAX_GAP."""
    if len(frame) == 0:
        return []
    cut = np.flatnonzero((np.diff(support) != 0) | (np.diff(frame) > MAX_GAP)) + 1
    edges = np.concatenate([[0], cut, [len(frame)]])
    return list(zip(edges[:-1].tolist(), edges[1:].tolist()))


def segment_cutoffs(segs: list[tuple[int, int]], support: np.ndarray, airborne_hz: float | None,
                    supported_hz: float | None) -> list[float | None]:
    """The cut-off of each segment: ``airborne_hz`` where the body flies (support none), else
    ``supported_hz`` (``airborne_hz`` where that is None)."""
    if airborne_hz is None or airborne_hz <= 0:
        return [None] * len(segs)
    on = airborne_hz if supported_hz is None else supported_hz
    return [airborne_hz if support[s0] == 0 else on for s0, _ in segs]


def filter_joints(X: np.ndarray, segs: list[tuple[int, int]], fps: float,
                  cutoff_hz: float | Sequence[float | None] | None = CUTOFF_HZ) -> np.ndarray:
    """X (..., M, K, 3) low-passed along M inside each segment; a joint with a gap (NaN) in a
    segment is left unfiltered there. ``cutoff_hz``: one for all segments or one per segment
    (:func:`segment_cutoffs`); None: no filtering."""
    cuts = list(cutoff_hz) if isinstance(cutoff_hz, (list, tuple)) else [cutoff_hz] * len(segs)
    if not any(c is not None and c > 0 for c in cuts):
        return X
    coef = {}
    out = X.copy()
    for (s0, s1), fc in zip(segs, cuts):
        if s1 - s0 < MIN_LEN or fc is None or fc <= 0:
            continue
        if fc not in coef:
            coef[fc] = butter(2, min(fc, 0.4 * fps) / (fps / 2))
        b, a = coef[fc]
        part = X[..., s0:s1, :, :]
        ok = np.isfinite(part).all(axis=-1).reshape(-1, part.shape[-2]).all(axis=0)  # (K,)
        if not ok.any():
            continue
        sub = part[..., ok, :]
        pad = min(3 * max(len(a), len(b)), s1 - s0 - 1)
        out[..., s0:s1, ok, :] = filtfilt(b, a, sub, axis=-3, padlen=pad)
    return out
