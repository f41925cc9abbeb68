"""One body, one person: a 2D pose found twice in a view (two tracks' crops on the same body) is
kept only by the track whose other views it agrees with.

Rule (several close people): a top-down model run on each track's crop locks on to the body in
the crop's middle, and where people overlap two tracks' crops can hold the same body; both then
return that body's pose (the crowded-scene failure of top-down models that CrowdPose, Li et al.,
CVPR 2019, was built to measure: a box holding several people). The pose belongs to one person
only. Two poses of one frame and view, put on different tracks, are the same body when their joints coincide (median
distance over the joints both found below ``same_frac`` of the pose's size); the one whose joints
lie farther from the epipolar lines of its track's poses in the other views
(:func:`.assign_joints.joint_costs`) loses its track. Where neither track has another view to
compare with, both are kept.

The same holds where the other track has no pose in that view (:func:`foreign_bodies`, every
track lifted): a pose on track A whose crop holds track B's 3D position and whose joints fit B's
other views far better than A's shows B's body; it moves to B, or is dropped where B has a pose
there already. Both tests are counted in the pose stage's summary.

Arrays: poses (N rows), track (N,) the assigned track id (-1 none).
"""

from __future__ import annotations

import numpy as np

from ..geometry.camera import Rig
from ..poses import Poses2D
from .assign_joints import JOINT_GATE, _undistorted, joint_costs

SAME_FRAC = 0.05


def same_body_pairs(poses: Poses2D, uv: np.ndarray, track: np.ndarray, same_frac: float = SAME_FRAC) -> np.ndarray:
    """(K, 2) row pairs of one frame and view, on different tracks, whose joints coincide; uv
    (N, J, 2) undistorted pixels (NaN = not found)."""
    rows = np.flatnonzero(track >= 0)
    key = poses.frame[rows].astype(np.int64) * 1024 + poses.camera[rows]
    o = np.argsort(key, kind="stable")
    rows, key = rows[o], key[o]
    pairs = []
    for k in range(1, len(rows)):
        same = np.flatnonzero(key[k:] == key[:-k])
        if not same.size:
            break
        pairs.append(np.column_stack([rows[same], rows[same + k]]))
    if not pairs:
        return np.zeros((0, 2), np.int64)
    pr = np.concatenate(pairs)
    pr = pr[track[pr[:, 0]] != track[pr[:, 1]]]
    a, b = uv[pr[:, 0]], uv[pr[:, 1]]
    with np.errstate(invalid="ignore"), np.testing.suppress_warnings() as sup:
        sup.filter(RuntimeWarning)  # poses without a common joint: NaN, not the same
        size = np.nanmax(np.nanmax(a, axis=1) - np.nanmin(a, axis=1), axis=1)
        d = np.nanmedian(np.linalg.norm(a - b, axis=-1), axis=1) / size
    return pr[np.isfinite(d) & (d < same_frac)]


def exclusive_bodies(poses: Poses2D, rig: Rig, track: np.ndarray, same_frac: float = SAME_FRAC) -> np.ndarray:
    """(N,) bool: the poses that lose their track because another track's pose is the same body
    and fits that track's other views better (module doc)."""
    track = np.asarray(track, np.int64)
    lose = np.zeros(len(track), bool)
    if not len(track):
        return lose
    pr = same_body_pairs(poses, _undistorted(poses, rig), track, same_frac)
    if not len(pr):
        return lose
    e = joint_costs(poses, rig, pr.reshape(-1), track[pr.reshape(-1)], track).reshape(-1, 2)
    e = np.where(np.isfinite(e), e, np.inf)
    decided = np.isfinite(e).any(axis=1) & (e[:, 0] != e[:, 1])
    loser = np.where(e[:, 0] > e[:, 1], pr[:, 0], pr[:, 1])
    lose[loser[decided]] = True
    return lose


def foreign_bodies(poses: Poses2D, rig: Rig, track: np.ndarray, frame3: np.ndarray, track3: np.ndarray,
                   xyz3: np.ndarray, ratio: float = 0.5, own_gate: float = JOINT_GATE) -> np.ndarray:
    """(N,) int64: each pose's track after the foreign-body test, -1 where dropped.

    A pose on track A whose crop holds another track B's 3D position (frame3, track3, xyz3: the
    tracks' rows) and whose joints fit B's poses in the other views far better than A's (joint
    cost ``e_B < ratio * e_A`` and ``e_A > own_gate``) shows B's body: it moves to B where B has no
    pose in that view, else it is dropped."""
    track = np.asarray(track, np.int64).copy()
    rows = np.flatnonzero(track >= 0)
    if not rows.size or not len(frame3):
        return track
    uv = _undistorted(poses, rig)
    with np.errstate(invalid="ignore"), np.testing.suppress_warnings() as sup:
        sup.filter(RuntimeWarning)
        lo, hi = np.nanmin(uv[rows], axis=1), np.nanmax(uv[rows], axis=1)  # (n, 2) the pose's extent
    o3 = np.argsort(frame3, kind="stable")
    f3 = frame3[o3]
    a, b = np.searchsorted(f3, poses.frame[rows], "left"), np.searchsorted(f3, poses.frame[rows], "right")
    n = b - a
    pi = np.repeat(np.arange(rows.size), n)
    qi = o3[np.repeat(a - np.cumsum(n) + n, n) + np.arange(pi.size)] if pi.size else np.zeros(0, np.int64)
    other = track3[qi] != track[rows[pi]]
    pi, qi = pi[other], qi[other]
    inside = np.zeros(pi.size, bool)
    cam = poses.camera[rows[pi]]
    for c, camera in enumerate(rig):
        m = np.flatnonzero(cam == c)
        if m.size:
            p2 = camera.undistort(camera.project(xyz3[qi[m]]))
            inside[m] = np.all((p2 >= lo[pi[m]]) & (p2 <= hi[pi[m]]), axis=1) & (camera.depth(xyz3[qi[m]]) > 0)
    pi, qi = pi[inside], qi[inside]
    if not pi.size:
        return track
    r = rows[pi]
    e_own = joint_costs(poses, rig, r, track[r], track)
    e_b = joint_costs(poses, rig, r, track3[qi], track)
    foreign = np.isfinite(e_b) & np.isfinite(e_own) & (e_own > own_gate) & (e_b < ratio * e_own)
    r, to, e_b = r[foreign], track3[qi][foreign], e_b[foreign]
    o = np.lexsort((e_b, r))  # per pose, the best-fitting other track first
    first = np.ones(o.size, bool)
    first[1:] = r[o][1:] != r[o][:-1]
    r, to = r[o][first], to[o][first]
    key = lambda f, c, t: (f.astype(np.int64) * 1024 + c) * (1 << 24) + t  # noqa: E731
    taken = np.isin(key(poses.frame[r], poses.camera[r], to), key(poses.frame[rows], poses.camera[rows], track[rows]))
    track[r] = np.where(taken, -1, to)
    return track
