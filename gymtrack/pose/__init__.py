"""The pose stage: the target's 3D skeleton from its multi-view 2D poses.

Paper: Section III-D (2D poses in the expanded boxes ``b_buf``, lifted with Eq. 3), extended by
robust lifting and the cascade for joints. Layer: above tracking and simulate, below
eval and cli.

* :mod:`.lift`       ``lift_track``, ``LiftOptions``, ``Lifted``: one track's 2D poses -> 3D
* :mod:`.dlt`        batched weighted triangulation, rays and the ray/plane fusion
* :mod:`.consensus`  per-frame view consensus and left/right swaps
* :mod:`.anchor`     weak joints on the target's plane; bone lengths
* :mod:`.smooth`     temporal smoothing that keeps flight phases sharp
* :mod:`.assign`     2D poses without a track id -> the 3D track whose box they overlap
* :mod:`.stage`      ``lift_poses``: a tracker result + 2D poses -> ``Poses3D`` (target or every track)
"""

from .lift import METHODS, LiftOptions, Lifted, lift_track

__all__ = ["METHODS", "LiftOptions", "Lifted", "lift_track"]
