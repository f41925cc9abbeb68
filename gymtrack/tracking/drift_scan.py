"""The venue check's change scan: when a camera's residuals moved, and by how much in their scatter.

Beyond the paper (see :mod:`.drift`). A knock is a step in each key's median residual at an
unknown sample. For each candidate step -- the last ``m`` samples moved, ``n_recent <= m <=
n_scan`` -- the recent samples' mean less the baseline's median (the ``n_base`` samples before
them) is weighed in the scatter of that mean: the baseline samples' scatter over ``sqrt(m)``
(a step's evidence grows with the samples since it, Page's CUSUM / the likelihood ratio of a
step at an unknown time). The candidate whose keys' moves weigh most (each key's share capped)
is kept. ``m = n_recent`` (one second) is the single-window test the thresholds of :mod:`.drift`
were set on; a longer step's evidence is counted as the longer mean earns it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["scan_steps"]


def scan_steps(meds: np.ndarray, n_base: int, n_recent: int, min_sigma: float, cap: float, shortest: int | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """meds (Nk, L, 2) the samples' median residuals (NaN: not judged) -> shift (Nk, 2) the
    recent samples' mean less the baseline's median (0 where not judged), sigma (Nk,) what it is
    weighed in (inf where not judged), scatter (Nk,) one sample's, base (Nk, 2) the baseline's
    median, m: the recent samples, of the step (``shortest`` (``n_recent``) .. ``L - n_base``)
    whose keys' squared moves in their sigma, each capped at ``cap``, sum highest.

    A key is judged with ``n_base - 1`` or more baseline samples and ``n_recent`` or more recent
    ones; its scatter is max(min_sigma, 1.4826 x the baseline's median distance from its median),
    its sigma that times sqrt(n_recent / the recent samples it has): at ``m = n_recent`` the
    shift in one sample's scatter, as the thresholds of :mod:`.drift` were set."""
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


def nanmedian(x: np.ndarray, axis: int = 1) -> np.ndarray:
    """``np.nanmedian(x, axis)`` (NaN where there is no value, without a warning) by one sort:
    numpy's goes through masked arrays for small inputs, which made it most of the venue check's
    time."""
    s = np.sort(x, axis=axis)  # NaNs last
    n = (~np.isnan(s)).sum(axis=axis, keepdims=True)
    lo = np.take_along_axis(s, np.maximum(n - 1, 0) // 2, axis=axis)  # (no values: the NaN at 0)
    hi = np.take_along_axis(s, n // 2, axis=axis)
    return np.squeeze((lo + hi) / 2, axis=axis)
