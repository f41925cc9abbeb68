"""Regaining the lost target from one view (the recipe's ``regain``; beyond the paper, Section III-C).

The cascade lets a single tracklet continue a track on the vertical plane only when its 2D track
was a member of the previous window's 3D tracklets, or is new (the one-view continuation of
:func:`.plane_fallback.plane_split`). A 2D track that a window saw but did not place -- its first
window clustered it with a coach's opposite view into a cluster that Eq. 4 dropped -- never
passes again: with two opposite cameras the gymnast is then lost for as long as she is seen in
one view (simulated beam, seed 2 r1, n_cam = 2: two seconds).

While the target's track is lost (not continued, still within the re-linking reach), such a
2D track may continue alone when it is in a view of the lost track's last tracklet -- the view
that was seeing the target lost it, its 2D track broke -- and its box holds the target's
predicted centre (the lost track's last point moved at its last velocity,
:func:`.linking.relink_distances`' prediction) at its first observed frame. It then goes to the
plane as any single tracklet and may only continue a track (re-linked by Eq. 10's gate).
Letting every seen-but-unplaced 2D track continue alone regained the gymnast but put coaches'
single views on the plane (rings and high bar worse); the target's own prediction keeps most
coaches out, and the view rule the rest: another camera's coach whose ray passes through a lost
phantom of an opposite pair (simulated beam, seed 3 r0, n_cam = 2: the phantom held 170 frames
more, and the gymnast identified 65 frames later).

Shapes: ``segs`` one window's segments (K, W); ``to_plane`` (n,) indices into them.
"""

from __future__ import annotations

import numpy as np

from .types import WindowTracklets, member

__all__ = ["regained_views"]


def regained_views(segs: WindowTracklets, to_plane: np.ndarray, prev_2d: np.ndarray, prev_seen: np.ndarray,
                   lost: tuple[int, np.ndarray, np.ndarray, np.ndarray] | None, P: np.ndarray) -> np.ndarray:
    """(m,) the 2D track ids among the segments ``to_plane`` that may continue alone though seen
    and never placed (in ``prev_seen``, not in ``prev_2d``): those in a view of the lost track
    whose box at their first observed frame holds the projection of its predicted centre.

    lost: the target's lost track as the linker keeps it (last frame, last xyz (3,), velocity
    (3,) in metres per frame, (C,) bool the views of its last tracklet), None when the target is
    not lost; P: (C, 3, 4) the cameras' projections (undistorted pixels, as ``segs.box``).
    """
    if lost is None or not len(to_plane):
        return np.zeros(0, np.int64)
    tid = segs.track2d[to_plane]
    refused = member(tid, prev_seen) & ~member(tid, prev_2d) & lost[3][segs.camera[to_plane]]
    k = to_plane[refused & segs.observed[to_plane].any(axis=1)]
    if not len(k):
        return np.zeros(0, np.int64)
    first = np.argmax(segs.observed[k], axis=1)
    dt = segs.start + first - lost[0]
    X = lost[1][None] + lost[2][None] * dt[:, None]  # (n, 3) the constant-velocity prediction
    x = np.einsum("nij,nj->ni", P[segs.camera[k]], np.c_[X, np.ones(len(k))])
    with np.errstate(invalid="ignore", divide="ignore"):
        uv = x[:, :2] / x[:, 2:]
    box = segs.box[k, first]
    inside = (np.abs(uv - box[:, :2]) <= box[:, 2:] / 2).all(axis=1) & (x[:, 2] > 0)
    return np.unique(segs.track2d[k[inside]])
