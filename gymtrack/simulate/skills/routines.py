"""The whole target routine per apparatus, with the off-plane drift.

Paper: Section III-C (moments off the vertical plane: :func:`add_drift` moves the centre (n, 3)
along the plane normal) and Section IV's seven apparatus (:data:`ROUTINES`).
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import distance_transform_edt, gaussian_filter1d

from ...apparatus import Apparatus
from .. import body as B
from ..motion import Motion, MotionBuilder, smoothstep
from .bars import horizontal_bar_routine, parallel_bars_routine, uneven_bars_routine
from .beam import beam_routine
from .choreography import Choreography, Event, Layout
from .pommel import pommel_routine
from .rings import rings_routine
from .vault import vault_routine

ROUTINES = {
    "balance_beam": beam_routine,
    "pommel_horse": pommel_routine,
    "vault": vault_routine,
    "still_rings": rings_routine,
    "horizontal_bar": horizontal_bar_routine,
    "uneven_bars": uneven_bars_routine,
    "parallel_bars": parallel_bars_routine,
}

#: Off-plane drift per apparatus: (standard deviation m, correlation time s, clip m).
DRIFT = {
    "balance_beam": (0.02, 1.0, 0.06),
    "pommel_horse": (0.03, 1.0, 0.1),
    "vault": (0.04, 1.5, 0.12),
    "still_rings": (0.025, 1.2, 0.08),
    "horizontal_bar": (0.15, 3.0, 0.45),
    "uneven_bars": (0.15, 3.0, 0.45),
    "parallel_bars": (0.05, 1.5, 0.12),
}


def add_drift(motion: Motion, app: Apparatus, rng: np.random.Generator, fps: float) -> np.ndarray:
    """Add the off-plane drift along the plane normal to the performing frames, in place.

    A smooth random process (Gaussian-filtered noise, std and correlation time per apparatus,
    clipped), faded in and out over 0.5 s at the edges of the performance, and replaced by a
    straight line through every flight (no sideways force in the air). Returns the (n,) drift.
    """
    sigma, corr, clip = DRIFT[app.name]
    n = len(motion)
    noise = gaussian_filter1d(rng.standard_normal(n + 200), corr * fps, mode="reflect")[100:-100]
    noise *= sigma / max(noise.std(), 1e-9)
    drift = clip * np.tanh(noise / clip)
    # fade in and out over 0.5 s inside the performance: zero at its edges, so no jump there
    inside = np.pad(motion.performing, 1)
    env = smoothstep(distance_transform_edt(inside)[1:-1] / (0.5 * fps))
    drift *= env
    fl = motion.flight
    if fl.any():
        idx = np.arange(n)
        edges = np.diff(np.concatenate([[0], fl.astype(np.int8), [0]]))
        starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        for s0, s1 in zip(starts, stops):  # a handful of flights per routine
            a, z = max(s0 - 1, 0), min(s1, n - 1)
            drift[s0:s1] = np.interp(idx[s0:s1], [a, z], [drift[a], drift[z]])
    normal = np.asarray(app.plane_normal, float)
    motion.centre += drift[:, None] * normal[None]
    return drift


def target_routine(app: Apparatus, seconds: float, fps: float, rng: np.random.Generator, body: B.BodyModel,
                   layout: Layout) -> tuple[Motion, list[Event], np.ndarray, list[dict]]:
    """The target gymnast's whole routine on ``app``, exactly ``round(seconds * fps)`` frames.

    Returns the motion (drift included), the events coaches react to, the (n,) drift and the
    choreography's element records (:attr:`MotionBuilder.records`, for ``gt/elements.json``)."""
    b = MotionBuilder(body, fps, rng)
    c = Choreography(app, b, rng, layout, int(round(seconds * fps)))
    ROUTINES[app.name](c)
    motion = b.build()
    drift = add_drift(motion, app, rng, fps)
    return motion, c.events, drift, b.records
