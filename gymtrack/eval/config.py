"""The benchmark's configuration: the claims' thresholds and the data paths.

Paper: the targets checked against Tables 3 and 5 (Section IV) -- the cascade's FR and AED
relative to triangulation alone at two cameras, no loss with four, closeness to the
ground-truth association, and speed -- live here rather than in the library's code, with the
default place of the WILDTRACK data; so do the pose targets of the paper's Fig. 7,
checked on the MPJPE over the frames and joints both compared outputs estimated
(:mod:`gymtrack.eval.pose_bench`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

__all__ = ["BenchmarkConfig", "DEFAULT_CONFIG"]


@dataclass(frozen=True)
class BenchmarkConfig:
    """Thresholds of :func:`gymtrack.eval.aggregate.claims` and the benchmark's data paths."""

    #: n_cam = 2, averaged over apparatus: cascade FR <= this x triangulation FR
    fr_cascade_over_triangulation_2: float = 0.3
    #: n_cam = 2: cascade AED <= this x triangulation AED
    aed_cascade_over_triangulation_2: float = 0.85
    #: n_cam = 4: cascade AED <= this x triangulation AED (the cascade must not hurt with views to spare)
    aed_cascade_over_triangulation_4: float = 1.05
    #: every n_cam: cascade AED <= this x the ground-truth association's (oracle) AED
    aed_cascade_over_oracle: float = 1.25
    #: the cascade's frames per second, at least
    min_fps: float = 1000.0
    #: the cascade's frames per second >= this x triangulation's
    fps_cascade_over_triangulation: float = 0.9
    #: pose, n_cam = 2, averaged over apparatus, common frames: cascade MPJPE <= this x triangulation's (robust lifting)
    pose_cascade_over_triangulation_2: float = 0.7
    #: pose, n_cam = 2, common frames: robust MPJPE <= this x dlt's (the cascade's boxes, same keypoints)
    pose_robust_over_dlt_2: float = 0.85
    #: pose, n_cam = 4, common frames: robust MPJPE <= this x dlt's (no worse with views to spare)
    pose_robust_over_dlt_4: float = 1.0
    #: pose, every n_cam, common frames: cascade MPJPE <= this x the oracle's
    pose_cascade_over_oracle: float = 1.3
    #: lifting one target seen by 4 views, frames per second, at least (benchmarks/bench_pose.py)
    pose_min_lift_fps: float = 2000.0
    #: beyond the paper, cascade+: all people, mean over apparatus, MOTA / IDF1 at n_cam = 4 at least
    plus_mota_4: float = 0.85
    plus_idf1_4: float = 0.80
    #: ... MOTA at n_cam = 2 at least
    plus_mota_2: float = 0.75
    #: cascade+ target AED <= this x the oracle's at every n_cam
    plus_aed_over_oracle: float = 1.15
    #: cascade+ frames per second >= this x triangulation's (and >= ``min_fps``)
    plus_fps_over_triangulation: float = 0.85
    #: WILDTRACK: cascade+ MOTA and IDF1 at least
    plus_wildtrack_mota: float = 0.6
    plus_wildtrack_idf1: float = 0.6
    #: WILDTRACK: cascade+ ghost and duplicate outputs below this x the paper's cascade's (same run)
    plus_wildtrack_fp_over_cascade: float = 1 / 3
    #: judging measurements (cascade+'s skeleton analysed, pooled over apparatus), n_cam = 4: flight recall and
    #: precision, exact-salto, exact-twist and shape shares at least; median flight-time error (frames), apex
    #: error (m), knee and hip angle errors (deg), hold deviation error (deg) at most; n_cam = 2: recall, saltos
    judge_flight_recall_4: float = 0.95
    judge_flight_precision_4: float = 0.95
    judge_saltos_4: float = 0.95
    judge_twists_4: float = 0.90
    judge_shape_4: float = 0.90
    judge_time_frames_4: float = 1.0
    judge_apex_m_4: float = 0.05
    judge_angle_deg_4: float = 8.0
    judge_deviation_deg_4: float = 3.0
    judge_saltos_2: float = 0.90
    judge_flight_recall_2: float = 0.90
    #: the WILDTRACK dataset, relative to the current directory (the project root)
    wildtrack: Path = Path("../shared/data/wildtrack")


#: The thresholds the report and the CLI use unless told otherwise.
DEFAULT_CONFIG = BenchmarkConfig()
