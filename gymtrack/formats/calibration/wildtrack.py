"""WILDTRACK ``calibrations/``: seven real, independently calibrated cameras read as a Rig.

Paper: none directly; WILDTRACK (Chavdarova et al., CVPR 2018) gives Section III-B's ``K_c``
(3, 3), ``R_c`` (Rodrigues (3,)) and ``t_c`` (3,, centimetres) per camera on real data.

Layout (``shared/data/wildtrack/README.md``): ``calibrations/extrinsic/extr_<cam>.xml`` holds
OpenCV FileStorage ``rvec`` and ``tvec`` (world -> camera, cm, z up, ground at z = 0);
``calibrations/intrinsic_zero/intr_<cam>.xml`` the ``camera_matrix`` of the undistorted frames the
annotations refer to (the default, no distortion); ``intrinsic_original/`` the same matrix plus the
lens distortion of the raw video. The annotations are :mod:`gymtrack.formats.wildtrack`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np

from ...errors import CalibrationError
from ...geometry.camera import Camera, Rig
from .checks import CalibrationFormat, CalibrationReport, as_array, build_camera, build_rig, distortion
from .filestorage import read_opencv_xml_numbers

__all__ = ["WILDTRACK_VIEWS", "WILDTRACK_SIZE", "is_wildtrack_dir", "read_wildtrack_calibration", "FORMAT"]

#: The seven views in ``viewNum`` order.
WILDTRACK_VIEWS: tuple[str, ...] = ("CVLab1", "CVLab2", "CVLab3", "CVLab4", "IDIAP1", "IDIAP2", "IDIAP3")
#: Image size of every WILDTRACK camera (width, height).
WILDTRACK_SIZE: tuple[int, int] = (1920, 1080)


def _calibrations_dir(folder: Path) -> Path:
    if (folder / "extrinsic").is_dir():
        return folder
    if (folder / "calibrations" / "extrinsic").is_dir():
        return folder / "calibrations"
    raise CalibrationError("not a WILDTRACK calibrations folder: no extrinsic/ inside", source=folder)


def read_wildtrack_calibration(
    folder: str | Path, intrinsics: str = "zero", size: tuple[int, int] = WILDTRACK_SIZE
) -> Rig:
    """Read a WILDTRACK ``calibrations/`` folder (or the dataset folder holding it) into a Rig.

    Parameters
    ----------
    folder: the ``calibrations/`` folder or its parent.
    intrinsics: ``"zero"`` (default): ``intrinsic_zero/``, no distortion, matching the annotated
        boxes, which refer to undistorted frames; ``"original"``: ``intrinsic_original/`` with the
        lens distortion of the raw video.
    size: image size, (1920, 1080) for WILDTRACK.

    Cameras are named after their files (``extr_CVLab1.xml`` -> ``CVLab1``) and ordered as
    :data:`WILDTRACK_VIEWS` (``viewNum`` order), other names after them, sorted. Translations
    are converted from centimetres to metres.
    """
    root = _calibrations_dir(Path(folder))
    if intrinsics not in ("zero", "original"):
        raise CalibrationError(f"intrinsics must be 'zero' or 'original', got {intrinsics!r}", source=root, field="intrinsics")
    intr_dir = root / f"intrinsic_{intrinsics}"
    if not intr_dir.is_dir():
        raise CalibrationError(f"missing folder intrinsic_{intrinsics}/", source=root)
    files = {p.stem[len("extr_"):]: p for p in (root / "extrinsic").glob("extr_*.xml")}
    if not files:
        raise CalibrationError("no extr_<cam>.xml files", source=root / "extrinsic")
    order = [n for n in WILDTRACK_VIEWS if n in files] + sorted(n for n in files if n not in WILDTRACK_VIEWS)
    cams: list[Camera] = []
    for name in order:
        ext = files[name]
        rvec = as_array(read_opencv_xml_numbers(ext, "rvec"), (3,), ext, "rvec")
        tvec = as_array(read_opencv_xml_numbers(ext, "tvec"), (3,), ext, "tvec")
        intr = intr_dir / f"intr_{name}.xml"
        if not intr.is_file():
            raise CalibrationError(f"no intrinsics for camera {name!r}", source=intr)
        K = as_array(read_opencv_xml_numbers(intr, "camera_matrix"), (3, 3), intr, "camera_matrix")
        dist = np.zeros(5)
        if intrinsics == "original":
            dist = distortion(read_opencv_xml_numbers(intr, "distortion_coefficients"), intr, "distortion_coefficients")
        R = cv2.Rodrigues(rvec)[0]
        cams.append(build_camera(name, size, K, R, tvec / 100.0, dist, ext))
    return build_rig(cams, root)


def is_wildtrack_dir(path: Path) -> bool:
    return ((path / "extrinsic").is_dir() and (path / "intrinsic_zero").is_dir()) or (
        (path / "calibrations" / "extrinsic").is_dir() and (path / "calibrations" / "intrinsic_zero").is_dir()
    )



def _read(path: Path, report: CalibrationReport, **options: Any) -> Rig:
    rig = read_wildtrack_calibration(path, **options)
    report.units = "cm"
    return rig


FORMAT = CalibrationFormat("wildtrack", frozenset({"intrinsics"}), _read)
