"""Numpy reference of cascade+'s motion-link kernels (beyond the paper: issue 12;
gymtrack/tracking/_kernels/motion_link.py): the code MotionLinker ran before they were compiled."""

from __future__ import annotations

import numpy as np

from gymtrack.tracking.linking import member


def first_boxes(frame: np.ndarray, track2d: np.ndarray, box: np.ndarray, ids: np.ndarray, n: int
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The first ``n`` boxes of each 2D track ``ids`` (T,) among rows frame (N,), track2d (N,),
    box (N, 4) (centre form). Returns frames (T, n), boxes (T, n, 4), valid (T, n) bool."""
    T = len(ids)
    f_out, b_out, ok = np.zeros((T, n), np.int64), np.full((T, n, 4), np.nan), np.zeros((T, n), bool)
    rows = np.flatnonzero(member(track2d, ids))
    rows = rows[np.lexsort((frame[rows], track2d[rows]))]  # by track, then frame
    which = np.searchsorted(ids, track2d[rows])  # ids sorted
    rank = np.arange(len(rows)) - np.searchsorted(track2d[rows], track2d[rows])  # position within its track
    use = rank < n
    which, rank, rows = which[use], rank[use], rows[use]
    f_out[which, rank], b_out[which, rank], ok[which, rank] = frame[rows], box[rows], True
    return f_out, b_out, ok


def motion_distances(P: np.ndarray, old_camera: np.ndarray, old_frame: np.ndarray, old_xyz: np.ndarray,
                     old_velocity: np.ndarray, frames: np.ndarray, boxes: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """(L, T) mean normalised offset between the new tracks' boxes and the old tracks' projected
    predictions. P: (C, 3, 4); old_camera, old_frame: (L,) the view and last frame of each 3D
    track's end point old_xyz (L, 3), moving at old_velocity (L, 3) metres per frame; frames
    (T, n), boxes (T, n, 4) centre form, ok (T, n): the new tracks' first boxes. NaN where a
    prediction falls behind the camera."""
    dt = frames[None] - old_frame[:, None, None]  # (L, T, n)
    X = old_xyz[:, None, None, :] + old_velocity[:, None, None, :] * dt[..., None]  # (L, T, n, 3)
    Pc = P[old_camera]  # (L, 3, 4)
    h = np.einsum("lij,ltnj->ltni", Pc[..., :3], X) + Pc[:, None, None, :, 3]  # (L, T, n, 3)
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = h[..., :2] / h[..., 2:3]
        off = (uv - boxes[None, ..., :2]) / boxes[None, ..., 2:]
        d = np.linalg.norm(off, axis=-1)  # (L, T, n)
        d = np.where(ok[None] & (h[..., 2] > 0), d, np.nan)
        bad = (np.isnan(d) & ok[None]).any(axis=-1)  # a box with no prediction in front of the camera
        out = np.nansum(np.where(ok[None], d, 0.0), axis=-1) / ok.sum(axis=-1)[None]
    out[bad | ~ok.any(axis=-1)[None]] = np.nan
    return out


def link_costs_numpy(frame, track2d, camera, ubox, new, cam_o, t_o, last_o, lf, lx, lv, P, n, max_gap):
    """One round of MotionLinker._link's costs (see the kernel)."""
    last = last_o.copy()
    held = member(track2d, t_o[t_o >= 0])
    if held.any():
        known = np.flatnonzero(t_o >= 0)
        order = known[np.argsort(t_o[known])]
        np.maximum.at(last, order[np.searchsorted(t_o[order], track2d[held])], frame[held])
    frames, boxes, ok = first_boxes(frame, track2d, ubox, new, n)
    cam_n = np.zeros(len(new), np.int64)
    at = member(track2d, new)
    cam_n[np.searchsorted(new, track2d[at])] = camera[at]
    D = motion_distances(P, cam_o, lf, lx, lv, frames, boxes, ok)
    gap = frames[:, 0][None, :] - last[:, None]
    late = ((gap < 1) | (gap > max_gap + 1)) & (t_o >= 0)[:, None]
    D[(cam_o[:, None] != cam_n[None, :]) | late] = np.nan
    return D


def window_ends_numpy(xyz, valid, start, max_speed, members, observed, seg_start):
    """MotionLinker.remember's tracklet ends (linking.tracklet_ends) and (M, C) last observed frames."""
    from gymtrack.tracking.linking import tracklet_ends

    lf, lx, lv = tracklet_ends(xyz, valid, start, max_speed)
    has = members >= 0
    obs = observed[np.maximum(members, 0)]
    last_obs = np.where(has, seg_start + obs.shape[-1] - 1 - np.argmax(obs[..., ::-1], axis=-1), -1 << 40)
    return lf, lx, lv, last_obs


def new_tracks_numpy(frame, track2d, start, stop, fresh_from, seen):
    """MotionLinker.step's new 2D tracks of the window (rows in frame order)."""
    inwin = (frame >= start) & (frame < stop)
    ids, first_at = np.unique(track2d[inwin], return_index=True)
    return ids[(frame[inwin][first_at] >= fresh_from) & ~member(ids, seen)]


def old_entries_numpy(C, ids, last_obs, track_id, lf, lx, lv):
    """MotionLinker._link's one entry per old 2D track (np.unique of the keys, first index)."""
    t_all = ids.ravel()
    _, keep = np.unique(np.where(t_all >= 0, t_all, -1 - np.arange(len(t_all))), return_index=True)
    m = keep // C
    return keep % C, t_all[keep], last_obs.ravel()[keep], track_id[m], lf[m], lx[m], lv[m]


def keep_views_numpy(members, ids, track_id, prev_track_id, prev_ids):
    """MotionLinker.remember's views without a member, as it was: a dict of the previous rows."""
    C = members.shape[1]
    vt = dict(zip(prev_track_id.tolist(), prev_ids))
    has = members >= 0
    if vt and not has.all():
        before = np.stack([vt.get(t, np.full(C, -1, np.int64)) for t in track_id.tolist()])
        return np.where(has, ids, before)
    return np.where(has, ids, -1)
