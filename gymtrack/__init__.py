"""gymtrack: multi-camera gymnast tracking with domain knowledge.

Implements Yang et al., "Enhancing Multi-Camera Gymnast Tracking Through Domain Knowledge
Integration": per-view IoU tracking, windowed cross-view clustering, triangulation with a
ray-plane fallback (the cascaded data association), cross-window linking and target selection.

Layout (reads like the pipeline):

* ``gymtrack.geometry``   cameras, epipolar distance, triangulation, ray-plane intersection
* ``gymtrack.formats``    calibration, detection, scene and routine files
* ``gymtrack.tracking``   one module per stage of the tracker
* ``gymtrack.simulate``   routines with ground truth
* ``gymtrack.eval``       metrics, baselines, benchmark
* ``gymtrack.cli``        the ``gymtrack`` command

Use from Python: ``gymtrack.Tracker(rig, scene)`` fed frame by frame (``update``/``finish``),
or ``gymtrack.track_routine(folder)`` / ``gymtrack.track_detections(rig, scene, detections)``.
The tracker's names are imported on first use, so ``import gymtrack`` stays light.
"""

from .version import SOURCE_VERSION as __version__  # noqa: E402  (the one literal: gymtrack/version.py)

import sys as _sys  # noqa: E402

if _sys.orig_argv[1:3] == ["-m", "gymtrack.cli"] or _sys.argv[0].endswith(("/gymtrack", "\\gymtrack.exe")):
    from . import interrupts as _interrupts  # the command line: Ctrl-C handled from the first line on

    _interrupts.install()

from .errors import GymtrackError, InputError  # noqa: E402

#: public names loaded on first access: name -> module (also Detections: numpy is not imported
#: before the command line has put its Ctrl-C handler in place)
_LAZY = {
    "Detections": "gymtrack.detections",
    "Tracker": "gymtrack.tracking.tracker",
    "TrackerOutput": "gymtrack.tracking.types",
    "track_detections": "gymtrack.tracking.offline",
    "track_routine": "gymtrack.tracking.offline",
    "Scene": "gymtrack.scene",
    "Rig": "gymtrack.geometry.camera",
    "analyse": "gymtrack.analysis.api",
    "Analysis": "gymtrack.analysis.api",
}

__all__ = ["Analysis", "Detections", "GymtrackError", "InputError", "Rig", "Scene", "Tracker", "TrackerOutput",
           "analyse", "track_detections", "track_routine", "__version__"]


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value  # later lookups skip this function
        return value
    raise AttributeError(f"module 'gymtrack' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
