"""EasyMocap's ``intri.yml`` + ``extri.yml`` (OpenCV FileStorage YAML).

Paper: Section III-B's ``K_c`` (3, 3), distortion, ``R_c`` (Rodrigues (3, 1) or matrix (3, 3))
and ``t_c`` (3, 1) per camera, in metres.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from ...errors import CalibrationError, GymtrackWarning
from ...geometry.camera import Rig
from .checks import (CalibrationFormat, CalibrationReport, as_array, build_camera, build_rig, camera_name, distortion,
                     image_size, units_scale)
from .filestorage import filestorage_numbers, open_filestorage

__all__ = ["read_easymocap", "FORMAT"]


def _fs_names(fs: cv2.FileStorage, source) -> list[str]:
    node = fs.getNode("names")
    if node.empty() or node.isNone() or not node.isSeq():
        raise CalibrationError("missing the list of camera names", source=source, field="names")
    names = []
    for i in range(node.size()):
        item = node.at(i)
        if item.isString():
            names.append(item.string())
        elif item.isInt():  # EasyMocap's reader turns unquoted numbers into names the same way
            names.append(str(int(item.real())))
        else:
            raise CalibrationError(f"name {i} is not a string", source=source, field=f"names[{i}]")
    names = [n for n in names if n != "none"]  # EasyMocap skips 'none' placeholders
    if not names:
        raise CalibrationError("the list of camera names is empty", source=source, field="names")
    return names


def read_easymocap(
    intri: str | Path,
    extri: str | Path | None = None,
    units: str = "m",
    size: tuple[int, int] | None = None,
    report: CalibrationReport | None = None,
) -> Rig:
    """Read EasyMocap's ``intri.yml`` + ``extri.yml`` (OpenCV FileStorage YAML).

    Layout (``easymocap/mytools/camera_utils.py``): ``intri.yml`` has ``names`` (list) and per
    camera ``K_<name>`` (3x3), ``dist_<name>`` (1x5; ``D_<name>`` also read), optionally
    ``H_<name>`` / ``W_<name>`` (image size); ``extri.yml`` has ``R_<name>`` (Rodrigues 3x1),
    ``Rot_<name>`` (3x3) and ``T_<name>`` (3x1), world -> camera, in metres (EasyMocap requires
    metres). Like EasyMocap, the rotation comes from ``R_``; ``Rot_`` is used when ``R_`` is
    absent and must agree with it when both are present.

    ``extri`` defaults to ``extri.yml`` beside ``intri``. The image size comes from
    ``W_``/``H_``, else from ``size``, else it is guessed as twice the principal point (a
    warning and a note in ``report``).
    """
    intri = Path(intri)
    extri = Path(extri) if extri is not None else intri.with_name("extri" + intri.suffix)
    scale = units_scale(units, intri, "units (argument)")
    fi, fe = open_filestorage(intri), open_filestorage(extri)
    try:
        names = _fs_names(fi, intri)
        out, guessed = [], []
        for nm in names:
            name = camera_name(nm, intri, "names")
            K = as_array(filestorage_numbers(fi.getNode(f"K_{nm}"), intri, f"K_{nm}"), (3, 3), intri, f"K_{nm}", "K")
            dnode = fi.getNode(f"dist_{nm}")
            dfield = f"dist_{nm}"
            if dnode.empty() or dnode.isNone():
                dnode, dfield = fi.getNode(f"D_{nm}"), f"D_{nm}"
            dist = distortion(filestorage_numbers(dnode, intri, dfield), intri, dfield)
            W = filestorage_numbers(fi.getNode(f"W_{nm}"), intri, f"W_{nm}")
            H = filestorage_numbers(fi.getNode(f"H_{nm}"), intri, f"H_{nm}")
            if W is not None and H is not None and W.size == 1 and H.size == 1 and W > 0 and H > 0:
                sz = image_size([W.item(), H.item()], intri, f"W_{nm}, H_{nm}")
            elif size is not None:
                sz = image_size(size, intri, "size (argument)")
            else:
                sz = (int(round(2 * K[0, 2])), int(round(2 * K[1, 2])))
                guessed.append(name)
            rvec = filestorage_numbers(fe.getNode(f"R_{nm}"), extri, f"R_{nm}")
            rot = filestorage_numbers(fe.getNode(f"Rot_{nm}"), extri, f"Rot_{nm}")
            if rvec is None and rot is None:
                raise CalibrationError(f"no rotation for camera {nm!r}: need R_{nm} (Rodrigues) or Rot_{nm} (matrix)", source=extri, field=f"R_{nm}")
            if rvec is not None:
                R = cv2.Rodrigues(as_array(rvec, (3,), extri, f"R_{nm}", "R (Rodrigues vector)"))[0]
                if rot is not None:
                    Rm = as_array(rot, (3, 3), extri, f"Rot_{nm}", "Rot")
                    if np.abs(Rm - R).max() > 1e-4:
                        raise CalibrationError(
                            f"Rot_{nm} and R_{nm} disagree by {np.abs(Rm - R).max():.3g}: they must be the same rotation",
                            source=extri, field=f"Rot_{nm}",
                        )
            else:
                R = as_array(rot, (3, 3), extri, f"Rot_{nm}", "Rot")
            t = as_array(filestorage_numbers(fe.getNode(f"T_{nm}"), extri, f"T_{nm}"), (3,), extri, f"T_{nm}", "T") * scale
            out.append(build_camera(name, sz, K, R, t, dist, intri))
    finally:
        fi.release()
        fe.release()
    if guessed:
        msg = f"{intri}: no W_/H_ image size for {', '.join(guessed)}; guessed as twice the principal point"
        warnings.warn(msg, GymtrackWarning, stacklevel=2)
        if report is not None:
            report.notes.append(msg)
    if report is not None:
        report.units = units
    return build_rig(out, intri)



def _read(path: Path, report: CalibrationReport, **options: Any) -> Rig:
    intri = path
    if path.name.lower().startswith("extri"):
        intri = path.with_name("intri" + path.suffix)
        options.setdefault("extri", path)
    return read_easymocap(intri, report=report, **options)


FORMAT = CalibrationFormat("easymocap", frozenset({"units", "size", "extri"}), _read)
