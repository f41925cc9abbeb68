"""Columnar types of the tracker, one per level of the pipeline (paper Section III).

Every type is a frozen dataclass of parallel numpy arrays (one row per box, tracklet or
point); no Python object per box. The levels, in pipeline order:

* :class:`gymtrack.detections.Detections`  boxes of all views (III-A), the input;
* :class:`WindowTracklets`  the 2D tracklet segments of one window (III-A), dense (K, W);
* :class:`WindowTracklets3D`  the 3D tracklets of one window (III-B/C), dense (M, W);
* :class:`Tracks3D`  final 3D track points (after cross-window linking, III-B), one row per
  (frame, track);
* :class:`TargetRows`  track points on their way through the target stage (III-D): the
  candidates' and the target's points with their detections' sizes;
* :class:`Target`  the target gymnast's trajectory (III-D), one row per frame;
* :class:`TrackerOutput`  what one call of the streaming tracker made final;
* :class:`TrackResult`  a whole routine plus its summary.

Source codes (``Tracks3D.source``, ``Target.source``): :data:`TRIANGULATION` (Eq. 3),
:data:`PLANE` (ray-plane intersection, Eq. 7-9), :data:`INTERPOLATED` (no view actually
observed the person at that frame: filled inside a window, or a target gap filled).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any, Sequence

import numpy as np

from ..detections import Detections

TRIANGULATION, PLANE, INTERPOLATED = 0, 1, 2
#: names written to the output files, indexed by source code
SOURCE_NAMES: tuple[str, ...] = ("triangulation", "plane", "interpolated")


_FIELD_NAMES: dict[type, tuple[str, ...]] = {}


def member(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.isin(a, b)`` for the small id arrays of one window or frame (a of any shape, b (m,) ->
    a's shape, bool): one broadcast comparison, ~10 x cheaper than ``np.isin``'s general path at
    these sizes."""
    if a.size * b.size > 65536:
        return np.isin(a, b)
    return (a[..., None] == b).any(axis=-1) if b.size else np.zeros(a.shape, bool)


def _field_names(cls) -> tuple[str, ...]:
    """The dataclass's field names, looked up once per class (``fields()`` is slow per call)."""
    names = _FIELD_NAMES.get(cls)
    if names is None:
        names = _FIELD_NAMES[cls] = tuple(f.name for f in fields(cls))
    return names


def _concat_rows(cls, parts: Sequence[Any]):
    """Concatenate dataclasses of parallel arrays row-wise (all array fields)."""
    parts = [p for p in parts if p is not None]
    if not parts:
        return cls.empty()
    return cls(*[np.concatenate([getattr(p, n) for p in parts]) for n in _field_names(cls)])


def _select_rows(obj, index):
    cls = type(obj)
    return cls(*[getattr(obj, n)[index] for n in _field_names(cls)])


class _PointRows:
    """Row operations shared by the per-point types (:class:`Tracks3D`, :class:`Target`)."""

    @classmethod
    def concat(cls, parts: Sequence[Any]):
        return _concat_rows(cls, parts)

    def select(self, index):
        return _select_rows(self, index)

    def __len__(self) -> int:
        return len(self.frame)

    @property
    def source_name(self) -> np.ndarray:
        """(N,) source names."""
        return np.asarray(SOURCE_NAMES, dtype=object)[self.source]


@dataclass(frozen=True, eq=False)
class WindowTracklets:
    """The 2D tracklet segments of one window (paper III-A), as dense arrays.

    A window covers frames ``start .. start + W - 1``. Segment ``k`` is the part of one 2D
    track (camera ``camera[k]``, id ``track2d[k]``) inside the window.

    Attributes
    ----------
    start: first frame of the window.
    camera: (K,) int, camera index.
    track2d: (K,) int64, the 2D track id (unique over all cameras).
    box: (K, W, 4) float64, centre-form boxes in *undistorted* pixels; NaN where not valid.
    observed: (K, W) bool, a detection was there (else interpolated / extrapolated / none).
    valid: (K, W) bool, ``box`` holds a value (observed, interpolated or extrapolated).
    det: (K, W) int64, row id of the detection (tracker-wide counter); -1 where not observed.
    """

    start: int
    camera: np.ndarray
    track2d: np.ndarray
    box: np.ndarray
    observed: np.ndarray
    valid: np.ndarray
    det: np.ndarray

    def __len__(self) -> int:
        return len(self.camera)

    @property
    def width(self) -> int:
        """W, frames per window."""
        return self.box.shape[1]

    @property
    def frames(self) -> np.ndarray:
        """(W,) frame numbers of the window."""
        return self.start + np.arange(self.width)

    def points(self, which: str = "centre") -> np.ndarray:
        """(K, W, 2) box ``centre``, ``top`` (top-centre) or ``bottom`` (bottom-centre) points."""
        b = self.box
        if which == "centre":
            return b[..., :2]
        sign = -0.5 if which == "top" else 0.5
        return np.stack([b[..., 0], b[..., 1] + sign * b[..., 3]], axis=-1)

    def subset(self, index) -> "WindowTracklets":
        return WindowTracklets(
            self.start, self.camera[index], self.track2d[index], self.box[index], self.observed[index],
            self.valid[index], self.det[index],
        )


