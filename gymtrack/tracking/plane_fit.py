"""The apparatus plane and the floor estimated from the data (beyond the paper; ``planes: auto``).

Paper: Section III-C's vertical plane (Eq. 7) is given by hand. Here it is fitted from the
target gymnast's well-triangulated centres: a first pass of the tracker in ``triangulation``
mode (which needs no plane) identifies the target (Eq. 13) and triangulates it (Eq. 3); its
points seen by three or more views (or, where there are too few, by two) feed a RANSAC fit of
a vertical plane (:func:`gymtrack.geometry.plane_fit.fit_vertical_plane`). The floor is fitted
to the box bottoms of the other people while they stand (box height 1.4-2.1 m), the classic
ground-plane mapping.

:class:`PlaneEstimator` owns the points gathered so far (``add`` a batch of track points and
the target's frames, ``fit`` when enough are in); :func:`fit_scene_planes` runs it over a
result, :func:`resolve_auto_planes` gives the scene with the fitted plane when ``planes: auto``.
Shapes: track points as :class:`~.types.Tracks3D` rows (N,), points (N, 3).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..detections import Detections
from ..errors import InputError
from ..geometry.camera import Rig
from ..geometry.plane import Plane
from ..geometry.plane_fit import PlaneFitResult, fit_plane, fit_vertical_plane, plane_difference
from ..scene import PlaneSpec, Scene
from .types import TRIANGULATION, Target, Tracks3D, TrackResult

__all__ = ["MIN_POINTS", "PlaneEstimator", "ScenePlaneFit", "fit_scene_planes", "with_plane", "resolve_auto_planes"]

MIN_POINTS = 30  #: points a fit needs (a second of a well-seen routine)
STANDING = (1.4, 2.1)  #: box heights (m) of a standing person, whose box bottom is on the floor


class PlaneEstimator:
    """Gathers the target's well-triangulated centres and standing people's feet; fits both planes.

    min_views: views a target point needs to count as well triangulated (fewer are used only
    when there are not ``MIN_POINTS`` such points); threshold: RANSAC inlier distance, metres.
    """

    def __init__(self, min_views: int = 3, threshold: float = 0.3):
        self.min_views, self.threshold = min_views, threshold
        self._target: list[np.ndarray] = []  # (n, 4): x, y, z, n_views
        self._feet: list[np.ndarray] = []  # (n, 3)

    def add(self, tracks: Tracks3D, target: Target) -> None:
        """Track points (final) and the target's frames of the same stretch of the stream."""
        if not len(tracks):
            return
        tri = tracks.source == TRIANGULATION
        key = tracks.frame * (1 << 32) + tracks.track_id
        is_target = np.isin(key, target.frame * (1 << 32) + target.track_id)
        t = tri & is_target
        self._target.append(np.column_stack([tracks.xyz[t], tracks.n_views[t]]))
        height = tracks.top_z - tracks.bottom_z
        stand = tri & ~is_target & (height >= STANDING[0]) & (height <= STANDING[1])
        self._feet.append(np.column_stack([tracks.xyz[stand, :2], tracks.bottom_z[stand]]))

    @property
    def n_target(self) -> int:
        return sum(len(x) for x in self._target)

    def target_points(self) -> np.ndarray:
        """(n, 3) the target points a fit uses: those of >= ``min_views`` views, or of >= 2
        when there are fewer than :data:`MIN_POINTS` of them."""
        pts = np.concatenate(self._target) if self._target else np.zeros((0, 4))
        good = pts[:, 3] >= self.min_views
        if good.sum() < MIN_POINTS:
            good = pts[:, 3] >= 2
        return pts[good, :3]

    def fit(self) -> tuple[PlaneFitResult | None, PlaneFitResult | None]:
        """(apparatus plane, floor); None where there are fewer than :data:`MIN_POINTS` points."""
        pts = self.target_points()
        plane = fit_vertical_plane(pts, self.threshold) if len(pts) >= MIN_POINTS else None
        feet = np.concatenate(self._feet) if self._feet else np.zeros((0, 3))
        floor = fit_plane(feet, 0.1) if len(feet) >= MIN_POINTS else None
        return plane, floor


@dataclass(frozen=True)
class ScenePlaneFit:
    """What :func:`fit_scene_planes` found.

    plane, floor: the fits (None: too few points); n_target, n_feet: points used; offset,
    angle: metres and degrees from the scene's first plane to the fitted one at the scene's
    focus (NaN without either); floor_height: the floor's height under the focus (m).
    """

    plane: PlaneFitResult | None
    floor: PlaneFitResult | None
    n_target: int
    n_feet: int
    offset: float
    angle: float
    floor_height: float

    def to_dict(self) -> dict:
        pl = None if self.plane is None else self.plane.plane
        fl = None if self.floor is None else self.floor.plane
        return {
            "plane": None if pl is None else {"point": pl.point.round(4).tolist(), "normal": pl.normal.round(5).tolist(),
                                              "inliers": self.plane.n_inliers, "rms_m": round(self.plane.rms, 4)},
            "floor": None if fl is None else {"point": fl.point.round(4).tolist(), "normal": fl.normal.round(5).tolist(),
                                              "inliers": self.floor.n_inliers, "rms_m": round(self.floor.rms, 4)},
            "target_points": self.n_target, "feet_points": self.n_feet,
            "offset_m": self.offset, "angle_deg": self.angle, "floor_height_m": self.floor_height,
        }


def fit_scene_planes(result: TrackResult, scene: Scene, min_views: int = 3) -> ScenePlaneFit:
    """The apparatus plane and the floor fitted to a ``triangulation``-mode result of a routine
    (its target and track points), compared with the scene's first plane."""
    est = PlaneEstimator(min_views)
    est.add(result.tracks, result.target)
    plane, floor = est.fit()
    focus = scene.focus_point
    offset = angle = float("nan")
    if plane is not None and scene.planes:
        offset, angle = plane_difference(plane.plane, Plane.from_spec(scene.planes[0]), focus)
    height = float("nan")
    if floor is not None and abs(floor.plane.normal[2]) > 1e-6:
        n, p = floor.plane.normal, floor.plane.point
        height = float(p[2] - (n[0] * (focus[0] - p[0]) + n[1] * (focus[1] - p[1])) / n[2])
    n_feet = sum(len(f) for f in est._feet)
    return ScenePlaneFit(plane, floor, len(est.target_points()), n_feet, offset, angle, height)


def with_plane(scene: Scene, plane: Plane) -> Scene:
    """The scene with ``plane`` as its only plane (``auto_planes`` cleared)."""
    spec = PlaneSpec(point=tuple(plane.point.tolist()), normal=tuple(plane.normal.tolist()))
    return scene.model_copy(update={"planes": (spec,), "auto_planes": False})


def resolve_auto_planes(rig: Rig, scene: Scene, detections: Detections,
                        track: Callable[..., TrackResult]) -> Scene:
    """``planes: auto``: the scene with the plane fitted to ``detections`` tracked by ``track``
    (:func:`~.tracker.track_detections`, given by the caller) in ``triangulation`` mode; any
    other scene is returned as it is. Raises InputError when too few target points were
    triangulated."""
    if not scene.auto_planes:
        return scene
    first = scene.model_copy(update={"auto_planes": False})  # (the first pass must not resolve again)
    fit = fit_scene_planes(track(rig, first, detections, mode="triangulation"), scene)
    if fit.plane is None:
        raise InputError(f"planes: auto: only {fit.n_target} well-triangulated target points, a fit needs "
                         f"{MIN_POINTS}; give the plane in scene.yaml", field="planes")
    return with_plane(scene, fit.plane.plane)
