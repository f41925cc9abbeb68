"""The offline runners: the streaming :class:`~.tracker.Tracker` over a whole routine (paper Section III).

:func:`track_detections` feeds every frame with boxes to :meth:`Tracker.update` (so input is
checked as in streaming use) and concatenates what became final; :func:`track_routine` loads a
routine folder first. With ``planes: auto`` in the scene, the plane is fitted from a first
triangulation pass before tracking (:func:`~.plane_fit.resolve_auto_planes`).

Beyond the paper: a knocked camera (:mod:`.drift`) is found seconds after it moved, and a stream
can only correct its boxes from then on. Offline, the whole routine is at hand: once a turn is
re-estimated, the routine is tracked again with each knocked camera's first turn, refitted to all
its points from the move to the end (:mod:`.turn_fit`), applied from the frame its move started
(its later turns found as the stream finds them), so the frames between the knock and its
detection are tracked with the corrected camera too. A clean routine is tracked once.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Callable

import numpy as np

from ..detections import Detections
from ..errors import GymtrackWarning
from ..geometry.camera import Rig
from ..scene import Scene
from .plane_fit import resolve_auto_planes
from ..modes import DEFAULT_MODE, Method
from .tracker import Tracker
from .turn_fit import degrees
from .types import TrackerOutput, TrackResult


def track_detections(
    rig: Rig,
    scene: Scene,
    detections: Detections,
    mode: Method | str = DEFAULT_MODE,
    association: str = "iou",
    progress: Callable[[int, int], None] | None = None,
    watch_cameras: bool = True,
    recalibrate: bool = True,
) -> TrackResult:
    """Run the streaming :class:`Tracker` over all frames of ``detections`` (offline use): one
    :meth:`Tracker.update` per frame with boxes, so input is checked as in streaming use.

    mode: a recipe (:class:`gymtrack.modes.Method`) or the name of one (:data:`gymtrack.modes.RECIPES`).

    progress: optional ``progress(frames_done, frames_total)`` callback (frames with boxes), called
    every ~100 frames.

    watch_cameras: watch the cameras for a knock or a desync (:mod:`.drift`); recalibrate: then a
    knocked camera's rotation re-estimated and the routine tracked again with it applied from
    the frame its move started (module docstring).
    """
    scene = resolve_auto_planes(rig, scene, detections, track_detections)
    det = detections.sorted()
    if not (watch_cameras and recalibrate):
        return _track(rig, scene, det, mode, association, progress, watch_cameras, recalibrate)[0]
    said, (result, venue) = _recorded(_track, rig, scene, det, mode, association, progress, True, True)
    first: dict[int, tuple[int, object]] = {}
    for c, start, R in venue.refined_knocks():  # each knocked camera's first turn (refitted), from the frame its move started
        first.setdefault(c, (start, R))
    if first:
        known, named = [], set()
        for e in venue.events:  # the events that found those turns, now applied from the start
            c = rig.names.index(e["camera"])
            if "recalibrated_from_frame" in e and c not in named:
                named.add(c)
                known.append({**e, "recalibrated_from_frame": first[c][0], "rotation_degrees": round(degrees(first[c][1]), 2)})
        again, (result, _) = _recorded(_track, rig, scene, det, mode, association, None, True, True, first, known)
        told = {(str(w.message), w.category) for w in said}
        said += [w for w in again if (str(w.message), w.category) not in told]
    for w in said:
        warnings.warn(w.message, w.category, stacklevel=2)
    for c, (start, _) in first.items():
        warnings.warn(f"camera {rig.names[c]}: the frames from {start} on tracked again with its re-estimated "
                      f"rotation", GymtrackWarning, stacklevel=2)
    return result


def _recorded(fn, *args):
    """(the warnings ``fn(*args)`` raised, recorded to be passed on once, its result)."""
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        out = fn(*args)
    return said, out


def _track(rig, scene, det, mode, association, progress, watch_cameras, recalibrate, turns=None, events=()):
    """One pass of the :class:`Tracker` over the sorted boxes ``det``: (TrackResult, its drift monitor).
    turns: {camera: (from frame, rotation)} applied from the start, with the ``events`` that found them."""
    tracker = Tracker(rig, scene, mode=mode, association=association, watch_cameras=watch_cameras, recalibrate=recalibrate)
    if turns:
        tracker.venue.turns, tracker.venue.events = dict(turns), list(events)
    outs = []
    if len(det):
        frames, first = np.unique(det.frame, return_index=True)
        bounds = np.r_[first, len(det)].tolist()
        total = len(frames)  # frames with boxes: a gap costs neither time nor progress
        for i, f in enumerate(frames.tolist()):
            out = tracker.update(f, det.select(slice(bounds[i], bounds[i + 1])))
            if out:  # (nothing became final at most frames)
                outs.append(out)
            if progress is not None and i % 100 == 0:
                progress(i + 1, total)
        if progress is not None:
            progress(total, total)
    outs.append(tracker.finish())
    out = TrackerOutput.concat(outs, rig.names)
    return (TrackResult(out.tracks, out.boxes, out.target, out.target_boxes, rig.names, tracker.mode, tracker.summary()),
            tracker.venue)


def track_routine(
    routine,
    mode: Method | str = DEFAULT_MODE,
    association: str = "iou",
    progress: Callable[[int, int], None] | None = None,
) -> TrackResult:
    """Track a routine folder (path) or a loaded :class:`gymtrack.formats.routine.Routine`."""
    if isinstance(routine, (str, Path)):
        from ..formats.routine import load_routine

        routine = load_routine(routine)
    return track_detections(routine.rig, routine.scene, routine.detections, mode=mode, association=association,
                            progress=progress)
