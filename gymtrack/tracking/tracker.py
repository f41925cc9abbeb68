"""The streaming gymnast tracker (paper Section III, Fig. 2) and its offline runner.

:class:`Tracker` is fed one frame of boxes (all views) at a time and returns what became final.
It wires the stages; the stateful ones are objects of their own modules:

1. single view (III-A): one IoU tracker per camera links boxes into 2D tracks (raw pixels,
   :class:`~.single_view.IoUTracker`); the boxes wait in a :class:`~.records.BoxTable`;
2. windows (III-A): every ``step = window // 2`` frames the boxes received since the last
   window are undistorted (:mod:`.undistort`; the geometric stages work in undistorted pixels,
   the outputs keep the raw boxes) and the 2D tracks are cut into the window of the last
   ``window`` frames (:mod:`.windows`);
3. cross-view clustering (III-B): Eq. 2 distances and Algorithm 1 (:mod:`.clustering`);
4. triangulation (III-B, Eq. 3) of clusters of >= 2 views that are not just an opposite pair
   (judged at the apparatus), and the outlier test (Eq. 4) (:mod:`.reconstruct`);
5. the cascade (III-C): the rest go to the vertical plane, Eq. 5-9 (:mod:`.plane_fallback`;
   stages 4-5 of a window: :mod:`.cascade`);
6. cross-window linking (III-B, Eq. 10-11) (:class:`~.linking.WindowLinker`), carrying the 2D
   boxes along; the windows' points wait in :class:`~.records.WindowRecords` and are merged
   (Eq. 12) when final;
7. the heights of the body's top and bottom, from the box tops and bottoms by the same method;
8. the target gymnast (III-D, Eq. 13-14) (:class:`~.target.TargetStage`).

Latency: a frame's track points and boxes are final ``window - 1`` frames after it arrives;
the target adds ``backfill_frames`` (its decisions wait so an identification can claim the
frames it looked back on, :class:`~.identify.TargetBackfill`) and the smoothing half-window (2
frames), more only at the end of a target segment (see :class:`~.smoothing.TargetSmoother`).
Memory is bounded on an endless stream (what is held: :meth:`Tracker.state_size`).

Beyond the paper (README, "Beyond the paper"): lost tracks re-link across ``relink_frames``;
segments Eq. 2 separates are never fused on the plane; a view left alone may continue its 2D
track's 3D track on the plane; the target back-fill.

What the tracker does is a recipe, :class:`gymtrack.modes.Method`: one field per choice, read
here once and handed to the stages as plain arguments (no stage tests a mode's name). The named
recipes (:data:`gymtrack.modes.RECIPES`): ``cascade`` (the method), ``triangulation`` (no plane
fallback; single-tracklet clusters dropped, opposite pairs triangulated -- close to UniMMT),
``plane`` (every segment to the plane stage), the paper's ablation (Table 4); beyond the paper,
``cascade+``: the floor hypothesis and its ghost test (:mod:`.floor`), 2D tracks joined at low
frame rates by image motion (:mod:`.single_view_motion`),
duplicates left out (:mod:`.exclusion`), ray/plane fusion (:mod:`.fusion`) and online plane
refinement (:mod:`.plane_refine`) where the scene asks for them.
``association="oracle"`` replaces the IoU tracker and Algorithm 1 by ground-truth ids in
``Detections.track_id`` (>= 0; -1 = a false positive, dropped and counted): the limit better
association could reach (the plane stage still applies Eq. 8 within each person).
``planes: auto``: :mod:`.plane_fit`.

Speed (``benchmarks/bench_tracker.py``): stages work on whole windows of columns; skips are
counted in :meth:`Tracker.summary`.
"""

from __future__ import annotations

import time
from collections import defaultdict
from typing import Callable

import numpy as np

from ..detections import Detections
from ..errors import InputError
from ..modes import DEFAULT_MODE, Method, method_of
from ..scene import Scene
from ..geometry.arrays import PlaneArrays
from ..geometry.camera import Rig
from ..geometry.epipolar import fundamental_matrices
from ..geometry.plane import Plane
from ..geometry.views import opposite_pairs
from ._kernels import warm_up
from ._kernels.single_view import frame_rows_check
from .drift import DriftMonitor
from .clustering import complete_linkage, tracklet_distances
from .floor import continuation_only
from .exclusion import suppress_duplicates
from .fusion import PlaneRayFusion
from .linking import WindowLinker
from .cascade import plane_stage, triangulation_stage
from .plane_fit import REFINE_EVERY
from .plane_refine import PlaneRefiner
from .reconstruct import outliers, outliers_at_mean
from .single_view import IoUTracker
from .single_view_motion import MotionIoUTracker, needs_motion
from .handover import TargetHandover
from .ballistic import FlightKeeper
from .target import TargetStage
from .types import TrackerOutput, Tracks3D, WindowTracklets, WindowTracklets3D, member
from .records import BoxTable, WindowRecords
from .summary import STAGES, tracker_summary
from .windows import build_window

