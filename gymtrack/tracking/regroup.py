"""Regrouping: an opposite pair inside a dropped cluster goes on to the vertical plane (paper Section III-C).

The cascade sends the clusters triangulation cannot use -- one view, or two opposite views -- to
the vertical plane (Eq. 5-9). With two opposite cameras the gymnast's two segments agree under
Eq. 2 whatever the depth (both rays lie near the line between the cameras), so complete
linkage (Algorithm 1) readily adds a third view's segment of someone standing anywhere on that
line: a coach or the next gymnast 5-8 m away. The wrong cluster triangulates to a body floating
off the apparatus, and Eq. 4 or the floor's ghost test drops it -- with the gymnast's segments,
which then reach no stage at all (the failure breakdown's ``unclustered``: on the simulated beam
at n_cam = 2 most of the target's misses).

Here the dropped clusters get a second chance (the recipe's ``regroup``): two of their segments
of opposite views that are each other's nearest opposite-view segment of the whole window by
Eq. 2 (below ``cluster_2d``) form a pair, and the pair goes on like the cascade's opposite
pairs: to the floor (people on the floor are placed there; a pair's segment only together with
its partner, :func:`pairs_only`: one view alone is often a person cut by the image's bottom edge,
whose box bottom is not the feet) and then to the plane stage as a
group of its own (it fuses only with its partner; Eq. 8 still decides). On the plane a pair is
kept only as a gymnast on the apparatus -- two views whose means pass Eq. 13's indicator (inside
S_perf, top above ``h_top``, bottom above ``h_bot``) -- and only to continue a track: two
people's segments in a dropped cluster are a pair by Eq. 2 too and meet on the plane by chance
(a phantom, e.g. beside a vault's landing, that would take over the target's track). Segments
without a pair stay dropped, as before.

The recipe's ``rejoin``: what the pair continues is the track its 2D tracks belonged to. A pair
links by its 2D tracks (as a floor tracklet, :meth:`.linking.WindowLinker.step`), wherever the
wrong cluster had put that track: Eq. 10's gate refused it when the wrong triangulation stood
1.5 m off the beam (simulated beam, seed 0 r3, n_cam = 2: three seconds without a track). A
pair's view whose partner did not fuse with it passes alone when it may continue its track alone
(:func:`continuing`) and looks like a gymnast on the apparatus (the indicator above, on one
view), and then continues only its own track within the gate. (Sending every segment of a
dropped cluster on alone kept more gymnasts but put coaches' single views on the plane: all-people
MOTA fell 0.84 -> 0.74 on the rings at n_cam = 3.) The recipe's ``lone`` sends on alone only the
dropped segments whose 2D track belonged to the target's track (:func:`target_lone`): a coach's
view never did. They pass the same gymnast test and continue only their own track.

Effect (simulated, n_cam = 2): the beam's target FR 11.9 -> 1.3 % (the oracle's 1.3 %) on a
seed-4 check suite, 11.9 -> 1.1 % on a seed-3 beam and pommel suite; the other apparatus' target
unchanged; all-people MOTA / IDF1 up on beam, rings and high bar. The floor's partner rule
(default suite, seed 0): parallel bars' ~200 false positives a routine at every n_cam gone (MOTA
0.82-0.86 -> 0.95-0.98), mean MOTA / IDF1 up at every n_cam, the target unchanged. Cost: the
regrouped people on the floor are tracked (+4 to +27 % tracking CPU time on a routine).
"""

from __future__ import annotations

import numpy as np

from ._kernels import regroup as kernels
from .types import WindowTracklets3D, member

__all__ = ["regroup", "regroup_pairs", "gymnast_only", "pairs_only", "continuing", "target_lone", "send_alone"]


