"""Camera geometry: one small functional module per topic, every array shape documented.

* :mod:`.camera`         ``Camera``, ``Rig``: projection with distortion, undistortion, rays (Eq. 5-6)
* :mod:`.epipolar`       fundamental matrices and the box distance of Eq. 1
* :mod:`.triangulation`  DLT + reprojection-error refinement (Eq. 3)
* :mod:`.plane`          ``Plane`` and ray-plane intersection (Eq. 7)
* :mod:`.views`          line-of-sight angles and opposite camera pairs
* :mod:`.primitives`     the scalar equations (Eq. 1, 3, 6, 7, projection) compiled with numba, shared
                         by the public functions above and the tracker's kernels
* :mod:`.arrays`         ``RigArrays`` (``Rig.arrays``) and ``PlaneArrays``: the groups the kernels take
"""

from .camera import Camera, Rig
from .epipolar import epipolar_distance, epipolar_lines, fundamental_matrices, fundamental_matrix, point_line_distance
from .plane import Plane, RayPlaneStatus, intersect_rays_plane
from .triangulation import reprojection_residuals, triangulate, triangulate_rig
from .views import line_of_sight_angle, opposite_pairs, pairwise_angles

__all__ = [
    "Camera", "Rig", "Plane", "RayPlaneStatus",
    "epipolar_distance", "epipolar_lines", "fundamental_matrices", "fundamental_matrix", "point_line_distance",
    "intersect_rays_plane", "line_of_sight_angle", "opposite_pairs", "pairwise_angles",
    "reprojection_residuals", "triangulate", "triangulate_rig",
]
