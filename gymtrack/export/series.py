"""One skeleton track on a regular frame grid, its short gaps filled and the rest cut into parts.

Rule (``shared/formats.md``, "Exports"): OpenSim cannot take an empty cell, so a joint's gap of
at most 0.5 s between two estimates is filled by linear interpolation (counted), and the frames
still missing a joint after that cut the track into numbered parts. The paper's 3D pose (Section
III-D, last paragraph) has a row per (frame, track) where it could be lifted; this module puts one
track's rows on its frame range (``first..last``, a frame without a row being a gap of every joint).

Shapes: ``xyz`` (T, J, 3) world metres over ``frames`` (T,), NaN = no estimate.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..poses import Poses3D

__all__ = ["MAX_GAP_S", "TrackSeries", "track_series", "fill_gaps", "complete_parts"]

#: the longest gap (seconds) filled by interpolation
MAX_GAP_S = 0.5


@dataclass(eq=False)
class TrackSeries:
    """One track's joints on its frame range.

    track_id: the track, None for the target (which may follow several tracks); frames: (T,) int64, consecutive; xyz: (T, J, 3) NaN = no estimate;
    joints: the J joint names.
    """

    track_id: int | None
    frames: np.ndarray
    xyz: np.ndarray
    joints: tuple[str, ...]


def track_series(poses: Poses3D, track_id: int | None = None) -> TrackSeries:
    """The rows of one track (every row when ``track_id`` is None: the target, one row a frame)
    on the grid ``frame.min()..frame.max()``."""
    p = poses if track_id is None else poses.subset(poses.track_id == track_id)
    if len(p) == 0:
        return TrackSeries(track_id, np.zeros(0, np.int64), np.zeros((0, len(poses.skeleton.joints), 3)),
                           poses.skeleton.joints)
    if np.unique(p.frame).size != len(p):
        raise ValueError("track_series needs one row a frame")
    f0 = int(p.frame.min())
    frames = np.arange(f0, int(p.frame.max()) + 1, dtype=np.int64)
    xyz = np.full((len(frames), len(p.skeleton.joints), 3), np.nan)
    xyz[p.frame - f0] = p.xyz
    return TrackSeries(track_id, frames, xyz, p.skeleton.joints)


@dataclass
class GapFill:
    """What :func:`fill_gaps` did: ``gaps`` runs filled, ``cells`` (frame, joint) cells filled,
    ``filled`` (T, J) bool where values are interpolated."""

    gaps: int = 0
    cells: int = 0
    filled: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), bool))


def fill_gaps(xyz: np.ndarray, max_frames: int) -> tuple[np.ndarray, GapFill]:
    """Fill every run of at most ``max_frames`` missing frames of a joint that has an estimate
    on both sides, by linear interpolation in time; leading and trailing runs stay NaN.

    xyz: (T, J, 3); returns the filled copy and what was filled.
    """
    out = xyz.copy()
    T, J = xyz.shape[:2]
    have = np.all(np.isfinite(xyz), axis=-1)  # (T, J)
    filled = np.zeros((T, J), bool)
    gaps = 0
    t = np.arange(T)
    for j in range(J):  # J is small (17-26): a loop over joints, vectorised over frames
        ok = have[:, j]
        if ok.sum() < 2:
            continue
        miss = ~ok
        # runs of missing frames: starts and ends (exclusive)
        d = np.diff(np.concatenate([[0], miss.astype(np.int8), [0]]))
        starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
        inner = (starts > 0) & (ends < T) & (ends - starts <= max_frames)
        if not inner.any():
            continue
        mask = np.zeros(T, bool)
        for s, e in zip(starts[inner], ends[inner]):
            mask[s:e] = True
        for c in range(3):
            out[mask, j, c] = np.interp(t[mask], t[ok], xyz[ok, j, c])
        filled[mask, j] = True
        gaps += int(inner.sum())
    return out, GapFill(gaps, int(filled.sum()), filled)


def complete_parts(xyz: np.ndarray, min_frames: int = 1) -> list[slice]:
    """The maximal runs of frames in which every joint of ``xyz`` (T, J, 3) is finite, as slices
    (runs shorter than ``min_frames`` left out)."""
    ok = np.all(np.isfinite(xyz), axis=(1, 2)).astype(np.int8)
    d = np.diff(np.concatenate([[0], ok, [0]]))
    return [slice(int(s), int(e)) for s, e in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)) if e - s >= min_frames]