@dataclass(frozen=True, eq=False)
class WindowTracklets3D:
    """The 3D tracklets of one window (after triangulation or the plane fallback).

    Attributes
    ----------
    start: first frame of the window.
    xyz: (M, W, 3) centre positions, metres; NaN where not valid.
    top_z, bottom_z: (M, W) heights of the body's top and bottom, metres (NaN when unknown).
    valid: (M, W) bool.
    source: (M, W) int8 source code per point.
    n_views: (M, W) int8, views that observed the person at that frame.
    members: (M, C) int, index into the window's :class:`WindowTracklets` of the segment each
        camera contributed; -1 where the camera has none.
    track_id: (M,) int64, filled by cross-window linking (-1 before).
    """

    start: int
    xyz: np.ndarray
    top_z: np.ndarray
    bottom_z: np.ndarray
    valid: np.ndarray
    source: np.ndarray
    n_views: np.ndarray
    members: np.ndarray
    track_id: np.ndarray

    def __len__(self) -> int:
        return self.xyz.shape[0]

    @classmethod
    def empty(cls, start: int, width: int, n_cameras: int) -> "WindowTracklets3D":
        return cls(
            start, np.zeros((0, width, 3)), np.zeros((0, width)), np.zeros((0, width)), np.zeros((0, width), bool),
            np.zeros((0, width), np.int8), np.zeros((0, width), np.int8), np.zeros((0, n_cameras), np.int64),
            np.zeros(0, np.int64),
        )

    @classmethod
    def concat(cls, parts: Sequence["WindowTracklets3D"]) -> "WindowTracklets3D":
        cat = np.concatenate  # (the columns spelled out: a generator per call costs more than the work)
        return cls(
            parts[0].start, cat([p.xyz for p in parts]), cat([p.top_z for p in parts]), cat([p.bottom_z for p in parts]),
            cat([p.valid for p in parts]), cat([p.source for p in parts]), cat([p.n_views for p in parts]),
            cat([p.members for p in parts]), cat([p.track_id for p in parts]),
        )

    def with_track_id(self, track_id: np.ndarray) -> "WindowTracklets3D":
        """The same tracklets with ``track_id`` (M,) (cheaper than ``dataclasses.replace``)."""
        return WindowTracklets3D(self.start, self.xyz, self.top_z, self.bottom_z, self.valid, self.source, self.n_views,
                                 self.members, track_id)

    def with_members(self, members: np.ndarray) -> "WindowTracklets3D":
        """The same tracklets with ``members`` (M, C)."""
        return WindowTracklets3D(self.start, self.xyz, self.top_z, self.bottom_z, self.valid, self.source, self.n_views,
                                 members, self.track_id)

    def subset(self, index) -> "WindowTracklets3D":
        return WindowTracklets3D(
            self.start, self.xyz[index], self.top_z[index], self.bottom_z[index], self.valid[index], self.source[index],
            self.n_views[index], self.members[index], self.track_id[index],
        )


@dataclass(frozen=True, eq=False)
class Tracks3D(_PointRows):
    """Final 3D track points, one row per (frame, track), sorted by (frame, track_id).

    Attributes
    ----------
    frame: (N,) int64, the input's frame numbers.
    track_id: (N,) int64.
    xyz: (N, 3) centre, metres, world frame.
    top_z, bottom_z: (N,) heights of the body's top and bottom (NaN when unknown).
    source: (N,) int8 source code (:data:`SOURCE_NAMES`).
    n_views: (N,) int8, views whose detection contributed at that frame (0: interpolated).
    """

    frame: np.ndarray
    track_id: np.ndarray
    xyz: np.ndarray
    top_z: np.ndarray
    bottom_z: np.ndarray
    source: np.ndarray
    n_views: np.ndarray

    @classmethod
    def empty(cls) -> "Tracks3D":
        return cls(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0), np.zeros(0),
                   np.zeros(0, np.int8), np.zeros(0, np.int8))

    def __repr__(self) -> str:
        return f"Tracks3D({len(self)} points, {len(np.unique(self.track_id))} tracks)"


