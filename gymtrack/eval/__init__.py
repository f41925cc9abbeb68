"""Evaluation: the paper's metrics, the baselines and the benchmark (paper Section IV).

* :mod:`.metrics`    ID switches, AED, FR, coverage of the target; MOTA / IDF1 of all people
* :mod:`.gt`         detections labelled with GT persons (the oracle); the ground truth itself is
  :mod:`gymtrack.formats.ground_truth`
* :mod:`.mvpt`       the frame-by-frame MvPT-like baseline
* :mod:`.benchmark`  every method on every routine of a suite, in parallel processes
* :mod:`.aggregate`  Tables 3, 5, 6 and the claims from the benchmark's rows
* :mod:`.render`     report.md / CSV / JSON, Fig. 6 plots
* :mod:`.config`     the claims' thresholds and the data paths
* :mod:`.score`      an output folder of ``gymtrack track`` scored against ``<routine>/gt/`` (``gymtrack eval``)
* :mod:`.wildtrack`  the real-data section on WILDTRACK
* :mod:`.elements`   judging measurements (elements, angles) scored against the simulator's ``gt/elements.json``
* :mod:`.judging`    the benchmark's judging section: each method's skeleton analysed and scored

Only the light modules are imported here; the others pull in the tracker and are imported on use.
"""

from .gt import GroundTruth, load_ground_truth, match_detections_to_gt, with_gt_ids
from .metrics import (
    average_euclidean_distance,
    coverage,
    failure_rate,
    mot_metrics,
    performing_frames,
    target_id_switches,
)

__all__ = [
    "GroundTruth", "load_ground_truth", "match_detections_to_gt", "with_gt_ids",
    "average_euclidean_distance", "coverage", "failure_rate", "mot_metrics", "performing_frames", "target_id_switches",
]
