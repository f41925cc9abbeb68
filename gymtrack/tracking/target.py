"""The target gymnast stage (paper Section III-D, Eq. 13-14): from final track points to the
target's trajectory and its expanded boxes for pose estimation.

:class:`TargetStage` wires, on a stream of final frames (the :class:`~.tracker.Tracker`) or
frame by frame (the MvPT baseline, :mod:`gymtrack.eval.mvpt`):

1. Eq. 13 identification, :class:`~.identify.TargetSelector` (the indicator:
   :func:`~.identify.identify_indicator`);
2. beyond the paper, the back-fill of the frames an identification looked back on,
   :class:`~.identify.TargetBackfill`;
3. gap filling and smoothing, :class:`~.smoothing.TargetSmoother`;
4. Eq. 14 boxes, :func:`buffered_boxes` (this module), with the body box's half-length carried
   between calls.

:func:`buffered_boxes` -- Eq. 14. The smoothed 3D centre is projected into every view
(raw pixels, with distortion) and gets the square box of side ``box_scale * l``: ``l`` is
``max(w, h)`` of the target's detection in that view at that frame. Where the view has no
detection of the target (a missed box, or a view that never detects it: n_cam < 4), ``l`` is
``max(w, h)`` of the projected *body box* (see :func:`buffered_boxes`): the body's vertical
extent (its estimated top and bottom heights) times its horizontal extent, a rectangle aligned
with the vertical plane -- half-length along the plane measured from the views that do see the
target (their box widths at their depths), half-depth across it a prior
(:data:`BODY_HALF_DEPTH`). The paper keeps the last box size, which misses a body that turns
from upright to horizontal. A box is given when the centre is in front of the camera and
inside the image.
"""

from __future__ import annotations

from collections import defaultdict
from typing import Sequence

import numpy as np

from ..placement import scene_geometry
from ..scene import Scene
from ..geometry.camera import Rig
from ..geometry.plane import Plane
from ._kernels.target import BodyBox
from ._kernels.target import buffered_boxes as buffered_boxes_kernel
from ..detections import Detections
from .chain import GAP_SECONDS
from .handover import TargetHandover
from .identify import TargetBackfill, TargetSelector, identify_indicator, point_support
from .reach import ReachLimit
from .smoothing import TargetSmoother
from .types import Target, TargetRows, Tracks3D


