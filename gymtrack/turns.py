"""Full turns of a rotation angle: the contract's circle (``shared/formats.md``, "Outputs of the
analysis stage": one circle per full 360 deg turn of somersault about the bar while the hands hold it).

One rule for both sides of the definitions check: the simulator's ground truth
(:mod:`gymtrack.simulate.elements`, on the true joints and its grip phases) and the analysis
(:mod:`gymtrack.analysis.elements`, on the lifted skeleton and the contacts it finds) count turns
here, so the two can differ only in what they are given.
"""

from __future__ import annotations

import numpy as np

FULL_TURN_TOL_DEG = 10.0  #: a giant sampled at 30 fps stops within a frame's rotation of its handstand
SWING_BACK_DEG = 20.0  #: a swing turns back by more than this; a smaller return (a handstand's sway, noise) does not
CIRCLE_MAX_S = 3.0  #: a circle is a swing: one turn in at most this long


def turning_points(angle: np.ndarray) -> np.ndarray:
    """Indices where the rotation turns back (a swing's turning points): an extreme of ``angle``
    (N,) that the angle then leaves the other way by more than :data:`SWING_BACK_DEG` (a smaller
    return -- a handstand's sway, a measured skeleton's noise -- keeps the direction)."""
    out, d, ext, ext_i = [], 0, float(angle[0]), 0
    for i in range(1, len(angle)):
        x = float(angle[i])
        if d == 0:  # the first direction: once the angle has left its start by the threshold
            if abs(x - ext) > SWING_BACK_DEG:
                d, ext, ext_i = (1 if x > ext else -1), x, i
            continue
        if d * (x - ext) >= 0:
            ext, ext_i = x, i
        elif d * (ext - x) > SWING_BACK_DEG:
            out.append(ext_i)
            d, ext, ext_i = -d, x, i
    return np.asarray(out, np.int64)


def full_turns(angle: np.ndarray, frame: np.ndarray, fps: float) -> list[tuple[int, int, int]]:
    """The full turns of ``angle`` within one run of contact.

    angle: (N,) degrees, unwrapped, finite, one row per entry of ``frame``; frame: (N,) frame
    numbers, increasing. The run is cut at the rotation's turning points (:func:`turning_points`),
    and inside each part the turns are counted from its start in its direction: the k-th ends at
    the first row whose progress reaches ``360 k - FULL_TURN_TOL_DEG``, the next starts on the row
    after. A turn longer than :data:`CIRCLE_MAX_S` ends the part's count (a slow turn through held
    positions, a press on the rings, is no circle).

    Returns (start, end, direction) per turn: row indices into ``angle`` and +1 / -1.
    """
    s = np.asarray(angle, float)
    if len(s) < 3:
        return []
    cuts = turning_points(s)
    out = []
    for p, q in zip(np.concatenate([[0], cuts]), np.concatenate([cuts, [len(s) - 1]])):
        if q <= p:
            continue
        d = 1 if s[q] > s[p] else -1
        prog = d * (s[p:q + 1] - s[p])
        k, start = 1, int(p)
        while True:
            hit = np.flatnonzero(prog >= 360.0 * k - FULL_TURN_TOL_DEG)
            if hit.size == 0:
                break
            end = int(p) + int(hit[0])
            if frame[end] - frame[start] > CIRCLE_MAX_S * fps:
                break
            out.append((start, end, d))
            start, k = end + 1, k + 1
    return out
