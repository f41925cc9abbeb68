"""Online refinement of the apparatus plane from the tracker's own points (beyond the paper).

Paper: Section III-C's vertical plane (Eq. 7) is fixed before tracking. In ``cascade+`` with
``params.refine_plane`` > 0 (or ``planes: auto``) the tracker refits it as it goes: the
window's triangulated clusters that passed the outlier and ghost tests, and its opposite pairs
(the plane stage still takes those; here they are triangulated too, Eq. 3) give points, kept
when they are on the apparatus (:func:`~.plane_fit.on_apparatus`: inside ``S_perf``, the
body's bottom above ``h_bot``, and its top above ``h_top``: Eq. 13's test, so that coaches and
people standing by do not count). Every ``refine_plane`` windows
:func:`~gymtrack.geometry.plane_fit.fit_apparatus_plane` refits the plane from the last
``max_points`` of them, each weighted by its triangulation covariance (an opposite pair's point
counts for little along the cameras' axis), its direction searched about the starting plane's:
where the data do not determine it only the offset moves. The plane moves when the fit
differs by more than ``min_move`` metres or ``min_turn`` degrees at the focus.

Trade: a small ``refine_plane`` follows the data sooner but refits more often (each refit is a
scan of 40 directions, coarse to fine, over at most ``max_points`` points, ~10 ms); points are gathered
from every other window (windows overlap by half: each frame once, at half the cost), in a
bounded buffer.
``summary()`` records how the plane moved (the tracker's summary, ``plane_refinement``).
"""

from __future__ import annotations

from collections import deque

import numpy as np

from ..geometry.plane import Plane
from ..geometry.plane_fit import fit_apparatus_plane, plane_difference, triangulation_covariances
from ..scene import Scene
from .plane_fit import MIN_POINTS, on_apparatus
from .reconstruct import triangulate_clusters
from .types import WindowTracklets, WindowTracklets3D

__all__ = ["PlaneRefiner"]


class PlaneRefiner:
    """Gathers well-observed points on the apparatus; refits the plane every ``every`` windows.

    P: (C, 3, 4) projections (undistorted pixels, as the windows' boxes); plane: the starting plane.
    """

    def __init__(self, P: np.ndarray, scene: Scene, plane: Plane, every: int, max_points: int = 1500,
                 min_move: float = 0.02, min_turn: float = 0.5):
        p = scene.params
        self.P, self.every, self.step = P, every, p.step
        self.initial = self.plane = plane
        self.focus = scene.focus_point
        self.on = on_apparatus(scene)
        self.h_top = scene.target.h_top
        self.pixel_sigma, self.box_sigma, self.stray = p.pixel_sigma, p.box_sigma, p.plane_sigma
        self.min_move, self.min_turn = min_move, min_turn
        self._buf: deque = deque()  # (xyz (n, 3), views (n, C), sigma (n, C)) per window
        self._n = 0
        self.max_points = max_points
        self.windows = self.refits = self.moves = self.undetermined = 0
        self.history: list[dict] = []

    def observe(self, segs: WindowTracklets, tri: WindowTracklets3D, pairs: np.ndarray) -> None:
        """One window: ``tri`` its triangulated clusters that passed the outlier and ghost tests,
        ``pairs`` (M, C) its clusters of >= 2 views the cascade sends to the plane (opposite
        pairs; indices into ``segs``), triangulated here for the plane only."""
        self.windows += 1
        if self.windows % 2:  # every other window: they cover the frames once, at half the cost
            return
        if len(tri):
            self._take(segs, tri)
        if len(pairs):
            self._take(segs, triangulate_clusters(segs, pairs, self.P))

    def _take(self, segs: WindowTracklets, tri: WindowTracklets3D) -> None:
        xyz, bottom = tri.xyz, tri.bottom_z
        # Eq. 13's test as well (the body's top above h_top): without the target's identity, people
        # standing by and ghosts low in S_perf must not pull the plane
        ok = tri.valid & (tri.n_views >= 2) & (tri.top_z >= self.h_top)
        ok[ok] = self.on(xyz[ok], bottom[ok])
        if not ok.any():
            return
        m, f = np.nonzero(ok)
        seg = tri.members[m]  # (n, C)
        segc = np.maximum(seg, 0)
        views = (seg >= 0) & segs.observed[segc, f[:, None]]
        sigma = self.pixel_sigma + self.box_sigma * segs.box[segc, f[:, None], 3]
        self._buf.append((xyz[m, f], views, np.where(views, sigma, 1.0)))
        self._n += len(m)
        while self._n - len(self._buf[0][0]) >= self.max_points:
            self._n -= len(self._buf.popleft()[0])

    def __len__(self) -> int:
        """Points held (bounded by ``max_points`` plus one window's)."""
        return self._n

    def due(self) -> bool:
        """A refit now: every ``every`` windows, and as soon as there are enough points for a first."""
        return self._n >= MIN_POINTS and (self.refits == 0 or self.windows % self.every == 0)

    def refit(self, frame: int) -> Plane | None:
        """The refitted plane when it moved (else None); ``frame``: where the stream is (recorded)."""
        xyz = np.concatenate([b[0] for b in self._buf])
        views = np.concatenate([b[1] for b in self._buf])
        sigma = np.concatenate([b[2] for b in self._buf])
        cov = triangulation_covariances(self.P, xyz, views, sigma)
        # the direction is searched about the starting plane (a refit must not wander 30 deg per round);
        # where the data do not fix it, the current direction is kept and only the offset refitted
        fit = fit_apparatus_plane(xyz, cov, self.initial, stray=self.stray)
        self.refits += 1
        if not fit.determined:
            self.undetermined += 1
            fit = fit_apparatus_plane(xyz, cov, self.plane, stray=self.stray, max_turn=0.0)
        off, ang = plane_difference(fit.plane, self.plane, self.focus)
        if off < self.min_move and ang < self.min_turn:
            return None
        self.plane = fit.plane
        self.moves += 1
        o0, a0 = plane_difference(self.plane, self.initial, self.focus)
        self.history.append({"frame": int(frame), "points": int(len(xyz)), "direction_determined": fit.determined,
                             "offset_from_start_m": round(o0, 4), "angle_from_start_deg": round(a0, 3)})
        return self.plane

    def summary(self) -> dict:
        """How the plane moved: refits, moves, the final plane and its offset/angle from the start."""
        off, ang = plane_difference(self.plane, self.initial, self.focus)
        return {"refits": self.refits, "moves": self.moves, "refits_direction_undetermined": self.undetermined,
                "points": self._n, "offset_from_start_m": round(off, 4), "angle_from_start_deg": round(ang, 3),
                "point": self.plane.point.round(4).tolist(), "normal": self.plane.normal.round(5).tolist(),
                "history": self.history[-20:]}
