"""The apparatus plane and the floor estimated from the data (beyond the paper; ``planes: auto``).

Paper: Section III-C's vertical plane (Eq. 7) is given by hand. Here it is fitted from the
target gymnast's triangulated centres: a first pass of the tracker in ``triangulation`` mode
(which needs no plane) identifies the target (Eq. 13) and triangulates it (Eq. 3); with a
preset plane, a ``cascade`` pass adds the target frames the first lacks, its two-view frames
re-triangulated from their boxes. The target's points on the apparatus, of two or more views,
feed :func:`gymtrack.geometry.plane_fit.fit_apparatus_plane`, each weighted by its
triangulation covariance, computed from the views whose boxes made it (an
opposite pair's point counts for little along the cameras' axis, the plane's normal, so the
two-view case of ``n_cam = 2`` is still determined across it); where the data do not determine
the direction (the pommel horse, a gymnast who hardly moves along the plane) the preset's
direction is kept and only the offset fitted, and the fit says why. The floor is fitted
to the box bottoms of the other people while they stand (box height 1.4-2.1 m), the classic
ground-plane mapping.

:class:`PlaneEstimator` owns the points gathered so far (``add`` a batch of track points and
the target's frames, ``fit`` when enough are in); :func:`fit_scene_planes` runs it over a
result, :func:`resolve_auto_planes` gives the scene with the fitted plane when ``planes: auto``.
Shapes: track points as :class:`~.types.Tracks3D` rows (N,), points (N, 3).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..detections import Detections
from ..errors import InputError
from ..geometry.camera import Rig
from ..geometry.plane import Plane
from ..geometry.plane_fit import (PlaneFitResult, fit_apparatus_plane, fit_plane, fit_vertical_plane, plane_difference,
                                  triangulation_covariances)
from ..scene import Params, PlaneSpec, Scene, in_box
from ..geometry.triangulation import triangulate_rig
from .types import PLANE, TRIANGULATION, Target, Tracks3D, TrackResult

__all__ = ["MIN_POINTS", "REFINE_EVERY", "on_apparatus", "PlaneEstimator", "ScenePlaneFit", "fit_scene_planes",
           "with_plane", "resolve_auto_planes"]

MIN_POINTS = 30  #: points a fit needs (a second of a well-seen routine)
REFINE_EVERY = 20  #: windows between cascade+'s online refits when planes: auto turns them on (.plane_refine)
STANDING = (1.4, 2.1)  #: box heights (m) of a standing person, whose box bottom is on the floor


def on_apparatus(scene: Scene) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """``f(xyz (N, 3), bottom_z (N,)) -> (N,) bool``: the target is on the apparatus -- inside
    ``S_perf`` with the body's bottom above Eq. 13's ``h_bot`` (off the floor: not the run-up,
    the landing or standing by). Points with an unknown bottom count as on it."""
    box = np.asarray(scene.performance_space, dtype=np.float64)
    h_bot = scene.target.h_bot

    def f(xyz: np.ndarray, bottom_z: np.ndarray) -> np.ndarray:
        return in_box(xyz, box) & ~(bottom_z < h_bot)
    return f


class PlaneEstimator:
    """Gathers the target's well-triangulated centres and standing people's feet; fits both planes.

    With a ``rig`` (and the boxes given to :meth:`add`) every target point of two or more views
    is used, weighted by its covariance (:func:`fit_apparatus_plane`, ``preset``: the direction kept
    when the data do not determine one); without, the old rule: RANSAC
    (:func:`fit_vertical_plane`, inlier distance ``threshold``) on points of >= ``min_views`` views
    (of two when there are not ``MIN_POINTS`` such points).
    """

    def __init__(self, min_views: int = 3, threshold: float = 0.3, rig: Rig | None = None,
                 scene: Scene | None = None, preset: Plane | None = None):
        self.min_views, self.threshold = min_views, threshold
        self.rig, self.preset = rig, preset
        p = scene.params if scene is not None else Params()  # (the detector noise and the plane's stray)
        self.pixel_sigma, self.box_sigma, self.stray = p.pixel_sigma, p.box_sigma, p.plane_sigma
        self.on_apparatus = None if scene is None else on_apparatus(scene)
        self._target: list[np.ndarray] = []  # (n, 5): x, y, z, n_views, on the apparatus
        self._cov: list[np.ndarray] = []  # (n, 3, 3) with a rig and boxes
        self._feet: list[np.ndarray] = []  # (n, 3)

    def add(self, tracks: Tracks3D, target: Target, boxes: Detections | None = None) -> None:
        """Track points (final) and the target's frames of the same stretch of the stream;
        ``boxes``: the tracks' 2D boxes (``track_id`` = the 3D track), for the covariances and,
        with a rig, to triangulate (Eq. 3) the target's points the plane stage made from two or
        more views (a cascade pass: its opposite pairs), so that a first pass with the preset
        plane gives its two-view frames too."""
        if not len(tracks):
            return
        tri = tracks.source == TRIANGULATION
        key = tracks.frame * (1 << 32) + tracks.track_id
        is_target = np.isin(key, target.frame * (1 << 32) + target.track_id)
        t = is_target & (tri | ((tracks.source == PLANE) & (tracks.n_views >= 2)))
        xyz, bottom, nv = tracks.xyz[t], tracks.bottom_z[t], tracks.n_views[t]
        cov = None
        if self.rig is not None and boxes is not None:
            views, box = self._views(tracks.frame[t], tracks.track_id[t], boxes)
            redo = tracks.source[t] == PLANE
            if redo.any():  # the plane put these points there: triangulate their box centres and bottoms
                xyz, bottom = xyz.copy(), bottom.copy()
                c, b = box[redo, :, :2], box[redo, :, :2] + np.stack([0 * box[redo, :, 3], box[redo, :, 3] / 2], -1)
                xyz[redo] = triangulate_rig(self.rig, c, views[redo])[0]
                bottom[redo] = triangulate_rig(self.rig, b, views[redo])[0][:, 2]
                nv = np.where(redo, views.sum(axis=1), nv)
            sigma = np.where(views, self.pixel_sigma + self.box_sigma * np.nan_to_num(box[..., 3]), 1.0)
            cov = triangulation_covariances(self.rig.projections, xyz, views, sigma)
        elif (tracks.source[t] == PLANE).any():  # without boxes, plane points are not measurements
            keep = tracks.source[t] == TRIANGULATION
            xyz, bottom, nv = xyz[keep], bottom[keep], nv[keep]
        # the plane holds while the gymnast is on the apparatus (used when there are enough such points)
        on = np.ones(len(xyz)) if self.on_apparatus is None else self.on_apparatus(xyz, bottom)
        self._target.append(np.column_stack([xyz, nv, on]))
        if cov is not None:
            self._cov.append(cov)
        height = tracks.top_z - tracks.bottom_z
        stand = tri & ~is_target & (height >= STANDING[0]) & (height <= STANDING[1])
        self._feet.append(np.column_stack([tracks.xyz[stand, :2], tracks.bottom_z[stand]]))

    def _views(self, frame: np.ndarray, track: np.ndarray, boxes: Detections) -> tuple[np.ndarray, np.ndarray]:
        """The views (n, C) bool whose boxes made each (frame, track) point, and the boxes (n, C, 4)
        (raw pixels, NaN where the view has none)."""
        key = frame * (1 << 32) + track
        order = np.argsort(key)
        bkey = boxes.frame.astype(np.int64) * (1 << 32) + boxes.track_id
        pos = np.clip(np.searchsorted(key[order], bkey), 0, max(len(key) - 1, 0))
        hit = key[order][pos] == bkey if len(key) else np.zeros(len(bkey), bool)
        row = order[pos[hit]]
        cam = boxes.camera[hit].astype(np.int64)
        views = np.zeros((len(key), len(self.rig)), bool)
        box = np.full((len(key), len(self.rig), 4), np.nan)
        views[row, cam] = True
        box[row, cam] = boxes.box[hit]
        return views, box

    @property
    def n_target(self) -> int:
        return sum(len(x) for x in self._target)

    @property
    def weighted(self) -> bool:
        """Covariance-weighted fit (a rig and boxes were given)."""
        return self.rig is not None and len(self._cov) == len(self._target) and len(self._cov) > 0

    def target_points(self) -> np.ndarray:
        """(n, 3) the target points a fit uses: weighted, those of >= ``min_views`` views on the
        apparatus (:func:`on_apparatus`), of >= 2 views when there are fewer than
        :data:`MIN_POINTS` such (then all, on the apparatus or not, when still fewer); else those of >=
        ``min_views`` views, or of >= 2 when there are fewer than :data:`MIN_POINTS` of them."""
        return self._selected()[0]

    def _selected(self) -> tuple[np.ndarray, np.ndarray | None]:
        pts = np.concatenate(self._target) if self._target else np.zeros((0, 5))
        if self.weighted:
            on = pts[:, 4] > 0
            good = pts[:, 3] >= self.min_views  # well triangulated: used alone when there are enough
            if (good & on).sum() < MIN_POINTS:  # (n_cam = 2: the opposite pair's points, weighted)
                good = pts[:, 3] >= 2
            if (good & on).sum() >= MIN_POINTS:  # else (a vault's short flight) all of them
                good &= on
            return pts[good, :3], np.concatenate(self._cov)[good]
        good = pts[:, 3] >= self.min_views
        if good.sum() < MIN_POINTS:
            good = pts[:, 3] >= 2
        return pts[good, :3], None

    def fit(self) -> tuple[PlaneFitResult | None, PlaneFitResult | None]:
        """(apparatus plane, floor); None where there are fewer than :data:`MIN_POINTS` points."""
        pts, cov = self._selected()
        if len(pts) < MIN_POINTS:
            plane = None
        elif cov is not None:
            plane = fit_apparatus_plane(pts, cov, self.preset, stray=self.stray)
        else:
            plane = fit_vertical_plane(pts, self.threshold)
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
                                              "inliers": self.plane.n_inliers, "rms_m": round(self.plane.rms, 4),
                                              "direction_determined": self.plane.determined,
                                              "why_not": self.plane.reason or None,
                                              "angle_sigma_deg": round(self.plane.angle_sigma_deg, 3)},
            "floor": None if fl is None else {"point": fl.point.round(4).tolist(), "normal": fl.normal.round(5).tolist(),
                                              "inliers": self.floor.n_inliers, "rms_m": round(self.floor.rms, 4)},
            "target_points": self.n_target, "feet_points": self.n_feet,
            "offset_m": self.offset, "angle_deg": self.angle, "floor_height_m": self.floor_height,
        }


def fit_scene_planes(result: TrackResult, scene: Scene, min_views: int = 3, rig: Rig | None = None,
                     extra: TrackResult | None = None) -> ScenePlaneFit:
    """The apparatus plane and the floor fitted to a ``triangulation``-mode result of a routine
    (its target and track points), compared with the scene's first plane (also the preset
    direction kept when the data do not determine one). With the ``rig``: the covariance-
    weighted fit (:class:`PlaneEstimator`); ``extra``: a cascade pass with the preset plane,
    whose target frames the first lacks are added (its two-view frames re-triangulated): on the
    suite's n_cam = 2 routines it found the beam's plane to 1 cm where the first pass alone
    was 4 cm off, and alone it lost the vault (whose cascade with a wrong plane loses the target)."""
    preset = Plane.from_spec(scene.planes[0]) if scene.planes else None
    est = PlaneEstimator(min_views, rig=rig, scene=scene, preset=preset)
    est.add(result.tracks, result.target, result.boxes)
    if extra is not None:
        t = extra.target
        new = ~np.isin(t.frame, result.target.frame)
        est.add(extra.tracks, Target(t.frame[new], t.track_id[new], t.xyz[new], t.source[new]), extra.boxes)
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
    (:func:`~.offline.track_detections`, given by the caller) in ``triangulation`` mode (and, with
    a preset plane, ``cascade`` mode: :func:`fit_scene_planes`'s ``extra``), and
    ``params.refine_plane`` set (cascade+ refines it online); any other scene is returned as it
    is. Warns when the direction was kept from the preset. Raises InputError when too few
    target points were triangulated."""
    if not scene.auto_planes:
        return scene
    first = scene.model_copy(update={"auto_planes": False})  # (the first pass must not resolve again)
    extra = track(rig, first, detections, mode="cascade") if scene.planes else None  # the preset's cascade
    fit = fit_scene_planes(track(rig, first, detections, mode="triangulation"), scene, rig=rig, extra=extra)
    if fit.plane is None:
        raise InputError(f"planes: auto: only {fit.n_target} well-triangulated target points, a fit needs "
                         f"{MIN_POINTS}; give the plane in scene.yaml", field="planes")
    if not fit.plane.determined:
        warnings.warn(f"planes: auto: the plane's direction is kept from scene.yaml ({fit.plane.reason}); "
                      "only its offset was fitted", stacklevel=2)
    out = with_plane(scene, fit.plane.plane)
    if not out.params.refine_plane:  # cascade+ goes on refining it online (other modes ignore the parameter)
        out = out.model_copy(update={"params": out.params.model_copy(update={"refine_plane": REFINE_EVERY})})
    return out