class TargetStage:
    """Eq. 13 identification, back-fill, gap filling, smoothing and Eq. 14 boxes on a stream of
    final frames (see the module docstring).

    rig: the cameras; scene: performance space, target heights, planes and parameters
    (``identify_frames``, ``backfill_frames``, ``max_gap``, ``box_scale``); reidentify: the
    recipe's ``reidentify`` (see :class:`~.identify.TargetSelector`); counts: the tracker's counters;
    reach: the recipe's ``reach`` (:mod:`.reach`); chain: the recipe's ``chain`` (:mod:`.chain`).

    Use: ``target, boxes = stage.update(a, b, tracks, boxes, ended)`` for every run of final
    frames ``a..b`` in order, then ``stage.finish()``. State: the selector's last
    ``identify_frames`` frames, the ``backfill_frames`` held back, the smoother's open segment
    and the body box's half-length.
    """

    def __init__(self, rig: Rig, scene: Scene, handover: TargetHandover | None = None, reidentify: bool = False,
                 counts: dict | None = None, reach: bool = False, chain: bool = False):
        p = scene.params
        self.handover = handover  # the recipe's handover (.handover): None is the paper's Eq. 13 alone
        self.flights = None if handover is None else handover.flights  # the recipe's ballistic (.ballistic)
        self.rig = rig
        self.n_cameras = len(rig)
        self.perf = np.asarray(scene.performance_space, dtype=np.float64)
        self.h_top, self.h_bot = scene.target.h_top, scene.target.h_bot
        self.planes = [Plane.from_spec(s) for s in scene.planes]
        self.identify_frames, self.backfill_frames, self.box_scale = p.identify_frames, p.backfill_frames, p.box_scale
        self.half_depth = p.body_half_depth  # Eq. 14's body box across the plane
        # the recipe's reidentify (False: the paper's hold until the target ends or leaves)
        self.counts = defaultdict(int) if counts is None else counts
        self.selector = TargetSelector(p.identify_frames, reidentify=reidentify, counts=self.counts)
        # the recipe's reach (.reach): None is Eq. 13's indicator alone
        self.reach = ReachLimit(scene_geometry(scene), self.h_bot, scene.fps) if reach else None
        # the recipe's chain (.chain): the look-back follows the track the identified one continues
        self.backfill = TargetBackfill(p.backfill_frames, (int(round(GAP_SECONDS * scene.fps)), self.counts) if chain else None,
                                       self.counts if reidentify else None)
        self.smoother = TargetSmoother(p.max_gap)
        self.memory: dict = {}  # Eq. 14: the body box's last half-length
        self.frames = 0  # target frames emitted
        self._last_point: int | None = None  # the last frame with a track point (pauses are jumped)
        self._none = (Target.empty(), Detections.empty(rig.names))  # what most calls return (immutable, empty)

    def __len__(self) -> int:
        return (len(self.selector) + len(self.smoother) + len(self.backfill) + len(self.handover or ())
                + len(self.flights or ()) + len(self.reach or ()))

    @property
    def switches(self) -> int:
        return self.selector.switches

    @property
    def identifications(self) -> int:
        return self.selector.identifications

    def live_track(self) -> int:
        """The 3D track the target follows now (its handed-over track); -1: no target."""
        t = self.selector.target
        return t if t < 0 or self.handover is None else self.handover.live.get(t, t)

    def update(self, a: int, b: int, tracks: Tracks3D, boxes: Detections,
               ended: dict[int, int]) -> tuple[Target, Detections]:
        """Final frames ``a..b``: their track points and boxes (``track_id`` = 3D track), and the
        tracks that ended (id -> last frame; entries that can no longer matter are removed).
        Returns the target's smoothed points and Eq. 14 boxes that became final.

        A pause of more than :attr:`settle` frames without track points (in the run, or since the
        last point) is decided over its first ``settle`` frames only -- by then every state has
        forgotten the last point -- and the rest is jumped over: time and memory do not grow with
        the pause."""
        cut = self._pause(a, b, tracks.frame)
        if cut is not None:
            p, q = cut  # the last point before the pause (None: none held), the first after it (None: none)
            out = []
            if p is not None and p + self.settle >= a:
                before, bb = tracks.frame <= p, boxes.frame <= p
                out.append(self.update(a, p + self.settle, tracks.select(before), boxes.select(bb), ended))
            self._jump()
            if q is not None:
                after, ba = tracks.frame >= q, boxes.frame >= q
                out.append(self.update(q, b, tracks.select(after), boxes.select(ba), ended))
            return (Target.concat([t for t, _ in out]), Detections.concat([d for _, d in out])) if out else self._none
        if len(tracks):
            self._last_point = max(self._last_point if self._last_point is not None else a, int(tracks.frame.max()))
        rows = TargetRows.from_tracks(tracks, track_box_sizes(tracks, boxes, self.n_cameras))
        if self.flights is not None:  # the target's track in flight: the parabola's points (.ballistic)
            rows = self.flights.extend(a, b, self.handover.flying(self.selector), rows)
        ind, inperf = identify_indicator(rows.xyz, rows.top_z, rows.bottom_z, self.perf, self.h_top, self.h_bot)
        if self.reach is not None:  # raised away from the apparatus longer than a flight: nowhere a body can be
            held_up = self.reach.grounded(rows.frame, rows.track_id, rows.xyz, rows.bottom_z)
            self.counts["target_points_out_of_reach"] += int((inperf & ~held_up).sum())
            ind &= held_up
            inperf &= held_up
        sup = point_support(rows.wh) if self.selector.reidentify else None
        if self.handover is None:
            target = self.selector.select(a, b, rows.frame, rows.track_id, ind, inperf, ended, sup)  # (b-a+1,)
        else:  # the new track that takes up the target's as the old one for Eq. 13; the rows keep their ids
            sel, ended_sel = self.handover.step(rows.frame, rows.track_id, rows.xyz, ended, self.selector)
            target = self.selector.select(a, b, rows.frame, sel, ind, inperf, ended_sel, sup)
            target = self.handover.actual(a, target, rows.frame, rows.track_id, sel)
        if self.flights is not None:  # frames still held without a point in flight (.ballistic)
            rows = self.flights.fill(a, target, rows)
        self.backfill.push(a, target, rows, self.selector.pop_takeovers())
        upto = b - self.backfill_frames
        emitted = [self.smoother.push(rows)] if (rows := self.backfill.pop(upto)) is not None else []
        emitted.append(self.smoother.advance(upto))
        # forget ended tracks that can no longer matter
        horizon = b - self.identify_frames
        for tid in [k for k, v in ended.items() if v < horizon and k != self.selector.target]:
            del ended[tid]
        return self._boxes(emitted)

    def _pause(self, a: int, b: int, frame: np.ndarray) -> tuple[int | None, int | None] | None:
        """The first pause longer than :attr:`settle` in frames ``a..b`` (points at ``frame``):
        (last point before it or None, first point after it or None), or None without one."""
        held = self._last_point is not None
        prev = self._last_point if held else a - 1  # (nothing held: a pause only if the first point is far)
        # no gap between consecutive frames of prev, the points and b + 1 exceeds their span: a
        # span within settle + 1 (every call of an uninterrupted stream) needs no search
        lo, hi = (min(prev, int(frame.min())), max(b + 1, int(frame.max()))) if len(frame) else (prev, b + 1)
        if hi - lo - 1 <= self.settle:
            return None
        u = np.unique(frame)
        s = np.r_[prev, u, b + 1]
        gap = np.flatnonzero(np.diff(s) - 1 > self.settle)
        if not len(gap):
            return None
        k = int(gap[0])
        p, q = int(s[k]), int(s[k + 1])
        return (p if k > 0 or held else None), (q if q <= b else None)

    @property
    def settle(self) -> int:
        """Frames without points after which no state holds a point: Eq. 13's Delta, the
        back-fill's hold and a gap the smoother could still fill."""
        return self.identify_frames + self.backfill_frames + self.smoother.max_gap + 2

    def _jump(self) -> None:
        """After ``settle`` frames without points: the frames that follow need no decision (no target)."""
        if self.backfill.pop() is not None or len(self.smoother) or self.selector.target >= 0:
            raise RuntimeError("the target stage still held points after a pause")  # pragma: no cover - a bug
        self.selector.forget()
        self.backfill.restart()
        self._last_point = None

    def finish(self) -> tuple[Target, Detections]:
        """End of stream: release the held-back decisions and close the last target segment."""
        rows = self.backfill.pop()
        emitted = [self.smoother.push(rows)] if rows is not None else []
        emitted.append(self.smoother.close())
        return self._boxes(emitted)

    def _boxes(self, emitted: list[TargetRows | None]) -> tuple[Target, Detections]:
        """Smoothed rows -> the target and its Eq. 14 boxes."""
        emitted = [e for e in emitted if e is not None]
        if not emitted:
            return self._none
        rows = TargetRows.concat(emitted)
        self.frames += len(rows)
        return target_and_boxes(self.rig, rows, self.box_scale, self.memory, self.planes, self.half_depth)


