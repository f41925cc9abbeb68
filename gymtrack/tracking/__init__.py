"""The gymnast tracker of paper Section III, one module per stage.

* :mod:`.single_view`     IoU tracker per camera, global assignment (III-A)
* :mod:`.windows`         overlapping windows, interpolation of segments (III-A)
* :mod:`.undistort`       fast undistortion of box corners (OpenCV on a grid, bilinear lookups)
* :mod:`.clustering`      Eq. 1-2 distances and Algorithm 1 (III-B)
* :mod:`.reconstruct`     triangulation (Eq. 3), opposite views, outliers (Eq. 4) (III-B/C)
* :mod:`.plane_fallback`  ray-plane candidates and their matching (Eq. 5-9) (III-C)
* :mod:`.cascade`         a window's cascaded association: triangulation, else the plane (III-C)
* :mod:`.linking`         cross-window linking (Eq. 10-12), the :class:`~.linking.WindowLinker` (III-B)
* :mod:`.records`         boxes and window points held until final, Eq. 12 at finalisation
* :mod:`.identify`        target identification (Eq. 13) and the back-fill (III-D)
* :mod:`.smoothing`       gap filling and smoothing of the target's trajectory (III-D)
* :mod:`.target`          the :class:`~.target.TargetStage` and the pose boxes (Eq. 14) (III-D)
* :mod:`.tracker`         the streaming :class:`Tracker` (Fig. 2), run by a recipe (:class:`gymtrack.modes.Method`)
* :mod:`.offline`         the offline runners
* :mod:`.types`           the columnar types of every level
* :mod:`._kernels`        the compiled loops of every stage, one module per stage (:func:`warm_up` compiles them)
"""

from ._kernels import warm_up
from .clustering import complete_linkage, tracklet_distances
from .offline import track_detections, track_routine
from ..modes import MODES, RECIPES, Method
from .tracker import ASSOCIATIONS, Tracker
from .types import (
    INTERPOLATED, PLANE, SOURCE_NAMES, TRIANGULATION, Target, TrackerOutput, Tracks3D, TrackResult, WindowTracklets,
    WindowTracklets3D,
)

__all__ = [
    "Tracker", "track_detections", "track_routine", "Method", "RECIPES", "MODES", "ASSOCIATIONS", "complete_linkage", "tracklet_distances",
    "warm_up",
    "Tracks3D", "Target", "TrackerOutput", "TrackResult", "WindowTracklets", "WindowTracklets3D",
    "TRIANGULATION", "PLANE", "INTERPOLATED", "SOURCE_NAMES",
]
