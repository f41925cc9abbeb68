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
    best = None
    for m in range(shortest or n_recent, L - n_base + 1):
        b, r = meds[:, L - m - n_base:L - m], meds[:, L - m:]
        good, fin = np.isfinite(b[..., 0]), np.isfinite(r[..., 0])
        base = nanmedian(b)
        spread = nanmedian(np.linalg.norm(b - base[:, None], axis=2))
        n_r = fin.sum(axis=1)
        ready = (good.sum(axis=1) >= n_base - 1) & (n_r >= n_recent)
        shift = np.where(ready[:, None], np.where(fin[..., None], r - base[:, None], 0.0).sum(axis=1)
                         / np.maximum(n_r, 1)[:, None], 0.0)
        scatter = np.where(ready, np.maximum(min_sigma, 1.4826 * np.nan_to_num(spread)), np.inf)
        sigma = scatter * np.sqrt(n_recent / np.maximum(n_r, 1))
        chi = float(np.minimum(cap, (shift ** 2).sum(axis=1) / sigma ** 2).sum())
        if best is None or chi > best[0]:
            best = (chi, shift, sigma, scatter, base, m)
    return best[1:]


def nanmedian(x: np.ndarray) -> np.ndarray:
    """``np.nanmedian(x, axis=1)`` (NaN where a row has no value, without a warning) by one sort:
    numpy's goes through masked arrays for small inputs, which made it most of the venue check's
    time. x: (K, L, ...) -> (K, ...)."""
    s = np.sort(x, axis=1)  # NaNs last
    n = (~np.isnan(s)).sum(axis=1, keepdims=True)
    lo = np.take_along_axis(s, np.maximum(n - 1, 0) // 2, axis=1)  # (a row without values: its NaN at 0)
    hi = np.take_along_axis(s, n // 2, axis=1)
    return ((lo + hi) / 2)[:, 0]
