"""Numpy reference of the venue check's kernels (gymtrack/tracking/_kernels/drift.py):
tracking.drift's residuals and steps before they were compiled, and its turn fit before it was batched."""

from __future__ import annotations

import numpy as np


def nanmedian(x: np.ndarray, axis: int = 1) -> np.ndarray:
    """``np.nanmedian(x, axis)`` (NaN where there is no value, without a warning) by one sort
    (numpy's goes through masked arrays for small inputs)."""
    s = np.sort(x, axis=axis)  # NaNs last
    n = (~np.isnan(s)).sum(axis=axis, keepdims=True)
    lo = np.take_along_axis(s, np.maximum(n - 1, 0) // 2, axis=axis)  # (no values: the NaN at 0)
    hi = np.take_along_axis(s, n // 2, axis=axis)
    return np.squeeze((lo + hi) / 2, axis=axis)


def _midpoints(Rt, centres, xa, a, xb, b):
    da = np.einsum("nij,nj->ni", Rt[a][:, :, :2], xa) + Rt[a][:, :, 2]
    db = np.einsum("nij,nj->ni", Rt[b][:, :, :2], xb) + Rt[b][:, :, 2]
    w0 = centres[a] - centres[b]
    aa, bb, cc = (da * da).sum(1), (da * db).sum(1), (db * db).sum(1)
    d, e = (da * w0).sum(1), (db * w0).sum(1)
    den = aa * cc - bb * bb
    with np.errstate(invalid="ignore", divide="ignore"):
        s, t = (bb * e - cc * d) / den, (aa * e - bb * d) / den
    return (centres[a] + s[:, None] * da + centres[b] + t[:, None] * db) / 2


def residuals_numpy(box, observed, members, Kinv, Rt, centres, Pn, pa, pb, max_residual, min_points, w_lo, w_hi):
    """What the kernels return for the window's frames ``w_lo .. w_hi - 1``, as {key: (median (2,), X (n, 3), seen (n, 2))} for the keys with
    ``min_points`` or more, and the sync sums by key (C * Np, 3)."""
    C, Np = members.shape[1], len(pa)
    outside = np.ones((Np, C), bool)
    outside[np.arange(Np), pa] = False
    outside[np.arange(Np), pb] = False
    sums, out = np.zeros((C * Np, 3)), {}
    members = members[(members >= 0).sum(axis=1) >= 3]
    if not len(members):
        return out, sums
    has = members >= 0
    idx = np.where(has, members, 0)
    obs = observed[idx] & has[..., None]  # (M, C, W)
    uv = box[idx][..., :2]
    x = np.einsum("cij,mcwj->mcwi", Kinv[:, :2, :2], uv) + Kinv[None, :, None, :2, 2]
    pair_ok = obs[:, pa] & obs[:, pb]
    pair_ok[..., :w_lo] = False
    pair_ok[..., w_hi:] = False
    m, p, w = np.nonzero(pair_ok)
    if not len(m):
        return out, sums
    X = _midpoints(Rt, centres, x[m, pa[p], w], pa[p], x[m, pb[p], w], pb[p])
    i, cam = np.nonzero(obs[m, :, w] & outside[p])
    Xi = X[i]
    pc = np.einsum("nij,nj->ni", Pn[cam][:, :, :3], Xi) + Pn[cam][:, :, 3]
    seen = x[m[i], cam, w[i]]
    with np.errstate(invalid="ignore", divide="ignore"):
        r = seen - pc[:, :2] / pc[:, 2:]
        ok = (pc[:, 2] > 0) & (np.abs(r).max(axis=1) < max_residual)
    vel = np.full_like(x, np.nan)
    vel[:, :, 1:-1] = np.where((obs[..., 2:] & obs[..., :-2])[..., None], (x[:, :, 2:] - x[:, :, :-2]) / 2, np.nan)
    v = vel[m[i], cam, w[i]]
    good = ok & np.isfinite(v[:, 0])
    key = cam * Np + p[i]
    for j, col in enumerate((np.ones(good.sum()), (v[good] ** 2).sum(1), (v[good] * r[good]).sum(1))):
        sums[:, j] += np.bincount(key[good], col, minlength=C * Np)
    for k in np.unique(key[ok]):
        sel = ok & (key == k)
        if sel.sum() >= min_points:
            out[int(k)] = (np.median(r[sel], axis=0), Xi[sel], seen[sel])
    return out, sums


def steps_numpy(meds, nb, min_sigma):
    """(shift, sigma, base) as the kernel's."""
    base_meds, recent = meds[:, :nb], meds[:, nb:]
    base = nanmedian(base_meds, axis=1)
    scatter = 1.4826 * nanmedian(np.linalg.norm(base_meds - base[:, None], axis=2))
    shift = (recent - base[:, None]).mean(axis=1)
    ready = (np.isfinite(base_meds[..., 0]).sum(1) >= nb - 1) & np.isfinite(shift).all(axis=1)
    return (np.where(ready[:, None], np.nan_to_num(shift), 0.0), np.where(ready, np.maximum(min_sigma, np.nan_to_num(scatter)), np.inf),
            base)


def scan_steps_numpy(meds, n_base, n_recent, min_sigma, cap, shortest=None):
    """gymtrack.tracking.drift_scan.scan_steps before it was compiled: every candidate at once in numpy."""
    Nk, L, _ = meds.shape
    ms = np.arange(shortest or n_recent, L - n_base + 1)  # every candidate at once: (Nk, M, ...) below
    b = meds[:, (L - ms - n_base)[:, None] + np.arange(n_base)]  # (Nk, M, n_base, 2) each candidate's baseline
    good = np.isfinite(b[..., 0])
    base = nanmedian(b, axis=2)
    spread = nanmedian(np.linalg.norm(b - base[:, :, None], axis=3), axis=2)
    recent = np.isfinite(meds[:, None, :, 0]) & (np.arange(L) >= (L - ms)[:, None])  # (Nk, M, L)
    n_r = recent.sum(axis=2)
    ready = (good.sum(axis=2) >= n_base - 1) & (n_r >= n_recent)
    # (the sum runs over the samples in order, the earlier ones as exact zeros: as over the recent ones alone)
    total = np.where(recent[..., None], meds[:, None] - base[:, :, None], 0.0).sum(axis=2)
    shift = np.where(ready[..., None], total / np.maximum(n_r, 1)[..., None], 0.0)
    scatter = np.where(ready, np.maximum(min_sigma, 1.4826 * np.nan_to_num(spread)), np.inf)
    sigma = scatter * np.sqrt(n_recent / np.maximum(n_r, 1))
    chi = np.ascontiguousarray(np.minimum(cap, (shift ** 2).sum(axis=2) / sigma ** 2).T).sum(axis=1)  # (M,) per candidate
    k = int(np.argmax(chi))  # (the shortest of equals)
    return shift[:, k], sigma[:, k], scatter[:, k], base[:, k], int(ms[k])


def fit_numpy(mon, shift, sigma, keys, recent, cap, huber, roll_deg):
    """``DriftMonitor._fit`` before it was batched: each key's median point by ``np.median`` over
    its rows of the recent samples, then each camera's turn fitted alone (robust least squares)."""
    rep = {}
    for k in keys:
        got = [(q[1][q[0][k]:q[0][k + 1]], q[2][q[0][k]:q[0][k + 1]]) for q in mon.samples[-recent:] if q is not None]
        X, S = np.concatenate([g[0] for g in got]), np.concatenate([g[1] for g in got])
        if len(X):
            rep[k] = (np.median(X, axis=0), np.median(S, axis=0))
    keys = np.array([k for k in keys if k in rep], np.int64)
    pts, seen = (np.array([rep[k][q] for k in keys]).reshape(-1, 3 - q) for q in (0, 1))
    z = shift[keys] / sigma[keys, None]
    prior = np.diag([1e-6, 1e-6, 1 / np.radians(roll_deg) ** 2])
    out = []
    for c in range(mon.C):
        inv = mon.involves[c, keys]
        own = inv & (mon.key_camera[keys] == c)
        if not own.any():
            out.append((np.inf, None, 0.0, None))
            continue
        A = np.zeros((len(keys), 2, 3))
        i = np.flatnonzero(inv)
        A[i] = mon._jacobians(c, keys[i], pts[i], seen[i]) / sigma[keys[i], None, None]
        weight = inv.astype(float)
        for _ in range(4):
            w = np.linalg.solve(np.einsum("n,nji,njk->ik", weight, A, A) + prior, np.einsum("n,nji,nj->i", weight, A, z))
            miss = np.linalg.norm(z - A @ w, axis=1)
            weight = inv * np.minimum(1.0, huber / np.maximum(miss, 1e-12))
        pred = np.zeros((len(sigma), 2))
        pred[keys] = (A @ w) * sigma[keys, None]
        out.append((float(np.minimum(cap, miss ** 2).sum()), w, float(np.linalg.norm(z[own], axis=1).min()), pred))
    return out, float(np.minimum(cap, (z ** 2).sum(axis=1)).sum())
