"""Camera calibration files: every supported format read into a :class:`~gymtrack.geometry.Rig`.

Paper: Section III-B needs, per camera ``c``, the intrinsics ``K_c`` and the extrinsics
``[R_c | t_c]`` (``P_c = K_c [R_c | t_c]``); this package reads them from the files people have, one module
per format. Every reader returns cameras in the conventions of ``shared/formats.md``: metres,
world z up, extrinsics world -> camera (``X_cam = R @ X_world + t``), OpenCV distortion order.

Formats (``format=`` name, how :func:`load_calibration` recognises the file):

* ``native``    ``cameras.yaml`` / ``cameras.yml`` / ``cameras.json`` (:func:`read_native`, :mod:`.native`)
* ``anipose``   aniposelib ``calibration.toml`` / any ``*.toml`` (:func:`read_anipose`, :mod:`.anipose`)
* ``easymocap`` OpenCV FileStorage ``intri.yml`` + ``extri.yml`` (:func:`read_easymocap`, :mod:`.easymocap`)
* ``panoptic``  CMU Panoptic ``calibration_<seq>.json`` (:func:`read_panoptic`, :mod:`.panoptic`)
* ``wildtrack`` a WILDTRACK ``calibrations/`` folder (:func:`read_wildtrack_calibration`, :mod:`.wildtrack`)

Each reader validates what it reads and raises :class:`~gymtrack.errors.CalibrationError` naming
the file and the field (``cameras[2].R``, ``cam_1.translation``, ``K_cam3``...) for missing keys,
wrong shapes, non-numbers, NaN, a singular ``K``, a rotation that is not a rotation, and missing or
unknown units. What a reader leaves out on purpose (Panoptic cameras of another type) or guesses
(an EasyMocap image size) is counted in the :class:`CalibrationReport` of
:func:`read_calibration`.

:mod:`.dispatch` holds the table format -> reader (each format module contributes its
``FORMAT`` entry) and the detection by name; :mod:`.checks` the validation every reader shares;
:mod:`.filestorage` the OpenCV FileStorage reading shared by EasyMocap and WILDTRACK.
"""

from .anipose import read_anipose
from .checks import UNITS, CalibrationFormat, CalibrationReport, units_scale
from .dispatch import CALIBRATION_NAMES, FORMATS, READERS, detect_format, find_calibration, load_calibration, read_calibration
from .easymocap import read_easymocap
from .filestorage import read_opencv_xml_numbers
from .native import native_from_dict, native_to_dict, read_native, write_native
from .panoptic import PANOPTIC_TO_ZUP, read_panoptic
from .wildtrack import read_wildtrack_calibration

__all__ = [
    "UNITS", "FORMATS", "READERS", "CALIBRATION_NAMES", "PANOPTIC_TO_ZUP", "CalibrationFormat", "CalibrationReport",
    "units_scale", "native_from_dict", "native_to_dict", "read_native", "write_native", "read_anipose", "read_easymocap",
    "read_panoptic", "read_wildtrack_calibration", "read_opencv_xml_numbers", "detect_format", "find_calibration",
    "read_calibration", "load_calibration",
]
