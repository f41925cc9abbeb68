"""Which views agree, and which saw the body's left and right swapped: a cheap per-frame consensus.

Paper: Section III-D (the target's 2D poses in each view are lifted by Eq. 3). Beyond the paper:
a top-down pose model sometimes returns a wrong body (another person in the crop) or swaps left
and right (the body seen from behind or upside down, as gymnasts often are); one such view pulls
every joint of a plain DLT. Here every view *pair* and both relative labellings of its second
view form a hypothesis (``C (C - 1)`` of them: 12 for 4 views, never a search over subsets); the
pair's triangulated skeleton is reprojected into every view in both labellings, and each view
costs its mean truncated reprojection error (MSAC: errors normalised by a gate scaled to the
pose's box and capped at 1, a view that does not fit costs 1). The cheapest hypothesis of a
frame decides which views are kept and which are read swapped; a judged view may also be read
with its legs only exchanged (a model swaps the legs alone too).

A labelling is only defined relative to the views: the one most kept views agree with wins; a
tie (e.g. two views, one swapped) is settled later in 3D against the neighbouring frames
(:func:`settle_ties`).

Shapes: C views, J joints, T frames; pixels ``u, v`` and masks are (C, J, T).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .dlt import project, weighted_dlt


@dataclass(eq=False)
class Consensus:
    """Per frame and view: ``keep`` (C, T) bool, ``swap`` (C, T) bool (read with left/right
    exchanged), ``swap_legs`` (C, T) bool (the legs read exchanged: with ``swap``, the whole
    body; without it, the legs only), ``tie`` (T,) bool (as many kept views swapped as not: the
    labelling is open)."""

    keep: np.ndarray
    swap: np.ndarray
    tie: np.ndarray
    swap_legs: np.ndarray | None = None

    def reading(self, legs: np.ndarray) -> np.ndarray:
        """(C, J, T) bool: where a view's joint is read from its mirror joint; legs (J,) bool."""
        sl = self.swap if self.swap_legs is None else self.swap_legs
        return np.where(np.asarray(legs, bool)[None, :, None], sl[:, None, :], self.swap[:, None, :])


def _view_errors(pu, pv, u, v, ok, gate):
    """(C, J, T) reprojection error / gate, capped at 1, and where it is defined (C, J, T), of
    the projections pu, pv (C, J, T)."""
    r = np.hypot(pu - u, pv - v) / gate
    m = ok & np.isfinite(r)
    return np.where(m, np.minimum(r, 1.0), 0.0), m


