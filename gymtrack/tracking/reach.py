"""Where a body can be held up: Eq. 13 counts a raised point away from the apparatus only for a flight's length.

Beyond the paper (Section III-D, Eq. 13; the recipe's ``reach``). Eq. 13 takes a track for the
gymnast when its body's bottom is above ``h_bot`` in the performance space. Off the floor a
body is held up by the apparatus, or it is in the air. A point raised above ``h_bot`` and more
than :data:`REACH` from every bar and block of the preset (laid on the scene's plane,
:mod:`gymtrack.placement`) is in the air, and nobody stays in the air longer than a flight
lasts: such a point counts for Eq. 13 only within the first :data:`MAX_FLIGHT_SECONDS` of its
track's run of raised points away from the apparatus. What outlasts it is a phantom of
association -- a person off the plane seen by one view, or by an opposite pair whose rays meet
the plane above the floor -- which stood still as a target at the edge of the performance space
for whole routines (uneven bars, vault; two opposite cameras), before the gymnast qualified.

A flight is also ballistic (gravity, g = 9.81 m/s^2): any stretch of a parabola that lasts
``tau`` seconds spans at least ``g tau^2 / 8`` metres of height (the least is the stretch centred
on the apex). A run whose centre has spanned less, by more than :data:`LEVEL_MARGIN`, is not a
flight: from that point on it counts no more. A phantom stays level (a plane point of a person
walking), and is given up after about 0.45 s instead of a flight's length -- before Eq. 13 can
identify it (more than Delta / 2 = 15 frames). The centre is that of the body's box, not the
centre of mass, so the margin holds what a tuck or an opening moves it by: of the simulated
gymnasts' 90 raised-away runs (seeds 0-2, n_cam 4 truth), the 31 long enough for the bound to
judge (12 to 28 frames) each spanned more than the bound less 0.08 m over their first 12 to 24.

Such a point is where no body can be: it counts neither for identifying a track nor for
keeping a target in the performance space (Eq. 13's "leaves"), so a phantom identified in its
first moments gives the target up a flight's length later. A scene without an apparatus behaves
as the paper's rule.
"""

from __future__ import annotations

import numpy as np

from ..placement import Geometry, yaw_rotation
from ._kernels.target import apparatus_distance
from .ballistic import G

__all__ = ["REACH", "MAX_FLIGHT_SECONDS", "LEVEL_MARGIN", "ReachLimit"]

#: metres from the nearest bar or block beyond which a raised body is not held up: a gymnast's
#: centre hangs about 1.1 m below a bar's grip and stands about 1.0 m over a beam or a bar in a
#: handstand. The simulator's gymnasts (seeds 0-2, 168 routines) were raised beyond 1.5 m for
#: at most 0.93 s at a time (dismounts and the vault's second flight).
REACH = 1.5
#: seconds: the longest flight counted. The longest flight there is, a horizontal bar dismount
#: from the grip at 2.8 m with the centre rising about 1 m above it, lasts about 1.4 s (0.45 s up
#: at 4.4 m/s, 0.96 s down 4.5 m under g = 9.81), and only part of it lies beyond REACH.
MAX_FLIGHT_SECONDS = 1.5
#: metres: how much less than ``g tau^2 / 8`` a flight's centre may span in ``tau`` seconds (the
#: body box's centre against the centre of mass, and the estimate's noise; see the module docstring)
LEVEL_MARGIN = 0.15


