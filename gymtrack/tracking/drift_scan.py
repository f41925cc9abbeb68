"""The venue check's change scan: when a camera's residuals moved, and by how much in their scatter.

Beyond the paper (see :mod:`.drift`). A knock is a step in each key's median residual at an
unknown sample. For each candidate step -- the last ``m`` samples moved, ``n_recent <= m <=
n_scan`` -- the recent samples' mean less the baseline's median (the ``n_base`` samples before
them) is weighed in the scatter of that mean: the baseline samples' scatter over ``sqrt(m)``
(a step's evidence grows with the samples since it, Page's CUSUM / the likelihood ratio of a
step at an unknown time). The candidate whose keys' moves weigh most (each key's share capped)
is kept. ``m = n_recent`` (one second) is the single-window test the thresholds of :mod:`.drift`
were set on; a longer step's evidence is counted as the longer mean earns it.

Every candidate is weighed over every key in one compiled call (:func:`._kernels.drift.scan_steps`;
numpy reference ``scan_steps_numpy`` in ``tests/reference/drift.py``): the scan runs at every
sample, and as numpy calls per candidate it was most of the venue check's time.
"""

from __future__ import annotations

import numpy as np

from ._kernels import drift as kernels

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
    return kernels.scan_steps(np.ascontiguousarray(meds, np.float64), int(n_base), int(n_recent), float(min_sigma), float(cap),
                              int(shortest or n_recent))
