"""Beyond the paper (``cascade+``): two tracks cannot be one body -- duplicates suppressed.

A person is sometimes carried by two 3D tracks at once: a cross-window link (Eq. 10-11) failed and
the old track's last window overlaps the new one's first, or a wrong cross-view pair (Eq. 1-2)
triangulates next to a person someone else already tracks. Two bodies cannot be closer than
about a shoulder width, so when Eq. 12 makes a frame final, a track point closer than
``min_separation`` metres (3D distance: a gymnast in the air above a coach stays apart) to a
point of an *older* track (a smaller track id: ids are given in order of the windows that
start the tracks, and a re-linked track keeps its old id) is dropped, with that track's boxes
of the frame. The older track keeps the person: it has the longer history (Eq. 13's target
decisions and the identities already reported rest on it).

Points :class:`~.records.WindowRecords` flags as superseded (every window estimate of them
lost its detections to other tracks) are left out the same way (counted as
``points_superseded`` in the tracker's summary).

Only the reported tracks (and their boxes) are thinned: the target stage (Eq. 13-14) gets every
point, because it picks one track and a duplicate cannot mislead it, while a suppressed point may
be the gymnast's own (a spotter within reach); so the target outputs are those without this step.

What it trades: two real people closer than ``min_separation`` (a tight crowd, a spotter
catching a gymnast) lose the younger one's point for those frames; a larger value removes more
duplicates and more such neighbours (WILDTRACK, a trial on finished outputs keeping the longer
track: 0.3 m left 454 duplicates, 0.5 m 277, 0.7 m 133 but 450 more misses; this streaming
version at 0.5 m: 289 duplicates). Counted as ``points_suppressed``.
"""

from __future__ import annotations

import numpy as np

from ..detections import Detections
from ..errors import InputError
from ._kernels import exclusion as kernels
from .types import Tracks3D

#: metres between two body centres below which they are one person (about a shoulder width)
MIN_SEPARATION = 0.5


def too_close(frame: np.ndarray, track_id: np.ndarray, xyz: np.ndarray, min_separation: float = MIN_SEPARATION,
              skip: np.ndarray | None = None) -> np.ndarray:
    """(N,) bool: the points (frame (N,), track_id (N,), xyz (N, 3)) closer than ``min_separation``
    to a point of an older track (smaller id) in the same frame. NaN points are never close.
    ``skip`` (N,) bool: points left out (never close, never compared with). One compiled pass
    per frame (:func:`._kernels.exclusion.too_close`)."""
    if not min_separation > 0:
        raise InputError(f"min_separation must be a positive number of metres, got {min_separation!r}",
                         field="min_separation")
    n = len(frame)
    if n < 2:
        return np.zeros(n, bool)
    skip = np.zeros(n, bool) if skip is None else np.ascontiguousarray(skip, bool)
    return kernels.too_close(np.ascontiguousarray(frame, np.int64), np.ascontiguousarray(track_id, np.int64),
                             np.ascontiguousarray(xyz, np.float64), skip, float(min_separation) * float(min_separation))


def suppress_duplicates(tracks: Tracks3D, boxes: Detections, counts: dict, gone: np.ndarray | None = None,
                        min_separation: float = MIN_SEPARATION) -> tuple[Tracks3D, Detections]:
    """The final points (and their boxes) without ``gone`` (N,) bool (points already known to be
    duplicates: :meth:`.records.WindowRecords.tracks_superseded`) and without those of the rest
    :func:`too_close` says duplicate an older track; the latter counted in
    ``counts["points_suppressed"]``."""
    if not min_separation > 0:
        raise InputError(f"min_separation must be a positive number of metres, got {min_separation!r}",
                         field="min_separation")
    # one compiled call: :func:`too_close` of the points not ``gone``, and the points dropped
    drop, n_close, n_drop = kernels.drop_close(
        np.ascontiguousarray(tracks.frame, np.int64), np.ascontiguousarray(tracks.track_id, np.int64),
        np.ascontiguousarray(tracks.xyz, np.float64), np.zeros(len(tracks), bool) if gone is None else gone,
        float(min_separation) * float(min_separation))
    counts["points_suppressed"] += int(n_close)
    if not n_drop:
        return tracks, boxes
    if len(boxes):
        span = int(max(tracks.track_id.max(), boxes.track_id.max())) + 1
        key = np.sort(tracks.frame[drop] * span + tracks.track_id[drop])  # (np.isin, by one binary search)
        box_key = boxes.frame * span + boxes.track_id
        gone = key[np.minimum(np.searchsorted(key, box_key), len(key) - 1)] == box_key
        if gone.any():
            boxes = boxes.select(~gone)
    return tracks.select(~drop), boxes