class ReachLimit:
    """The reach rule on a stream of track points (see the module docstring).

    geometry: the apparatus laid on the scene (:func:`gymtrack.placement.scene_geometry`);
    h_bot: Eq. 13's bottom height; fps: frames per second.
    State: per track whose last point was raised away from the apparatus, its run: first and last
    frame, lowest and highest centre, and whether it has stayed too level for a flight (dropped
    once a flight's length has passed since it).
    """

    def __init__(self, geometry: Geometry, h_bot: float, fps: float):
        self.geometry, self.h_bot, self.fps = geometry, float(h_bot), float(fps)
        g = geometry  # the surfaces as the compiled distance reads them
        self._has_apparatus = g.has_apparatus
        self._surfaces = tuple(np.ascontiguousarray(np.reshape(a, shape), np.float64) for a, shape in (
            (g.bar_a, (-1, 3)), (g.bar_b, (-1, 3)), (g.bar_r, (-1,)), (g.box_lo, (-1, 3)), (g.box_hi, (-1, 3)),
            (yaw_rotation(g.yaw), (3, 3)), (g.shift, (3,))))
        self.max_frames = int(round(MAX_FLIGHT_SECONDS * fps))
        # track id -> (first frame of its run, last frame, lowest z, highest z, level)
        self._open: dict[int, tuple[int, int, float, float, bool]] = {}

    def __len__(self) -> int:
        return len(self._open)

    def grounded(self, frame: np.ndarray, tid: np.ndarray, xyz: np.ndarray, bottom_z: np.ndarray) -> np.ndarray:
        """(n,) rows in frame order -> (n,) bool: False where the point is raised away from the
        apparatus for longer than a flight, or too level for one (it must not count for Eq. 13)."""
        n = len(frame)
        if not n or not self._has_apparatus:
            return np.ones(n, bool)
        away = bottom_z > self.h_bot  # (NaN: False)
        raised = np.flatnonzero(away)
        if len(raised):  # the distance only where it can matter: most points stand on the floor
            away[raised] = apparatus_distance(np.ascontiguousarray(xyz[raised], np.float64), *self._surfaces) > REACH
        if not away.any():  # every track here is grounded: its run, if any, has ended
            if self._open:
                for k in set(tid.tolist()).intersection(self._open):
                    del self._open[k]
                self._forget(int(frame.max()))
            return np.ones(n, bool)
        order = np.lexsort((frame, tid))  # each track's rows in frame order
        t, f, a, z = tid[order], frame[order], away[order], np.asarray(xyz, np.float64)[order, 2]
        new_track = np.ones(n, bool)
        new_track[1:] = t[1:] != t[:-1]
        # a run of raised points away begins at an away row after a grounded row or a track's first row
        begins = a.copy()
        begins[1:] &= new_track[1:] | ~a[:-1]
        start = np.where(begins, f, -1)
        run = np.cumsum(begins)  # each row's run (0: before any); runs ascend along the rows
        seed = np.zeros((run[-1] + 1, 3))  # per run: lowest z, highest z, level -- carried over the calls
        seed[:, 0], seed[:, 1] = np.inf, -np.inf
        for i in np.flatnonzero(begins & new_track):  # a run open since the last call continues
            held = self._open.get(int(t[i]))
            if held is not None and f[i] - held[1] <= self.max_frames:
                start[i] = held[0]
                seed[run[i]] = held[2], held[3], held[4]
        first = np.zeros(run[-1] + 1, np.int64)
        first[run[begins]] = start[begins]
        zin = np.where(a & np.isfinite(z), z, np.nan)
        hi = _running_max(np.fmax(zin, seed[run, 1]), run)  # each run's highest and lowest centre so far
        lo = -_running_max(np.fmax(-zin, -seed[run, 0]), run)
        tau = (f - first[run]) / self.fps
        level = a & (hi - lo < G * tau ** 2 / 8 - LEVEL_MARGIN)
        level = _running_max((level | (seed[run, 2] > 0)).astype(np.float64), run) > 0  # once level, it stays
        ok = ~a | ((f - first[run] < self.max_frames) & ~level)
        last = np.append(new_track[1:], True)  # each track's last row in this call
        for i in np.flatnonzero(last):
            if a[i]:
                self._open[int(t[i])] = (int(first[run[i]]), int(f[i]), float(lo[i]), float(hi[i]), bool(level[i]))
            else:
                self._open.pop(int(t[i]), None)
        self._forget(int(frame.max()))
        out = np.empty(n, bool)
        out[order] = ok
        return out

    def _forget(self, frame: int) -> None:
        """Drop the runs whose track has not been seen for a flight's length before ``frame``."""
        horizon = frame - self.max_frames
        for k in [k for k, held in self._open.items() if held[1] < horizon]:
            del self._open[k]


def _running_max(x: np.ndarray, run: np.ndarray) -> np.ndarray:
    """(n,) the maximum of ``x`` so far within each row's run (NaN: none; -inf before any value).
    run: (n,) non-decreasing run index per row. One ``np.maximum.accumulate``: each run is lifted
    above the ones before it by an offset larger than the values' spread."""
    x = np.asarray(x, np.float64)
    x = np.where(np.isnan(x), -np.inf, x)
    finite = np.abs(x[np.isfinite(x)])
    step = 2.0 * (np.max(finite, initial=0.0) + 1.0)
    return np.maximum.accumulate(x + run * step) - run * step
