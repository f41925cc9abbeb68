"""The cascade for joints: weakly observed joints anchored on the target's plane, and bone lengths.

Paper: Section III-C, Eq. 5-7, applied to joints instead of box centres. A joint seen by one
view only, or only by two views looking at each other (line-of-sight angle above
``opposite_angle_deg``), has a nearly unobservable depth along the line of sight -- the
degeneracy the paper's ray-plane intersection fixes for the centre. The gymnast's joints lie
within ~0.3-0.5 m of the plane through the target's 3D centre parallel to the apparatus plane,
so such a joint is the fusion (information form, :func:`gymtrack.pose.dlt.fuse_rays_plane`) of
its lines of sight (lateral noise from a pixel noise scaled to the pose's box) and that plane as
a prior of ``plane_sigma_m`` along its normal. One view: the ray-plane intersection (how =
plane); an opposite pair: rays and plane by their uncertainty (how = fused).

Bone lengths (beyond the paper): a person's bones do not change, so each bone's length is the
median over the frames where both its joints were triangulated from well-spread views; a weak
joint is then moved along its main line of sight (the direction its depth is uncertain in)
towards the sphere of that radius around its better-observed neighbour -- a soft constraint,
applied outwards from the strong joints in a few passes.

Shapes: C views, J joints, T frames; N = J * T points flattened joint-major (``n = j T + t``).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..skeletons import Skeleton
from .dlt import fuse_rays_plane, rays


def opposite_only(centres: np.ndarray, ref: np.ndarray, seen: np.ndarray, threshold_deg: float) -> np.ndarray:
    """(J, T) bool: joints seen by exactly two views whose lines of sight at ``ref`` meet at more
    than ``threshold_deg`` (paper Section III-C's "opposite" pair).

    centres (C, 3) camera centres; ref (T, 3) a point of the body per frame; seen (C, J, T) bool.
    """
    C = len(centres)
    los = ref[None] - centres[:, None]  # (C, T, 3)
    los /= np.linalg.norm(los, axis=2, keepdims=True)
    cos = np.einsum("atk,btk->abt", los, los)  # (C, C, T)
    opposite = cos < np.cos(np.radians(threshold_deg))
    two = seen.sum(axis=0) == 2
    a = np.argmax(seen, axis=0)  # first view that sees the joint
    b = C - 1 - np.argmax(seen[::-1], axis=0)  # last one
    t = np.broadcast_to(np.arange(seen.shape[2]), a.shape)
    return two & opposite[a, b, t]


def lines_of_sight(cams, u: np.ndarray, v: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rays through undistorted pixels u, v (C, M) of the views with weight w (C, M) > 0.

    Returns the camera centres o (C, 3), the unit directions d (C, 3, M) (paper Eq. 5-6; through
    the principal point where a view does not count) and the main ray of each point -- the view
    with the largest weight: origin (3, M), direction (3, M).
    """
    K = np.stack([c.K for c in cams])
    R = np.stack([c.R for c in cams])
    o = np.stack([c.centre for c in cams])  # (C, 3)
    d = rays(K, R, np.where(w > 0, u, K[:, 0, 2, None]), np.where(w > 0, v, K[:, 1, 2, None]))
    main = np.argmax(w, axis=0)
    m = np.arange(u.shape[1])
    return o, d, o[main].T, d[main, :, m].T


def anchor_on_plane(cams, o: np.ndarray, d: np.ndarray, d_main: np.ndarray, w: np.ndarray, centre: np.ndarray,
                    normal: np.ndarray, sigma_px: np.ndarray, sigma_plane: float | np.ndarray, min_cos: float) -> np.ndarray:
    """Fuse the lines of sight of weak joints with the plane through the centre.

    cams: the rig's cameras; o (C, 3), d (C, 3, M), d_main (3, M) from :func:`lines_of_sight`;
    w (C, M) > 0 where a view counts; centre (3, M) the target's centre at each point's frame;
    normal (3,) unit; sigma_px (C, M) the pixel noise; sigma_plane: the plane prior's std along
    the normal, metres, scalar or (M,) (:func:`plane_spread`). Returns X (3, M); NaN where a lone ray is
    within ``min_cos`` of parallel to the plane or the point falls behind a camera.
    """
    f = np.array([c.K[0, 0] for c in cams])
    depth = np.linalg.norm(centre[None] - o[:, :, None], axis=1)  # (C, M) distance to the body
    sigma_m = depth * sigma_px / f[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        info = np.where(w > 0, 1.0 / sigma_m**2, 0.0)
    X = fuse_rays_plane(o, d, info, centre, normal, sigma_plane)
    lone = (w > 0).sum(axis=0) == 1
    parallel = lone & (np.abs(normal @ d_main) < min_cos)
    behind = np.any((w > 0) & (np.einsum("cim,cim->cm", X[None] - o[:, :, None], d) <= 0), axis=0)
    X[:, parallel | behind] = np.nan
    return X


def plane_spread(X: np.ndarray, strong: np.ndarray, centre: np.ndarray, normal: np.ndarray, floor: float,
                 min_frames: int) -> np.ndarray:
    """(J,) each joint's spread (RMS, metres) along the normal about the plane through the centre,
    measured on the frames where it was strongly triangulated; never below ``floor`` (the
    configured prior), ``floor`` with fewer than ``min_frames`` such frames.

    X (T, J, 3); strong (T, J) bool; centre (T, 3); normal (3,). The plane prior holds for a body
    that moves in the apparatus plane (a beam walk, a giant swing); a pommel horse circle sweeps
    the legs a metre across it, and a fixed prior there pulls joints half a metre off.
    """
    off = np.einsum("tjk,k->tj", X - centre[:, None], normal)
    ok = strong & np.isfinite(off)
    n = ok.sum(axis=0)
    rms = np.sqrt(np.where(ok, off * off, 0.0).sum(axis=0) / np.maximum(n, 1))
    return np.where(n >= min_frames, np.maximum(rms, floor), floor)


def bone_lengths(X: np.ndarray, strong: np.ndarray, bones: np.ndarray, min_frames: int) -> np.ndarray:
    """(B,) median length of each bone over frames where both ends are strong; NaN with fewer
    than ``min_frames`` such frames. X (T, J, 3); strong (T, J) bool; bones (B, 2)."""
    a, b = bones[:, 0], bones[:, 1]
    both = strong[:, a] & strong[:, b]  # (T, B)
    length = np.linalg.norm(X[:, a] - X[:, b], axis=2)
    length = np.where(both, length, np.nan)
    out = np.full(len(bones), np.nan)
    enough = both.sum(axis=0) >= min_frames
    if enough.any():
        out[enough] = np.nanmedian(length[:, enough], axis=0)
    return out


def pull_to_bones(X: np.ndarray, strong: np.ndarray, weak: np.ndarray, origin: np.ndarray, direction: np.ndarray,
                  bones: np.ndarray, lengths: np.ndarray, weight: float, iterations: int) -> tuple[np.ndarray, int]:
    """Move weak joints along their main line of sight towards their bone's length.

    X (T, J, 3) joints; strong, weak (T, J) bool; origin, direction (T, J, 3) the weak joints'
    main rays; bones (B, 2); lengths (B,) (NaN = unknown). Each pass moves the weak end of every
    bone whose other end is anchored (strong, or moved in an earlier pass) by ``weight`` of the way
    to the nearer point of its ray on the sphere of the bone's length (the ray's closest point to
    the anchor when it misses the sphere). Returns the new X and how many joints moved.
    """
    X = X.copy()
    anchored = strong & np.isfinite(X).all(axis=2)
    moved = np.zeros_like(weak)
    ok_len = np.isfinite(lengths)
    pairs = np.concatenate([bones[ok_len], bones[ok_len][:, ::-1]])  # both directions
    L = np.concatenate([lengths[ok_len], lengths[ok_len]])
    for _ in range(iterations):
        newly = np.zeros_like(weak)
        for (a, b), length in zip(pairs, L):
            sel = anchored[:, a] & weak[:, b] & ~moved[:, b] & np.isfinite(X[:, b]).all(axis=1)
            if not sel.any():
                continue
            o, d, xa = origin[sel, b], direction[sel, b], X[sel, a]
            p = np.sum(d * (xa - o), axis=1)
            q = np.sum((xa - o) ** 2, axis=1) - length**2
            disc = p * p - q
            root = np.sqrt(np.maximum(disc, 0.0))
            lam0 = np.sum(d * (X[sel, b] - o), axis=1)
            lam = np.where(np.abs(p - root - lam0) < np.abs(p + root - lam0), p - root, p + root)
            lam = np.where(disc >= 0, lam, p)
            lam = np.where(lam > 0, lam, lam0)  # never behind the camera
            X[sel, b] += (weight * (lam - lam0))[:, None] * d
            moved[sel, b] = True
            newly[sel, b] = True
        anchored |= newly
    return X, int(moved.sum())


def given_lengths(options, skeleton: Skeleton) -> np.ndarray:
    """(B,) ``options.bone_lengths_m`` checked against ``skeleton.bones``; all NaN when not given."""
    B = len(np.asarray(skeleton.bones).reshape(-1, 2))
    if options.bone_lengths_m is None:
        return np.full(B, np.nan)
    L = np.asarray(options.bone_lengths_m, np.float64)
    if L.shape != (B,) or (np.isfinite(L) & (L <= 0)).any() or np.isinf(L).any():
        raise InputError(f"must be {B} lengths in metres (> 0, NaN = unknown), one per bone of the {skeleton.name} "
                         f"skeleton, got {options.bone_lengths_m!r}", source="LiftOptions", field="bone_lengths_m")
    return L
