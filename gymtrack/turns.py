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
TURN_STILL_DEG = 0.5  #: degrees a frame: a slower turn (a hold's sway) keeps the direction it had
CIRCLE_MAX_S = 3.0  #: a circle is a swing: one turn in at most this long


def full_turns(angle: np.ndarray, frame: np.ndarray, fps: float) -> list[tuple[int, int, int]]:
    """The full turns of ``angle`` within one run of contact.

    angle: (N,) degrees, unwrapped, finite, one row per entry of ``frame``; frame: (N,) frame
    numbers, increasing. The run is cut where the rotation turns back (a swing's turning point: the
    rate's sign changes; a rate under :data:`TURN_STILL_DEG` a frame keeps the direction before it),
    and inside each part the turns are counted from its start: the k-th ends at the first row whose
    progress reaches ``360 k - FULL_TURN_TOL_DEG``, the next starts on the row after. A turn longer
    than :data:`CIRCLE_MAX_S` ends the part's count (a slow turn through held positions, a press on
    the rings, is no circle).

    Returns (start, end, direction) per turn: row indices into ``angle`` and +1 / -1.
    """
    s = np.asarray(angle, float)
    if len(s) < 3:
        return []
    rate = np.gradient(s)
    sign = np.where(np.abs(rate) > TURN_STILL_DEG, np.sign(rate), 0.0)
    idx = np.where(sign != 0, np.arange(len(s)), 0)
    np.maximum.accumulate(idx, out=idx)
    sign = sign[idx]  # a pause keeps the direction it had
    cuts = np.flatnonzero(np.diff(sign) != 0) + 1
    out = []
    for p, q in zip(np.concatenate([[0], cuts]), np.concatenate([cuts - 1, [len(s) - 1]])):
        d = int(sign[p])
        if d == 0:
            continue
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