def regroup_pairs(tested: np.ndarray, kept: np.ndarray, D2: np.ndarray, camera: np.ndarray, opposite: np.ndarray,
                  cut: float) -> tuple[np.ndarray, np.ndarray | None]:
    """The opposite pairs among the segments of the clusters that Eq. 4 and the ghost test dropped.

    tested: (M, C) members of the clusters before the tests (-1: none); kept: (M', C) those after
    them; D2: (K, K) Eq. 2 distances of the window's segments; camera: (K,) their views;
    opposite: (C, C) bool, the opposite camera pairs; cut: Eq. 2's threshold (``cluster_2d``).
    A pair: two dropped segments of opposite views, each the other's nearest opposite-view
    segment of the whole window by Eq. 2, below ``cut``. Returns the pairs' segments (sorted)
    and (K,) group labels for the plane stage (0: any segment; a pair: its own label), None when
    there is no pair. One compiled call (:func:`._kernels.regroup.regroup_pairs`); the tracker's
    window step calls :func:`regroup`, whose kernel runs the same pairing."""
    c = np.ascontiguousarray
    groups = kernels.regroup_pairs(c(tested, np.int64), c(kept, np.int64), c(D2, np.float64), c(camera, np.int64),
                                   c(opposite, np.bool_), float(cut))
    seg = np.flatnonzero(groups)
    return (seg, groups) if len(seg) else (seg, None)


def gymnast_only(pl: WindowTracklets3D, regrouped: np.ndarray, performance_space: np.ndarray, target,
                 counts: dict, alone: np.ndarray | None = None) -> WindowTracklets3D | None:
    """The plane tracklets without those of ``regrouped`` segments that are not a gymnast on the
    apparatus: one view alone (its partner did not fuse with it), or means that fail Eq. 13's
    indicator (inside ``performance_space``, body top above ``target.h_top`` and bottom above
    ``target.h_bot``). Two people's segments of a dropped cluster are a pair by Eq. 2 too and
    meet on the plane by chance: a phantom standing in the air over the floor. ``alone`` (M,)
    bool: rows that may pass with one view, when they pass the indicator (the recipe's
    ``rejoin``: one view continuing its track, :func:`continuing`; a coach's one view stays out).
    Counted in ``regrouped_left_out``; None when nothing is left."""
    m = pl.members
    mine = member(m, regrouped).any(axis=1)
    if not mine.any():
        return pl
    v = pl.valid
    n = np.maximum(v.sum(axis=1), 1)
    mean = np.where(v[..., None], pl.xyz, 0.0).sum(axis=1) / n[:, None]
    top = np.where(v, pl.top_z, 0.0).sum(axis=1) / n
    bottom = np.where(v, pl.bottom_z, 0.0).sum(axis=1) / n
    lo, hi = performance_space[:3], performance_space[3:]
    views = (m >= 0).sum(axis=1) >= 2
    if alone is not None:
        views |= alone
    gymnast = np.all((mean >= lo) & (mean <= hi), axis=1) & (top > target.h_top) & (bottom > target.h_bot) & views
    out = mine & ~gymnast
    if not out.any():
        return pl
    counts["regrouped_left_out"] += int(out.sum())
    pl = pl.subset(~out)
    return pl if len(pl) else None


def pairs_only(fl: WindowTracklets3D, fresh: np.ndarray, groups: np.ndarray, counts: dict) -> WindowTracklets3D | None:
    """The floor tracklets without those holding a ``fresh`` regrouped segment (one of a cluster
    Eq. 4 dropped) without its pair's partner (``groups``: :func:`regroup_pairs`' labels). A pair
    is one person where its two opposite views agree on where the feet stand; one view placed
    alone is a box the pair does not vouch for (a person cut by the image's edge, placed a metre
    off). Counted in ``regrouped_left_out``; None when nothing is left."""
    m = fl.members
    new = np.zeros(len(groups) + 1, bool)  # (the last entry: -1, no segment)
    new[fresh] = True
    label = np.append(groups, 0)[m]
    partner = (label[:, :, None] == label[:, None, :]).sum(axis=2) >= 2  # (M, C): its partner is in the row
    out = (new[m] & ~partner).any(axis=1)
    if not out.any():
        return fl
    counts["regrouped_left_out"] += int(out.sum())
    fl = fl.subset(~out)
    return fl if len(fl) else None


