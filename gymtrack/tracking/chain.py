"""The identification's look-back follows the track its target continues (the recipe's ``chain``).

Beyond the paper (Section III-D's back-fill, :func:`.identify.backfill`). Eq. 13 identifies the
gymnast once she qualifies: on the vault in the pre-flight, over the bars once she hangs. The
back-fill hands the identified track the frames of the look-back, but where that track was born
inside the look-back, the frames before its birth belonged to the track it continues -- the
run-up's, broken at the take-off (the board's jolt, the body's sudden rise out of its box).

A *predecessor* of a track born at frame ``s``: a track with no point from ``s`` on, whose last
point lies at most :data:`GAP_SECONDS` before ``s``, and whose horizontal constant-velocity
prediction (from its last moving points: a held end box repeats its point) lands within
:data:`GATE` of the new track's first point; the nearest such. Horizontal only: the height of a
take-off follows neither a constant velocity nor one parabola (the board, then the table). The
look-back's frames without a target where the predecessor has a point become the target's, and
the same holds for the predecessor's own predecessor, back to the look-back's start.

Arrays: ``index`` (n,) frame index of each held point, ``track_id`` (n,), ``xyz`` (n, 3).
"""

from __future__ import annotations

import numpy as np

__all__ = ["GAP_SECONDS", "GATE", "predecessor", "chain_back"]

GAP_SECONDS = 0.5  #: the longest break between a track and its continuation (a vault's take-off: ~0.2 s)
GATE = 1.0  #: metres: the predecessor's predicted position within this of the new track's first point (the handover's 1 m)
MOVING_POINTS = 5  #: the last distinct points the predecessor's velocity is measured over


def _motion(i: np.ndarray, x: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """From points at indices ``i`` (increasing) with positions ``x`` (m, 3): the last point that
    moved (its index and horizontal position (2,)) and the horizontal metres per frame over the
    last :data:`MOVING_POINTS` such points (zero when fewer than 2). A held end box repeats its
    point: predicting from the repeats would slow the track down."""
    moved = np.ones(len(i), bool)
    moved[1:] = np.any(x[1:] != x[:-1], axis=1)
    i, x = i[moved][-MOVING_POINTS:], x[moved][-MOVING_POINTS:]
    v = np.zeros(2) if len(i) < 2 else (x[-1, :2] - x[0, :2]) / (i[-1] - i[0])
    return int(i[-1]), x[-1, :2], v


def predecessor(index: np.ndarray, track_id: np.ndarray, xyz: np.ndarray, tid: int, gap: int) -> tuple[int, int]:
    """The predecessor of track ``tid`` among the held points (see the module docstring): (its
    track id, its last frame index), or (-1, -1). ``gap``: :data:`GAP_SECONDS` in frames."""
    mine = np.flatnonzero(track_id == tid)
    if not len(mine):
        return -1, -1
    born = mine[np.argmin(index[mine])]
    s, first = int(index[born]), xyz[born]
    later = np.unique(track_id[index >= s])
    near = (index < s) & (index >= s - gap) & ~np.isin(track_id, later)
    best, best_d, best_e = -1, GATE, -1
    for other in np.unique(track_id[near]).tolist():
        rows = np.flatnonzero(track_id == other)
        rows = rows[np.argsort(index[rows], kind="stable")]
        e = int(index[rows[-1]])
        m, at, v = _motion(index[rows], xyz[rows])
        pred = at + v * (s - m)
        d = float(np.linalg.norm(pred - first[:2]))
        if d <= best_d:
            best, best_d, best_e = int(other), d, e
    return best, best_e


def chain_back(decision: np.ndarray, pointed: np.ndarray, index: np.ndarray, track_id: np.ndarray, xyz: np.ndarray,
               tid: int, lo: int, gap: int) -> int:
    """Hand the predecessors of ``tid`` (and theirs) their points at frame indices ``lo ..`` that
    have no pointed target (``decision`` and ``pointed`` (F,) written in place). Returns the
    number of frames handed on."""
    handed = 0
    for _ in range(8):  # (a chain of breaks within one look-back: a few at most)
        prev, e = predecessor(index, track_id, xyz, tid, gap)
        if prev < 0 or e < lo:
            break
        take = index[(track_id == prev) & (index >= lo) & (index <= e)]
        take = take[~pointed[take]]
        decision[take] = prev
        pointed[take] = True
        handed += len(take)
        tid = prev
    return handed
