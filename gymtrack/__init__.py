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
"""

__version__ = "0.1.0"

from .detections import Detections  # noqa: E402
from .errors import GymtrackError, InputError  # noqa: E402

__all__ = ["Detections", "GymtrackError", "InputError", "__version__"]