ASSOCIATIONS = ("iou", "oracle")


class Tracker:
    """Streaming multi-camera gymnast tracker.

    Parameters
    ----------
    rig: the cameras; ``Detections.camera`` indexes it.
    scene: performance space, buffer, planes, target heights and every parameter (``scene.params``).
    method: a :class:`~gymtrack.modes.Method` recipe or the name of one in
        :data:`~gymtrack.modes.RECIPES` (``cascade`` | ``triangulation`` | ``plane`` | ``cascade+``);
        ``mode=`` is the same argument under its older name.
    association: ``iou`` (the method) | ``oracle`` (ground-truth ids in ``track_id``).
    watch_cameras: watch each camera's residuals for a knock or a desync (:mod:`.drift`; on by default);
    recalibrate: then a knocked camera's rotation re-estimated and applied (the warning stays).

    Use: ``out = tracker.update(frame, detections_of_that_frame)`` for increasing frame
    numbers (frames without boxes may be skipped), then ``tracker.finish()``; every call
    returns a :class:`TrackerOutput` of what became final.
    """

    def __init__(self, rig: Rig, scene: Scene, method: Method | str = DEFAULT_MODE, association: str = "iou",
                 *, mode: Method | str | None = None, watch_cameras: bool = True, recalibrate: bool = True):
        try:
            m = self.method = method_of(method if mode is None else mode)
        except ValueError as e:
            raise InputError(str(e), field="mode") from None
        if association not in ASSOCIATIONS:
            raise InputError(f"unknown association {association!r}; choose one of {', '.join(ASSOCIATIONS)}",
                             field="association")
        if m.plane != "none" and not scene.planes:
            raise InputError(f"mode {m.name!r} needs at least one plane in scene.yaml (planes:)", field="planes")
        self.rig, self.scene, self.mode, self.association = rig, scene, m.name, association
        self._floor_only = np.zeros(0, np.int64)  # the ghost test's segments this window (floor only)
        self._outliers = outliers_at_mean if m.outliers_at_mean else outliers  # Eq. 4
        p = self.params = scene.params
        self.width, self.step = p.window, p.step
        self.n_cameras = len(rig)
        self.names = rig.names
        self.F = fundamental_matrices(rig)
        self.P = rig.projections
        self.centres = rig.centres
        self.planes = [Plane.from_spec(s) for s in scene.planes]
        self.plane_arrays = PlaneArrays.from_planes(self.planes)  # the planes as the plane kernel takes them
        # the recipe's surfaces: the scene's further surfaces join the planes in the plane stage only
        self.surfaces = [Plane.from_spec(s) for s in scene.surfaces] if m.surfaces else []
        self.stage_planes = PlaneArrays.from_planes(self.planes + self.surfaces)
        self.space = np.asarray(scene.tracking_space, dtype=np.float64)
        self.perf_space = np.asarray(scene.performance_space, dtype=np.float64)  # S_perf
        # (C, C) opposite camera pairs, judged at the scene's focus, the apparatus (see reconstruct)
        self.opposite = opposite_pairs(rig, scene.focus_point, p.opposite_angle_deg)
        warm_up()  # numba's compile / cache load of every kernel: once per process, never tracking time
        self.counts: dict = defaultdict(int)
        # the per-view tracker, linking by IoU or also by predicted image motion (.single_view_motion)
        self.iou = (MotionIoUTracker(scene.fps, p.iou_threshold, p.max_age, counts=self.counts)
                    if m.image_motion and association == "iou" and needs_motion(scene.fps)
                    else IoUTracker(p.iou_threshold, p.max_age))
        self.linker = WindowLinker(p.step, p.link_3d, p.relink_frames, p.max_speed, self.counts,
                                   floor_by_2d=m.floor or m.rejoin, keep_older=m.keep_older)  # rows linked by 2D tracks
        self.fusion = (PlaneRayFusion(rig, scene, self.plane_arrays, self.opposite, self.counts)
                       if m.fusion and p.fuse_plane else None)
        # frames a segment's end box is held (windows): max_age, or hold_seconds (capped at max_age)
        self.hold = p.max_age if m.hold_seconds is None else min(p.max_age, int(m.hold_seconds * scene.fps))
        flights = FlightKeeper(scene.fps, self.counts) if m.ballistic else None  # (.ballistic: through the handover)
        self.target = TargetStage(rig, scene, TargetHandover(p.identify_frames, self.counts, flights=flights, plain=m.handover)
                                  if m.handover or m.ballistic else None, reidentify=m.reidentify, counts=self.counts,
                                  reach=m.reach, chain=m.chain)
        self.venue = DriftMonitor(rig, scene.fps, p.step, self.opposite, recalibrate, active=watch_cameras)  # knocked or unsynchronised cameras
        # the apparatus plane refined online (.plane_refine); planes: auto turns it on
        every = p.refine_plane or (REFINE_EVERY if scene.auto_planes else 0)
        self.refiner = PlaneRefiner(self.P, scene, self.planes[0], every) if m.refine_plane and every else None
        self._space_mean = self.space if m.outliers_at_mean else None  # Eq. 4 by the mean with the ghost test
        self._solo_space = self.perf_space if m.solo_inside else None  # one view alone only inside S_perf
        self._regrouped, self._groups, self._fresh = np.zeros(0, np.int64), None, np.zeros(0, np.int64)  # (.regroup)
        # stream position
        self.first_frame: int | None = None
        self.last_frame: int | None = None
        self.frames = 0  # frames that carried boxes (the summary's count; the range may be far larger)
        self.final_frame: int | None = None  # every frame <= this is final
        self._next_start: int | None = None
        self._window_index = 0
        self._finished = False
        self.table = BoxTable(rig)  # the boxes of frames not yet final
        # the windows' 3D points and member boxes
        self.records = WindowRecords(superseded=m.exclusion, best_only=m.best_estimates)
        self._out: list[TrackerOutput] = []
        self._nothing = TrackerOutput.empty(self.names)  # what most calls return
        # counters
        self.timings = dict.fromkeys(STAGES, 0.0)
        self._nested = 0.0  # seconds of the timed stages so far (see _timed)
        self.read = np.zeros(self.n_cameras, np.int64)
        self.used = np.zeros(self.n_cameras, np.int64)
        self.false_positives = np.zeros(self.n_cameras, np.int64)

    # ================================================================ public API
    def update(self, frame: int, detections: Detections) -> TrackerOutput:
        """Feed the boxes of one frame (all views); returns what became final."""
        if self._finished:
            raise RuntimeError("this Tracker has finished; create a new one")
        frame = int(frame)
        if self.last_frame is not None and frame <= self.last_frame:
            raise InputError(f"frames must increase: got frame {frame} after {self.last_frame}", field="frame")
        if detections.camera_names != self.names and tuple(detections.camera_names) != self.names:
            raise InputError(f"detections are of cameras {list(detections.camera_names)}, the rig has {list(self.names)}",
                             field="camera_names")
        camera = detections.camera.astype(np.int64)
        # one compiled test per frame for both (a frame's few rows: numpy's per-call cost dominated)
        if len(camera) and frame_rows_check(np.asarray(detections.frame, np.int64), camera, frame, self.n_cameras):
            if (detections.frame != frame).any():
                bad = int(detections.frame[detections.frame != frame][0])
                raise InputError(f"update({frame}, ...) got a box of frame {bad}", field="frame")
            raise InputError(f"camera index outside 0..{self.n_cameras - 1}", field="camera")
        self.frames += len(camera) > 0
        box = self.venue.correct(frame, camera, detections.box) if self.venue.turns else detections.box
        self._ingest(frame, camera, box, detections.score, detections.track_id)
        return self._collect()

    def finish(self) -> TrackerOutput:
        """Flush: process the remaining windows and make every frame final."""
        if self._finished:
            return TrackerOutput.empty(self.names)
        self._finished = True
        if self.last_frame is not None:
            while self._next_start <= self.last_frame:
                self._process_window(self._next_start)
            self._finalise(self.last_frame)
            target, boxes = self._timed("target", self.target.finish)
            if len(target):
                self._out.append(TrackerOutput(Tracks3D.empty(), Detections.empty(self.names), target, boxes))
            self.venue.warn_sync()
        return self._collect()

    def state_size(self) -> int:
        """Number of stored rows/items over all internal state (for checking bounded memory)."""
        return (len(self.iou) + len(self.table) + len(self.records) + len(self.linker) + len(self.target)
                + len(self.refiner or ()))

    def summary(self) -> dict:
        """Counts and timings so far (:func:`.summary.tracker_summary`)."""
        return tracker_summary(self)

    # ================================================================ ingest (stage 1)
    def _ingest(self, frame: int, camera: np.ndarray, box: np.ndarray, score: np.ndarray, ident: np.ndarray) -> None:
        if self.first_frame is None:
            self.first_frame = self._next_start = frame
            self.final_frame = frame - 1
        # windows that end before this frame can get no more boxes
        while self._next_start + self.width - 1 < frame:
            skip = (frame - self.width - self._next_start) // self.step  # windows wholly before frame - 1
            if skip > 2 and self._idle():  # a long pause with nothing buffered: jump over empty windows
                self._next_start += (skip - 1) * self.step
                self.linker.break_chain()
                self._finalise(self._next_start - 1)
                continue
            self._process_window(self._next_start)
        t0 = time.perf_counter()
        self.last_frame = frame
        box = np.asarray(box, dtype=np.float64)
        if self.association == "iou":
            track2d = self.iou.update(frame, camera, box)
        else:
            self.read += np.bincount(camera, minlength=self.n_cameras)  # (iou: counted per window)
            keep = ident >= 0
            if not keep.all():
                self.false_positives += np.bincount(camera[~keep], minlength=self.n_cameras)
            camera, box, score, ident = camera[keep], box[keep], score[keep], ident[keep]
            track2d = ident * self.n_cameras + camera
            _, first = np.unique(track2d, return_index=True)
            if len(first) < len(track2d):  # one box per person and view
                self.counts["duplicates"] += len(track2d) - len(first)
                first = np.sort(first)
                camera, box, score, track2d = camera[first], box[first], score[first], track2d[first]
        self.table.add(frame, camera, track2d, box, score)
        self.timings["single_view"] += time.perf_counter() - t0
        if self._next_start + self.width - 1 == frame:
            self._process_window(self._next_start)

    def _idle(self) -> bool:
        """Nothing buffered that a window could still use (no boxes, tracklets or pending records)."""
        return self.table.idle(self._next_start) and self.linker.idle and not len(self.records)

    # ================================================================ one window (stages 2-6, Fig. 2)
    def _process_window(self, start: int) -> None:
        """The window of frames ``start .. start + window - 1``: cut, cluster, triangulate, plane
        fallback, link; then the frames before the next window's start are final."""
        segs = self._timed("windows", self._cut, start)
        labels, D2 = self._timed("clustering", self._cluster, segs)
        tri, to_plane = self._timed("triangulation", triangulation_stage, self, segs, labels, D2)  # (.cascade)
        plane, floor = self._timed("plane", plane_stage, self, segs, to_plane, D2)
        self._timed("linking", self._link, start, segs, tri, plane, floor)
        if self.refiner is not None and self.refiner.due():
            self._timed("plane", self._refine_plane, start)
        self._finalise(start + self.step - 1)

    def _refine_plane(self, start: int) -> None:
        """The plane refitted from the tracker's own points (:mod:`.plane_refine`)."""
        moved = self.refiner.refit(start + self.width - 1)
        if moved is not None:
            self.planes = [moved] + self.planes[1:]
            self.plane_arrays = PlaneArrays.from_planes(self.planes)
            self.stage_planes = PlaneArrays.from_planes(self.planes + self.surfaces)
            self.target.planes = self.planes  # (Eq. 14's boxes follow the plane's normal)
            if self.fusion is not None:
                self.fusion.set_planes(self.plane_arrays)

    def _timed(self, stage: str, fn: Callable, *args):
        """``fn(*args)``, its time counted to ``stage`` less that of the stages timed inside it (the venue check's)."""
        t0, nested = time.perf_counter(), self._nested
        out = fn(*args)
        took = time.perf_counter() - t0
        self.timings[stage] += took - (self._nested - nested)
        self._nested = nested + took
        return out

    def _cut(self, start: int) -> WindowTracklets:
        """Stage 2: the boxes received so far undistorted, the 2D tracks cut into the window."""
        p = self.params
        new = self.table.flush(start)
        if new is not None and self.association == "iou":
            self.read += np.bincount(new, minlength=self.n_cameras)
        t = self.table.rows
        segs, dropped = build_window(start, self.width, t["frame"], t["camera"], t["track2d"], t["ubox"], t["det"],
                                     p.min_tracklet_boxes, self.hold)
        self.counts["windows"] += 1
        self.counts["segments"] += len(segs)
        self.counts["segments_dropped_short"] += dropped
        return segs

    def _cluster(self, segs: WindowTracklets) -> tuple[np.ndarray | None, np.ndarray | None]:
        """Stage 3: (K,) cluster labels of the segments (None: every segment goes to the plane)
        and the Eq. 2 distances (K, K) (the method's own association only, else None)."""
        if self.method.plane == "all":
            return None, None
        if self.association == "oracle":
            return np.unique(segs.track2d // self.n_cameras, return_inverse=True)[1], None
        D2 = tracklet_distances(segs, self.F)
        return complete_linkage(D2, self.params.cluster_2d), D2

    def _link(self, start: int, segs: WindowTracklets, tri: WindowTracklets3D | None,
              plane: WindowTracklets3D | None, floor: WindowTracklets3D | None = None) -> None:
        """Stage 6: cross-window linking (one-view plane tracklets only continue tracks); the
        window's points and boxes are kept until final."""
        parts = [x for x in (tri, floor, plane) if x is not None]
        # (one part is used as it is: the stages never write into a window's tracklets)
        cur = (parts[0] if len(parts) == 1 else WindowTracklets3D.concat(parts)) if parts else \
            WindowTracklets3D.empty(start, self.width, self.n_cameras)
        solo, by_2d = continuation_only(len(cur), tri, floor, plane, self.counts)  # (floor rows: by their 2D tracks)
        own = None
        if plane is not None and len(self._regrouped):  # a regrouped pair only continues a track (.regroup)
            mine = member(plane.members, self._regrouped).any(axis=1)
            solo[len(cur) - len(plane):] |= mine
            if self.method.rejoin:  # its own track: a pair wherever the wrong cluster had put it, one view near it
                views = (plane.members >= 0).sum(axis=1)
                by_2d[len(cur) - len(plane):] |= mine & (views >= 2)
                own = np.zeros(len(cur), bool)
                own[len(cur) - len(plane):] = mine & (views == 1)
        cur = self.linker.step(cur, segs.track2d, solo, by_2d, own)
        self.records.add(cur, segs, self._window_index)
        self._window_index += 1
        self._next_start = start + self.step

    # ================================================================ finalisation (Eq. 12, stages 7-8)
    def _finalise(self, upto: int) -> None:
        if self._finished:  # the last windows reach past the input: no output frames beyond its last one
            upto = min(upto, self.last_frame)
        if upto <= self.final_frame:
            return
        t0 = time.perf_counter()
        tracks, gone = self.records.tracks_superseded(upto)
        boxes = all_boxes = self._final_boxes(upto)
        all_tracks = tracks  # the target stage (Eq. 13-14) keeps every point: see .exclusion
        if self.method.exclusion:  # beyond the paper: the reported tracks without duplicates (.exclusion)
            tracks, boxes = suppress_duplicates(tracks, boxes, self.counts, gone)
        self.used += np.bincount(boxes.camera, minlength=self.n_cameras)
        t1 = time.perf_counter()
        self.timings["finalise"] += t1 - t0
        target = self.target.update(self.final_frame + 1, upto, all_tracks, all_boxes, self.linker.ended)
        self.final_frame = upto
        self._out.append(TrackerOutput(tracks, boxes, *target))
        self.timings["target"] += time.perf_counter() - t1

    def _final_boxes(self, upto: int) -> Detections:
        """The tracks' raw boxes of the frames up to ``upto`` (:meth:`~.records.WindowRecords.boxes`)."""
        rows = self.records.boxes(upto, self.n_cameras, self.linker.next_track_id + 1)
        if rows is None:
            return Detections.empty(self.names)
        det, frame, cam, tid = rows
        raw, score = self.table.lookup(det)
        return Detections.from_arrays(frame, cam, raw, self.names, score=score, track_id=tid)

    def _collect(self) -> TrackerOutput:
        if not self._out:
            return self._nothing
        out = TrackerOutput.concat(self._out, self.names) if len(self._out) != 1 else self._out[0]
        self._out = []
        return out if not self.venue.turns else self.venue.uncorrect_output(out)