def track_box_sizes(tracks, boxes: Detections, n_cameras: int) -> np.ndarray:
    """Width and height of every track point's detection per view: (n, C, 2), NaN where none.

    tracks: rows with ``frame`` and ``track_id`` (n,), sorted by (frame, track_id), one per pair;
    boxes: the tracks' boxes (``track_id`` = the 3D track), at most one per (frame, view, track).
    Boxes of a (frame, track) without a point are not used.
    """
    wh = np.full((len(tracks.frame), n_cameras, 2), np.nan)
    if len(tracks.frame) == 0 or len(boxes) == 0:
        return wh
    span = int(max(tracks.track_id.max(), boxes.track_id.max())) + 1
    key = tracks.frame * span + tracks.track_id  # increasing: tracks are sorted
    bkey = boxes.frame.astype(np.int64) * span + boxes.track_id
    row = np.minimum(np.searchsorted(key, bkey), len(key) - 1)
    hit = key[row] == bkey
    wh[row[hit], boxes.camera[hit].astype(np.int64)] = boxes.box[hit, 2:]
    return wh


def target_and_boxes(rig: Rig, rows: TargetRows, box_scale: float, memory: dict,
                     planes: Sequence[Plane] = (), half_depth: float | None = None) -> tuple[Target, Detections]:
    """Smoothed target rows -> the :class:`Target` and its Eq. 14 boxes in every view
    (:func:`buffered_boxes`; ``memory`` carries the body box's half-length between calls;
    ``planes``: the scene's vertical planes, the body box follows the nearest; ``half_depth``:
    its half-depth across them, default :data:`BODY_HALF_DEPTH`)."""
    frame, tid, xyz, top, bot, src, wh = (rows.frame, rows.track_id, rows.xyz, rows.top_z, rows.bottom_z, rows.source,
                                          rows.wh)
    box, ok = buffered_boxes(rig, xyz, top, bot, wh, box_scale, memory, nearest_normals(planes, xyz), half_depth)
    n, c = np.nonzero(ok)
    return Target(frame, tid, xyz, src), Detections.from_arrays(frame[n], c, box[n, c], rig.names, track_id=tid[n])


