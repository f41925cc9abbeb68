"""The vectorised numpy version of ``cascade+``'s ray-plane fusion that
:func:`gymtrack.tracking._kernels.fusion.fuse_pairs` replaced (beyond the paper;
Eq. 5-8 and the weighted least squares of :mod:`gymtrack.tracking.fusion`): the reference the
tests compare the kernel with, on random input. Same signature and outputs as the kernel.
"""

from __future__ import annotations

import numpy as np

from gymtrack.tracking.fusion import fuse_rays_plane, fusion_chi2

_OFFSETS = np.array([0.0, -0.5, 0.5])  # centre, top-centre, bottom-centre: v = cy + offset * h


def _refined(o, d, sp, z0, ok, normal, point, plane_sigma):
    """fuse_rays_plane with s = depth0 * sp, then once more with the depths of that solution."""
    with np.errstate(invalid="ignore"):
        X, _ = fuse_rays_plane(o, d, np.where(ok, z0 * sp, 1.0), ok, normal, point, plane_sigma)
        s = np.where(ok, np.linalg.norm(X[..., None, :] - o, axis=-1) * sp, 1.0)
    X, A = fuse_rays_plane(o, d, s, ok, normal, point, plane_sigma)
    return X, A, s


def fuse_pairs(box, observed, cams, centres, back, focal, depth0, pixel_sigma, box_sigma, normal, point,
               plane_sigma, min_cos):
    """See :func:`gymtrack.tracking._kernels.fusion.fuse_pairs`."""
    m, _, W, _ = box.shape
    ok = np.isfinite(box).all(-1)  # (m, 2, W)
    b = np.where(ok[..., None], box, 0.0)
    # (m, 2, 3, W) pixel rows of the three points, rays (m, 3, W, 2, 3) views next to last
    v = b[..., 1][:, :, None, :] + _OFFSETS[:, None] * b[..., 3][:, :, None, :]
    u = np.broadcast_to(b[..., 0][:, :, None, :], v.shape)
    pix = np.stack([u, v, np.ones_like(v)], axis=-1)
    d = np.einsum("mcij,mcqwj->mcqwi", back[cams], pix)
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    d = np.moveaxis(d, 1, 3)
    o = np.broadcast_to(centres[cams][:, None, None], d.shape)
    okq = np.broadcast_to(np.moveaxis(ok, 1, -1)[:, None], d.shape[:-1])  # (m, 3, W, 2)
    sp = np.moveaxis(np.hypot(pixel_sigma, box_sigma * b[..., 3]) / focal[cams][:, :, None], 1, -1)[:, None]
    sp = np.broadcast_to(sp, okq.shape)
    z0 = np.broadcast_to(depth0[cams][:, None, None, :], okq.shape)
    both = okq.all(-1)  # (m, 3, W)
    # pass 1: two-ray centres, Mahalanobis distance of every plane, median over frames
    Xt, At, _ = _refined(o[:, 0], d[:, 0], sp[:, 0], z0[:, 0], okq[:, 0], np.array([0.0, 0, 1]), np.zeros(3), np.inf)
    cov_n = np.linalg.solve(At[:, :, None], np.broadcast_to(normal[None, None, :, :, None], At.shape[:2] + normal.shape + (1,)))[..., 0]
    r = np.einsum("mwi,pi->mwp", Xt, normal) - (normal * point).sum(-1)
    maha = r ** 2 / ((cov_n * normal).sum(-1) + plane_sigma ** 2)  # (m, W, P)
    m2 = np.full(m, np.inf)
    plane = np.zeros(m, np.int64)
    for k in range(m):
        if both[k, 0].any():
            med = np.median(maha[k, both[k, 0]], axis=0)
            plane[k] = int(np.argmin(med))
            m2[k] = med[plane[k]]
    # pass 2: fused with each cluster's plane; chi-square where both rays are valid
    X = np.full((m, 3, W, 3), np.nan)
    chi2 = np.zeros(m)
    for p in np.unique(plane):
        sel = plane == p
        Xp, _, s = _refined(o[sel], d[sel], sp[sel], z0[sel], okq[sel], normal[p], point[p], plane_sigma)
        c2 = fusion_chi2(Xp, o[sel], d[sel], s, okq[sel], normal[p], point[p], plane_sigma)
        X[sel] = np.where(okq[sel].any(-1)[..., None], Xp, np.nan)
        chi2[sel] = np.where(both[sel], c2, 0.0).max(axis=(1, 2))
    # Eq. 8 on the cluster's plane: Eq. 7 centre candidates of the two views, frames both observed
    n, pt = normal[plane][:, None, None], point[plane][:, None, None]  # (m, 1, 1, 3)
    dc, oc = d[:, 0], o[:, 0]  # (m, W, 2, 3)
    with np.errstate(invalid="ignore", divide="ignore"):
        dn = (dc * n).sum(-1)
        lam = ((pt - oc) * n).sum(-1) / dn
        good = (np.abs(dn) >= min_cos) & (lam > 0)
        cand = oc + lam[..., None] * dc
        dist = np.linalg.norm(cand[:, :, 0] - cand[:, :, 1], axis=-1)  # (m, W)
    use = both[:, 0] & observed.all(axis=1) & good.all(-1)
    eq8 = np.where(use.any(1), np.where(use, dist, 0.0).sum(1) / np.maximum(use.sum(1), 1), np.inf)
    return X, plane, m2, chi2, eq8