def view_consensus(P: np.ndarray, u: np.ndarray, v: np.ndarray, ok: np.ndarray, gate: np.ndarray,
                   flip: np.ndarray, flip_ratio: float, inlier_error: float, min_common: int,
                   legs: np.ndarray | None = None) -> Consensus:
    """Pick per frame the views that agree and their left/right labelling (see the module doc).

    P (C, 3, 4) undistorted projections; u, v (C, J, T) undistorted pixels; ok (C, J, T) found;
    gate (C, J, T) pixels; flip (J,) mirror joint of each joint. legs (J,) bool or None: the leg
    joints, whose labels a pose model also swaps on their own (a legs-only swap, Ronchi &
    Perona's "inversion" of the legs): each judged view is then also read with its legs only
    exchanged (no extra hypotheses: the pairs still read their second view whole).
    """
    C, J, T = u.shape
    present = ok.sum(axis=1) > 0  # (C, T)
    lateral = flip != np.arange(J)
    us, vs, oks = u[:, flip], v[:, flip], ok[:, flip]
    if legs is not None:
        pl = np.where(np.asarray(legs, bool) & lateral, flip, np.arange(J))
        ul, vl, okl = u[:, pl], v[:, pl], ok[:, pl]
    best = np.full(T, np.inf)
    keep = present.copy()
    swap = np.zeros((C, T), bool)
    swap_legs = np.zeros((C, T), bool)
    for a in range(C):
        for b in range(a + 1, C):
            for s in (False, True):
                ub, vb, okb = (us[b], vs[b], oks[b]) if s else (u[b], v[b], ok[b])
                if s and not (ok[b][lateral].any()):
                    continue
                pair = np.array([a, b])
                w = np.stack([ok[a], okb]).reshape(2, J * T).astype(np.float64)
                X = weighted_dlt(P[pair], np.stack([u[a], ub]).reshape(2, -1), np.stack([v[a], vb]).reshape(2, -1), w)
                n3d = np.isfinite(X[0]).reshape(J, T).sum(axis=0)
                pu, pv = (p.reshape(C, J, T) for p in project(P, X))
                eo, mo = _view_errors(pu, pv, u, v, ok, gate)
                es, ms = _view_errors(pu, pv, us, vs, oks, gate)
                # the labelling from the lateral joints only: central joints read the same both ways
                lat_o = (eo * mo)[:, lateral].sum(1) / np.maximum(mo[:, lateral].sum(1), 1)
                lat_s = (es * ms)[:, lateral].sum(1) / np.maximum(ms[:, lateral].sum(1), 1)
                sw = (ms[:, lateral].sum(1) >= 2) & (lat_s < flip_ratio * lat_o)
                e = np.where(sw, es.sum(1) / np.maximum(ms.sum(1), 1), eo.sum(1) / np.maximum(mo.sum(1), 1))
                checked = np.where(sw, ms.sum(1), mo.sum(1)) >= min_common
                lg = np.zeros_like(sw)
                if legs is not None:
                    el, ml = _view_errors(pu, pv, ul, vl, okl, gate)
                    lat_l = (el * ml)[:, lateral].sum(1) / np.maximum(ml[:, lateral].sum(1), 1)
                    lg = (ml[:, lateral].sum(1) >= 2) & (lat_l < flip_ratio * lat_o) & ~(sw & (lat_s <= lat_l))
                    sw = sw & ~lg
                    e = np.where(lg, el.sum(1) / np.maximum(ml.sum(1), 1), e)
                    checked = np.where(lg, ml.sum(1) >= min_common, checked)
                inlier = present & (~checked | (e < inlier_error))
                cost = np.where(present, np.where(checked & inlier, e, 1.0), 0.0).sum(axis=0)
                cost = np.where(n3d >= min_common, cost, np.inf)
                better = cost < best
                best = np.where(better, cost, best)
                keep = np.where(better, inlier, keep)
                swap = np.where(better, sw & inlier, swap)
                swap_legs = np.where(better, (sw | lg) & inlier, swap_legs)
    n_sw = np.sum(keep & swap, axis=0)
    n_keep = np.sum(keep & ~swap, axis=0)
    invert = n_sw > n_keep
    # relabel every kept view: upper body and legs each toggle (a legs-only swap stays one)
    swap_legs = np.where(invert, keep & ~swap_legs, swap_legs)
    swap = np.where(invert, keep & ~swap, swap)
    return Consensus(keep=keep, swap=swap, tie=(n_sw == n_keep) & (n_sw > 0),
                     swap_legs=swap_legs if legs is not None else None)


def leg_joints(skeleton) -> np.ndarray:
    """(J,) bool: the skeleton's leg joints (hips down), by name (a model swaps the legs alone too)."""
    parts = ("hip", "knee", "ankle", "heel", "toe", "foot")
    return np.array([any(p in name for p in parts) for name in skeleton.joints], bool)


def settle_ties(X: np.ndarray, tie: np.ndarray, flip: np.ndarray) -> np.ndarray:
    """(T,) bool: which tie frames to relabel (left <-> right) so they match their neighbours.

    X (T, J, 3) the lifted joints; a tie frame is compared with the nearest earlier frame whose
    labelling was decided (the nearest later one at the start); relabelled where its mirror
    image is closer to it. Without any decided frame nothing is relabelled.
    """
    T = len(tie)
    decided = ~tie & np.isfinite(X).all(axis=2).any(axis=1)
    if not tie.any() or not decided.any():
        return np.zeros(T, bool)
    idx = np.where(decided, np.arange(T), -1)
    prev = np.maximum.accumulate(idx)
    first = int(np.flatnonzero(decided)[0])
    ref = np.where(prev >= 0, prev, first)
    R = X[ref]
    same = np.linalg.norm(X - R, axis=2)  # (T, J)
    mirrored = np.linalg.norm(X[:, flip] - R, axis=2)
    m = np.isfinite(same) & np.isfinite(mirrored)  # compare on the same joints both ways
    d_same = np.where(m, same, 0.0).sum(axis=1)
    d_flip = np.where(m, mirrored, 0.0).sum(axis=1)
    return tie & (d_flip < d_same)
