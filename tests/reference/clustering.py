"""Numpy references of the clustering kernels (paper Section III-B, Eq. 1-2, Algorithm 1).

* :func:`complete_linkage_sequential`: Algorithm 1 literally, one merge per step;
* :func:`complete_linkage_numpy`: the vectorised reciprocal-nearest-neighbour rounds the kernel
  replaced;
* :func:`tracklet_distances_numpy`: Eq. 2 as (K, C, W) line tensors and matrix products.
"""

from __future__ import annotations

import numpy as np


def number_by_first_member(owner: np.ndarray) -> np.ndarray:
    """(K,) cluster representatives (any member index) -> labels 0..n-1 in order of each
    cluster's first member (table lookups: cheaper than np.unique and two argsorts)."""
    K = len(owner)
    idx = np.arange(K)
    first = np.full(K, K)
    np.minimum.at(first, owner, idx)  # first member of each representative's cluster
    is_first = first[owner] == idx
    return (np.cumsum(is_first) - 1)[first[owner]]


def complete_linkage_sequential(D: np.ndarray, threshold: float, merges: list | None = None) -> np.ndarray:
    """Algorithm 1 literally, one merge per step (the closest pair, ties: first in row-major
    order). Same inputs and labels as :func:`gymtrack.tracking.clustering.complete_linkage`;
    slower, kept as the reference.

    merges: if a list is given, each merge is appended as ``(i, j, distance)``: the clusters are
    named by their smallest original member (``j`` joins ``i``)."""
    S = np.array(D, dtype=np.float64)
    K = S.shape[0]
    owner = np.arange(K)
    if K >= 2:
        np.fill_diagonal(S, np.nan)
        while True:
            W = np.where(np.isnan(S), np.inf, S)
            i, j = divmod(int(np.argmin(W)), K)
            if not W[i, j] < threshold:
                break
            if merges is not None:
                merges.append((int(i), int(j), float(W[i, j])))
            merged = np.fmax(S[i], S[j])
            S[i], S[:, i] = merged, merged
            S[j], S[:, j] = np.nan, np.nan
            S[i, i] = np.nan
            owner[owner == j] = i
    return number_by_first_member(owner)



def complete_linkage_numpy(D, threshold):
    """Algorithm 1 in vectorised reciprocal-nearest-neighbour rounds (the replaced numpy code)."""
    S = np.array(D, dtype=np.float64)
    K = S.shape[0]
    owner = np.arange(K)
    if K >= 2:
        np.fill_diagonal(S, np.nan)
        idx = np.arange(K)
        while True:
            W = np.fmin(S, np.inf)
            nn = np.argmin(W, axis=1)
            d = W[idx, nn]
            I = np.flatnonzero((nn[nn] == idx) & (idx < nn) & (d < threshold))
            if len(I) == 0:
                if not d.min() < threshold:
                    break
                I = np.array([int(np.argmin(d))])
            J = nn[I]
            S[I] = np.fmax(S[I], S[J])
            S[:, I] = np.fmax(S[:, I], S[:, J])
            S[J] = np.nan
            S[:, J] = np.nan
            S[I, I] = np.nan
            relabel = idx.copy()
            relabel[J] = I
            owner = relabel[owner]
    first = np.full(K, K)
    np.minimum.at(first, owner, np.arange(K))
    is_first = first[owner] == np.arange(K)
    return (np.cumsum(is_first) - 1)[first[owner]]


def tracklet_distances_numpy(segs, F):
    K, W = segs.observed.shape
    cam = segs.camera
    if K == 0:
        return np.zeros((0, 0))
    C = F.shape[0]
    obs, box = segs.observed, segs.box
    xh = np.empty((K, W, 3))
    xh[..., :2] = box[..., :2]
    xh[..., 2] = 1.0
    xh[~obs] = 0.0
    scale = np.abs(box[..., 2] + box[..., 3])
    scale[~obs] = 1.0
    xh /= scale[..., None]
    lines = (F[cam].reshape(K, 3 * C, 3) @ xh.transpose(0, 2, 1)).reshape(K, C, 3, W)
    norm = np.sqrt(lines[:, :, 0] ** 2 + lines[:, :, 1] ** 2)
    norm[norm == 0] = 1.0
    lines /= norm[:, :, None]
    full = (xh.transpose(1, 0, 2) @ lines.transpose(3, 2, 1, 0).reshape(W, 3, C * K)).reshape(W, K, C, K)
    S = np.abs(full[:, np.arange(K), cam, :]).sum(axis=0)
    obsf = obs.astype(np.float64)
    n = obsf @ obsf.T
    with np.errstate(invalid="ignore", divide="ignore"):
        D = (S + S.T) / n
    D[n == 0] = np.nan
    D[cam[:, None] == cam[None, :]] = np.inf
    return D