@dataclass(frozen=True, eq=False)
class TargetRows:
    """Track points inside the target stage (III-D): back-fill, gap filling, smoothing, Eq. 14.

    Attributes
    ----------
    frame: (n,) int64, in frame order.
    track_id: (n,) int64.
    xyz: (n, 3) float64 centre, metres (smoothed once the smoother emitted it).
    top_z, bottom_z: (n,) float64 heights of the body's top and bottom (NaN when unknown).
    source: (n,) int8 source code.
    wh: (n, C, 2) float64 width and height of the track's detection per view (raw pixels; NaN
        where none).
    """

    frame: np.ndarray
    track_id: np.ndarray
    xyz: np.ndarray
    top_z: np.ndarray
    bottom_z: np.ndarray
    source: np.ndarray
    wh: np.ndarray

    @classmethod
    def of(cls, frame, track_id, xyz, top_z, bottom_z, source, wh) -> "TargetRows":
        """Rows from array-likes, converted to the dtypes above (no copy where they already are)."""
        return cls(np.asarray(frame, np.int64), np.asarray(track_id, np.int64), np.asarray(xyz, np.float64),
                   np.asarray(top_z, np.float64), np.asarray(bottom_z, np.float64), np.asarray(source, np.int8),
                   np.asarray(wh, np.float64))

    @classmethod
    def from_tracks(cls, tracks: "Tracks3D", wh: np.ndarray) -> "TargetRows":
        """The points of ``tracks`` with their detections' sizes ``wh`` (n, C, 2)."""
        return cls.of(tracks.frame, tracks.track_id, tracks.xyz, tracks.top_z, tracks.bottom_z, tracks.source, wh)

    @classmethod
    def concat(cls, parts: Sequence["TargetRows"]) -> "TargetRows":
        """Row-wise concatenation of one or more parts (one part is returned as it is)."""
        if len(parts) == 1:
            return parts[0]
        cat = np.concatenate
        return cls(cat([p.frame for p in parts]), cat([p.track_id for p in parts]), cat([p.xyz for p in parts]),
                   cat([p.top_z for p in parts]), cat([p.bottom_z for p in parts]), cat([p.source for p in parts]),
                   cat([p.wh for p in parts]))

    def with_xyz(self, xyz: np.ndarray) -> "TargetRows":
        """The same rows with centres ``xyz`` (n, 3) (cheaper than ``dataclasses.replace``)."""
        return TargetRows(self.frame, self.track_id, xyz, self.top_z, self.bottom_z, self.source, self.wh)

    def take(self, index) -> "TargetRows":
        """Rows by index, mask or slice."""
        return TargetRows(self.frame[index], self.track_id[index], self.xyz[index], self.top_z[index],
                          self.bottom_z[index], self.source[index], self.wh[index])

    def __len__(self) -> int:
        return len(self.frame)


@dataclass(frozen=True, eq=False)
class Target(_PointRows):
    """The target gymnast's 3D trajectory (gaps filled, smoothed), one row per frame.

    Attributes
    ----------
    frame: (N,) int64, increasing.
    track_id: (N,) int64, the 3D track the target was following at that frame.
    xyz: (N, 3) smoothed centre, metres.
    source: (N,) int8 source code; :data:`INTERPOLATED` for filled gaps.
    """

    frame: np.ndarray
    track_id: np.ndarray
    xyz: np.ndarray
    source: np.ndarray

    @classmethod
    def empty(cls) -> "Target":
        return cls(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0, np.int8))


@dataclass(frozen=True, eq=False)
class TrackerOutput:
    """What became final in one call of the streaming tracker (or all of a routine).

    Attributes
    ----------
    tracks: final 3D track points.
    boxes: the 2D boxes of those tracks in every view: raw-image detections whose
        ``track_id`` is the 3D track id (one box per track, view and frame at most).
    target: the target gymnast's trajectory.
    target_boxes: the expanded square boxes ``b_buf`` (Eq. 14) of the target in every view,
        raw-image pixels, ``track_id`` = the target's track id.
    """

    tracks: Tracks3D
    boxes: Detections
    target: Target
    target_boxes: Detections

    @classmethod
    def empty(cls, camera_names: Sequence[str]) -> "TrackerOutput":
        return cls(Tracks3D.empty(), Detections.empty(camera_names), Target.empty(), Detections.empty(camera_names))

    @classmethod
    def concat(cls, parts: Sequence["TrackerOutput"], camera_names: Sequence[str]) -> "TrackerOutput":
        parts = list(parts)
        if not parts:
            return cls.empty(camera_names)
        return cls(
            Tracks3D.concat([p.tracks for p in parts]),
            Detections.concat([p.boxes for p in parts]),
            Target.concat([p.target for p in parts]),
            Detections.concat([p.target_boxes for p in parts]),
        )

    def __bool__(self) -> bool:  # (array sizes, not len(): asked once per streamed frame)
        return bool(self.tracks.frame.size or self.boxes.frame.size or self.target.frame.size
                    or self.target_boxes.frame.size)


@dataclass(frozen=True, eq=False)
class TrackResult:
    """The tracker's results on a whole routine.

    Attributes
    ----------
    tracks, boxes, target, target_boxes: as in :class:`TrackerOutput`.
    camera_names: the rig's cameras, in index order.
    mode: ``cascade`` | ``triangulation`` | ``plane``.
    summary: counts and timings (see :meth:`gymtrack.tracking.tracker.Tracker.summary`).
    """

    tracks: Tracks3D
    boxes: Detections
    target: Target
    target_boxes: Detections
    camera_names: tuple[str, ...]
    mode: str
    summary: dict = field(default_factory=dict)
