"""Numpy reference of the linking kernels (paper Section III-B, Eq. 10; Eq. 12 with cascade+'s
``best_only``, beyond the paper)."""

from __future__ import annotations

import numpy as np

from gymtrack.tracking.types import Tracks3D


def link_distances_numpy(prev_xyz, prev_valid, new_xyz, new_valid, offset):
    Wo = prev_xyz.shape[1] - offset
    a, av = prev_xyz[:, offset:], prev_valid[:, offset:]
    b, bv = new_xyz[:, :Wo], new_valid[:, :Wo]
    both = av[:, None] & bv[None]
    d = np.linalg.norm(a[:, None] - b[None], axis=-1)
    n = both.sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        D = np.where(both, d, 0.0).sum(axis=-1) / n
    D[n == 0] = np.nan
    return D


def merge_overlaps_numpy(frame, track_id, xyz, top_z, bottom_z, source, n_views, best_only=False):
    """tracking.linking.merge_overlaps before it was compiled."""
    if len(frame) == 0:
        return Tracks3D.empty()
    # one stable argsort of a combined (frame, track) key: cheaper than lexsort of two keys
    lo = track_id.min()
    key = (frame - frame.min()) * (track_id.max() - lo + 1) + (track_id - lo)
    order = np.argsort(key, kind="stable")
    key = key[order]
    frame, track_id, xyz, top_z, bottom_z, source, n_views = (
        c[order] for c in (frame, track_id, xyz, top_z, bottom_z, source, n_views))
    new = np.ones(len(key), bool)  # first estimate of each (frame, track)
    np.not_equal(key[1:], key[:-1], out=new[1:])
    start = np.flatnonzero(new)
    if len(start) == len(key):  # every (frame, track) has one estimate: nothing to average
        return Tracks3D(frame, track_id, xyz, top_z, bottom_z, source.astype(np.int8), n_views.astype(np.int8))
    count = np.diff(np.append(start, len(key)))
    if best_only:  # where a group has an over-determined triangulation, only those are averaged
        strong = (source == 0) & (n_views >= 3)
        keep = strong | ~np.repeat(np.logical_or.reduceat(strong, start), count)
        if not keep.all():
            frame, track_id, xyz, top_z, bottom_z, source, n_views = (
                c[keep] for c in (frame, track_id, xyz, top_z, bottom_z, source, n_views))
            count = np.add.reduceat(keep.astype(np.int64), start)  # every group keeps a row
            start = np.r_[0, np.cumsum(count)[:-1]]

    def mean(v):
        ok = np.isfinite(v)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.add.reduceat(np.where(ok, v, 0.0), start) / np.add.reduceat(ok.astype(np.float64), start)

    return Tracks3D(
        frame[start], track_id[start], np.add.reduceat(xyz, start) / count[:, None], mean(top_z), mean(bottom_z),
        np.minimum.reduceat(source, start).astype(np.int8), np.maximum.reduceat(n_views, start).astype(np.int8),
    )


def link_by_2d_numpy(rows, members, track2d, prev_2d, prev_owner, ids):
    """tracking.linking.WindowLinker._link_by_2d before it was compiled: writes ``ids``, returns the links."""
    links = 0
    for m in rows.tolist():
        t2 = track2d[members[m][members[m] >= 0]]
        at = np.flatnonzero(np.isin(prev_2d, t2))
        if len(at) == len(t2) and len(np.unique(prev_owner[at])) == 1:
            tid = int(prev_owner[at[0]])
            if tid not in ids:
                ids[m] = tid
                links += 1
    return links