def regroup(tested: np.ndarray, kept: np.ndarray, D2: np.ndarray, camera: np.ndarray, opposite: np.ndarray, cut: float,
            to_plane: np.ndarray, floor_only: np.ndarray, counts: dict):
    """The tracker's step: :func:`regroup_pairs`, its segments added to ``to_plane`` (sorted) and
    taken out of ``floor_only`` (counted in ``segments_regrouped``). Returns the regrouped
    segments, the plane stage's group labels (or None), ``to_plane``, ``floor_only`` and the
    fresh regrouped segments (not in ``floor_only``: without regrouping they were dropped).
    One compiled call (:func:`._kernels.regroup.regroup_step`): it runs on every window."""
    c = np.ascontiguousarray
    groups, seg, to_plane, floor_only, fresh = kernels.regroup_step(
        c(tested, np.int64), c(kept, np.int64), c(D2, np.float64), c(camera, np.int64), c(opposite, np.bool_), float(cut),
        c(to_plane, np.int64), c(floor_only, np.int64))
    if not len(seg):
        return seg, None, to_plane, floor_only, seg
    counts["segments_regrouped"] += len(seg)
    return seg, groups, to_plane, floor_only, fresh


def continuing(pl: WindowTracklets3D, may: np.ndarray) -> np.ndarray:
    """(M,) bool: the plane tracklets of one view whose segment may continue a track from its view
    alone (``may`` (K,) bool per segment, indexed by ``pl.members``: the tracker's
    :meth:`.linking.WindowLinker.may_continue_alone`)."""
    m = pl.members
    one = (m >= 0).sum(axis=1) == 1
    return one & may[m.max(axis=1)]


def target_lone(tested: np.ndarray, kept: np.ndarray, regrouped: np.ndarray, track2d: np.ndarray, prev_2d: np.ndarray,
                prev_owner: np.ndarray, target: int) -> np.ndarray:
    """(n,) sorted: the segments of dropped clusters (in ``tested``, not in ``kept``, not
    ``regrouped``) whose 2D track belonged to the ``target``'s 3D track in the previous window
    (``prev_2d`` and ``prev_owner``, the linker's); empty without a target. A coach's view never
    belonged to the gymnast's track: sending every dropped segment on alone put coaches' single
    views on the plane."""
    tested = tested[tested >= 0]
    if target < 0 or not len(prev_2d) or not len(tested):
        return np.zeros(0, np.int64)
    drop = np.zeros(int(tested.max()) + 1, bool)  # masks, not set operations: this runs every window
    drop[tested] = True
    for out in (kept, regrouped):
        drop[out[(out >= 0) & (out < len(drop))]] = False
    dropped = np.flatnonzero(drop)
    if not len(dropped):
        return dropped
    return dropped[member(track2d[dropped], prev_2d[prev_owner == target])]


def send_alone(seg: np.ndarray, n_segments: int, regrouped: np.ndarray, groups: np.ndarray | None, to_plane: np.ndarray,
               floor_only: np.ndarray, fresh: np.ndarray, counts: dict):
    """The segments ``seg`` (:func:`target_lone`) join the regrouped ones, each in a group of its
    own (it fuses with no segment on the plane), on to the plane and not to the floor alone (a
    fresh segment: :func:`pairs_only`). Returns ``regrouped``, ``groups`` ((n_segments,) labels),
    ``to_plane``, ``floor_only`` and ``fresh``, as :func:`regroup` does; counted in ``segments_lone``."""
    counts["segments_lone"] += len(seg)
    g = np.zeros(n_segments, np.int64) if groups is None else groups.copy()
    g[seg] = g.max() + 1 + np.arange(len(seg))
    return (np.union1d(regrouped, seg), g, np.union1d(to_plane, seg), np.setdiff1d(floor_only, seg),
            np.union1d(fresh, seg))
