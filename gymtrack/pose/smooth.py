"""Temporal smoothing of a lifted track that keeps flight phases sharp.

Beyond the paper (Section III-D smooths the target's *centre* track; here its joints). Each
joint coordinate is replaced by a confidence-weighted local quadratic fit over ``2 h + 1``
frames (a weighted Savitzky-Golay filter): exact for any motion of constant acceleration -- a
salto's flight, a swing's arc over a few frames -- so fast but consistent motion is not
blurred, while independent per-frame noise shrinks (to ~0.70 of its standard deviation for
h = 2, ~0.58 for h = 3). Motion that changes its acceleration within the window (a foot's
step, a hand's catch) is blurred slightly: ~3 mm mean for h = 2, ~7 mm for h = 3 on a
noise-free walking salto at 30 frames per second (``benchmarks/bench_pose.py`` input).

Before the fit, each sample is compared with the same fit *without* it (leave-one-out); a
sample farther than ``outlier_m`` from that prediction is an outlier (a swap or wrong body the
consensus missed) and is replaced by the fit of its neighbours; the worst sample of a window
goes first (an outlier also pulls its neighbours' predictions), in up to three passes.
Missing samples stay missing: nothing is invented across gaps.

Shapes: X (T, J, 3) metres, weights (T, J) >= 0 (0 = missing).
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import correlate1d, maximum_filter1d


def _moments(X: np.ndarray, w: np.ndarray, h: int) -> tuple[list, list]:
    tau = np.arange(-h, h + 1, dtype=np.float64)
    S = [correlate1d(w, tau**k, axis=0, mode="constant") for k in range(5)]  # (T, J) each
    wx = w[..., None] * X
    B = [correlate1d(wx, tau**k, axis=0, mode="constant") for k in range(3)]  # (T, J, 3) each
    return S, B


def _fit_centre(S: list, B: list) -> np.ndarray:
    """(T, J, 3) value at tau = 0 of the weighted quadratic fit (first row of the inverse)."""
    a00 = S[2] * S[4] - S[3] ** 2
    a01 = S[2] * S[3] - S[1] * S[4]
    a02 = S[1] * S[3] - S[2] ** 2
    det = S[0] * a00 + S[1] * a01 + S[2] * a02
    scale = np.maximum(S[0] * S[2] * S[4], 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(np.abs(det) > 1e-9 * scale, 1.0 / det, np.nan)
    return (a00[..., None] * B[0] + a01[..., None] * B[1] + a02[..., None] * B[2]) * inv[..., None]


def smooth_track(X: np.ndarray, weights: np.ndarray, half_window: int, outlier_m: float,
                 min_samples: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Smooth joints over time; see the module doc.

    Returns the smoothed X (T, J, 3) and the outliers replaced (T, J) bool. Samples whose window
    holds fewer than ``min_samples`` observations (>= 4: a quadratic needs a spare to be a fit)
    are left as they are.
    """
    if half_window <= 0 or len(X) < 2:
        return X.copy(), np.zeros(X.shape[:2], bool)
    found = np.isfinite(X).all(axis=2) & (weights > 0)
    w = np.where(found, np.maximum(weights, 1e-3), 0.0)
    Xz = np.where(found[..., None], X, 0.0)
    count = correlate1d(found.astype(np.float64), np.ones(2 * half_window + 1), axis=0, mode="constant")
    outlier = np.zeros_like(found)
    for _ in range(3):  # an outlier also pulls its neighbours' predictions: take the worst of a window first
        S, B = _moments(Xz, w, half_window)
        # leave-one-out: the centre sample only enters the zeroth moments (tau^k = 0 for k >= 1)
        loo = _fit_centre([S[0] - w] + S[1:], [B[0] - w[..., None] * Xz] + B[1:])
        dist = np.where(found & ~outlier, np.linalg.norm(X - loo, axis=2), 0.0)
        dist = np.nan_to_num(dist, nan=0.0)
        worst = dist >= maximum_filter1d(dist, 2 * half_window + 1, axis=0, mode="constant")
        new = (count - outlier_count(outlier, half_window) - 1 >= min_samples) & (dist > outlier_m) & worst
        if not new.any():
            break
        outlier |= new
        w = np.where(new, 0.0, w)
        Xz = np.where(new[..., None], 0.0, Xz)
    fit = _fit_centre(S, B) if not outlier.any() else _fit_centre(*_moments(Xz, w, half_window))
    usable = found & (count - outlier_count(outlier, half_window) >= min_samples) & np.isfinite(fit).all(axis=2)
    out = np.where(usable[..., None], fit, X)
    return out, outlier & usable


def outlier_count(outlier: np.ndarray, h: int) -> np.ndarray:
    """(T, J) number of outliers in each sample's window."""
    return correlate1d(outlier.astype(np.float64), np.ones(2 * h + 1), axis=0, mode="constant")