def nearest_normals(planes: Sequence[Plane], xyz: np.ndarray) -> np.ndarray | None:
    """(N, 3) the normal of the plane nearest to each point (xyz (N, 3)); None without planes."""
    if not planes:
        return None
    normals = np.stack([pl.normal for pl in planes])
    if len(planes) == 1:
        return np.broadcast_to(normals[0], (len(xyz), 3))
    dist = np.abs(np.stack([pl.signed_distance(xyz) for pl in planes], axis=1))  # (N, P)
    return normals[np.argmin(dist, axis=1)]


#: metres: half the body's extent across the vertical plane. Views facing the plane cannot
#: measure it; a gymnast's trunk is ~0.25 m deep and limbs leave the plane in twists and circles.
BODY_HALF_DEPTH = 0.25
#: metres: the smallest half-length along the plane (a tucked body seen side-on).
MIN_HALF_LENGTH = 0.1
#: metres: half an upright body's height, where the top/bottom heights are unknown.
DEFAULT_HALF_HEIGHT = 0.9
#: views that see the plane this obliquely (|cos| between their x-axis and the plane's direction)
#: tell little about the body's length along it and are not used to measure it.
MIN_LENGTH_COS = 0.3


def buffered_boxes(
    rig: Rig,
    xyz: np.ndarray,
    top_z: np.ndarray,
    bottom_z: np.ndarray,
    wh: np.ndarray,
    box_scale: float,
    memory: dict,
    normal: np.ndarray | None = None,
    half_depth: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 14 boxes of the target in every view, for rows in frame order (see the module docstring).

    xyz: (N, 3) smoothed centres; top_z, bottom_z: (N,) heights of the body's top and bottom
    (NaN: unknown, then ``z +- DEFAULT_HALF_HEIGHT``); wh: (N, C, 2) width and height of the
    target's detection per view (NaN: none); box_scale: alpha; memory: dict carried between calls
    (``"half_length"``: the body box's last measured half-length); normal: (N, 3) or (3,) normal of
    the vertical plane the body box is aligned with, or None (no plane: a box as deep as long,
    aligned with the world axes); half_depth: the body box's half-depth across the plane (default
    :data:`BODY_HALF_DEPTH`; the scene's ``params.body_half_depth``).

    The body box: its half-length ``a`` along the plane is measured in every view with a
    detection -- a box of width ``w`` at depth ``z`` spans ``w z / f`` metres across the view's
    x-axis ``r``, which the body box fills as ``2 (a |r . along| + b |r . across|)``; views that
    see the plane more obliquely than :data:`MIN_LENGTH_COS` are not used; the largest wins (a
    cut or occluded box only shrinks) and rows without a measurement keep the last one. In a view
    without a detection ``l`` is ``max(w, h)`` of the rectangle bounding its 8 projected corners.
    One compiled loop (:func:`._kernels.target.buffered_boxes`) per call.

    Returns (box (N, C, 4) centre-form raw-pixel squares, ok (N, C) bool).
    """
    N, C = wh.shape[:2]
    if N == 0:
        return np.full((N, C, 4), np.nan), np.zeros((N, C), bool)
    if normal is None:
        across = np.broadcast_to(np.array([0.0, 1.0, 0.0]), (N, 3))
    else:
        across = np.array(np.broadcast_to(normal, (N, 3)), dtype=np.float64)
        across[:, 2] = 0
        flat = np.linalg.norm(across, axis=1)
        across = np.where(flat[:, None] > 1e-9, across / np.maximum(flat, 1e-12)[:, None], [0.0, 1.0, 0.0])
    box, ok, last = buffered_boxes_kernel(
        np.ascontiguousarray(xyz, dtype=np.float64), np.ascontiguousarray(top_z, dtype=np.float64),
        np.ascontiguousarray(bottom_z, dtype=np.float64), np.ascontiguousarray(wh, dtype=np.float64),
        np.ascontiguousarray(across), float(memory.get("half_length", BODY_HALF_DEPTH)), rig.arrays,
        BodyBox(float(box_scale), BODY_HALF_DEPTH if half_depth is None else float(half_depth), normal is None, MIN_LENGTH_COS, MIN_HALF_LENGTH,
                DEFAULT_HALF_HEIGHT))
    memory["half_length"] = float(last)
    return box, ok
