"""Assigning poses to tracks by their joints, not only their boxes: each joint's epipolar distance
to the track's poses in the other views.

Rule (several close people, as a bottom-up pose model gives them): where people overlap, a
pose's box overlaps several tracks' boxes about equally, and the box IoU of
:func:`gymtrack.pose.assign.assign_poses` cannot tell whose it is. The joints can: a pose of the
person a track follows has its joints on the epipolar lines of the same joints of that track's
poses in the other views (paper Eq. 1, per joint). After the box pass, every candidate (pose,
track) pair with some overlap gets

``cost = (1 - IoU) + JOINT_WEIGHT * e``, ``e`` = the median over joints seen in both of the symmetric
point-to-epipolar-line distance over the pose's size (at most 1), averaged over the track's other views,

and each (frame, view) is solved again (Hungarian) on it. A pair is allowed when its IoU passes
the box gate, or when it overlaps at all (IoU >= ``MIN_OVERLAP``) and its joints agree (``e`` <=
``JOINT_GATE``): a crowd's pose box may overlap its own track's box less than a neighbour's.
Arrays: keypoints (N, J, 3), undistorted per camera once.
"""

from __future__ import annotations

import numpy as np

from ..geometry.camera import Rig
from ..geometry.epipolar import fundamental_matrices
from ..poses import Poses2D

__all__ = ["joint_costs", "JOINT_WEIGHT", "JOINT_GATE", "MIN_OVERLAP"]

JOINT_WEIGHT = 2.0
JOINT_GATE = 0.05
MIN_OVERLAP = 0.05


def _undistorted(poses: Poses2D, rig: Rig) -> np.ndarray:
    """(N, J, 2) undistorted pixels (NaN where not found with score >= 0.3)."""
    kp = poses.keypoints
    out = np.full(kp.shape[:2] + (2,), np.nan)
    good = (kp[..., 2] >= 0.3) & np.isfinite(kp[..., :2]).all(-1)
    for c, cam in enumerate(rig):
        rows = np.flatnonzero(poses.camera == c)
        if rows.size:
            out[rows] = cam.undistort(kp[rows, :, :2].reshape(-1, 2)).reshape(rows.size, -1, 2)
    out[~good] = np.nan
    return out


def joint_costs(poses: Poses2D, rig: Rig, pi: np.ndarray, ti: np.ndarray, track: np.ndarray) -> np.ndarray:
    """(M,) ``e`` of each candidate (pose ``pi``, track ``ti``) against the poses ``track`` (N,) has
    put on that track in the other views of the same frame; NaN where there is none to compare."""
    M = pi.size
    e = np.full(M, np.nan)
    have = np.flatnonzero(track >= 0)
    if not M or not have.size:
        return e
    big = np.int64(1) << 32
    key_q = poses.frame[have] * big + track[have]
    key_c = poses.frame[pi] * big + ti
    order = np.argsort(key_q, kind="stable")
    lo, hi = np.searchsorted(key_q[order], key_c, "left"), np.searchsorted(key_q[order], key_c, "right")
    n = hi - lo
    ci = np.repeat(np.arange(M), n)
    qi = have[order[np.repeat(lo - np.cumsum(n) + n, n) + np.arange(ci.size)]] if ci.size else np.zeros(0, np.int64)
    p = pi[ci]
    other = poses.camera[qi] != poses.camera[p]
    ci, qi, p = ci[other], qi[other], p[other]
    if not ci.size:
        return e
    uv = _undistorted(poses, rig)
    F = fundamental_matrices(rig)
    cp, cq = poses.camera[p], poses.camera[qi]
    xp = np.concatenate([uv[p], np.ones(uv[p].shape[:2] + (1,))], axis=-1)  # (K, J, 3)
    xq = np.concatenate([uv[qi], np.ones(uv[qi].shape[:2] + (1,))], axis=-1)
    lp = np.einsum("kab,kjb->kja", F[cq, cp], xq)  # lines in p's view of q's joints
    lq = np.einsum("kab,kjb->kja", F[cp, cq], xp)
    dp = np.abs((lp * xp).sum(-1)) / np.linalg.norm(lp[..., :2], axis=-1)
    dq = np.abs((lq * xq).sum(-1)) / np.linalg.norm(lq[..., :2], axis=-1)
    with np.errstate(invalid="ignore", all="ignore"), np.testing.suppress_warnings() as sup:
        sup.filter(RuntimeWarning)  # poses without a found joint: NaN, expected
        size = np.nanmax(np.nanmax(uv[p], axis=1) - np.nanmin(uv[p], axis=1), axis=1)  # (K,)
        d = np.nanmedian(0.5 * (dp + dq), axis=1) / np.where(size > 0, size, np.nan)  # (K,)
        ok = np.isfinite(d)
    ci, d = ci[ok], np.minimum(d[ok], 1.0)
    cnt = np.bincount(ci, minlength=M)
    tot = np.bincount(ci, weights=d, minlength=M)
    e[cnt > 0] = tot[cnt > 0] / cnt[cnt > 0]  # mean over the track's other views
    return e
