"""The offline runners: the streaming :class:`~.tracker.Tracker` over a whole routine (paper Section III).

:func:`track_detections` feeds every frame with boxes to :meth:`Tracker.update` (so input is
checked as in streaming use) and concatenates what became final; :func:`track_routine` loads a
routine folder first. With ``planes: auto`` in the scene, the plane is fitted from a first
triangulation pass before tracking (:func:`~.plane_fit.resolve_auto_planes`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

import numpy as np

from ..detections import Detections
from ..geometry.camera import Rig
from ..scene import Scene
from .plane_fit import resolve_auto_planes
from ..modes import DEFAULT_MODE, Method
from .tracker import Tracker
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
    knocked camera's rotation re-estimated and applied from then on.
    """
    tracker = Tracker(rig, resolve_auto_planes(rig, scene, detections, track_detections), mode=mode, association=association,
                      watch_cameras=watch_cameras, recalibrate=recalibrate)
    det = detections.sorted()
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
    return TrackResult(out.tracks, out.boxes, out.target, out.target_boxes, rig.names, tracker.mode, tracker.summary())


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
