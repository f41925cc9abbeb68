"""CMU Panoptic ``calibration_<seq>.json``, converted to metres and z up.

Paper: Section III-B's ``K_c`` (3, 3), ``R_c`` (3, 3), ``t_c`` (3,) per camera; the Panoptic
world (y down, cm) is rotated by :data:`PANOPTIC_TO_ZUP` (3, 3) into the gymtrack world.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ...errors import CalibrationError
from ...geometry.camera import Rig
from .checks import (CalibrationFormat, CalibrationReport, as_array, build_camera, build_rig, camera_name, distortion,
                     image_size, read_calibration_text, short_repr)

__all__ = ["PANOPTIC_TO_ZUP", "read_panoptic", "FORMAT"]

#: Panoptic world (y down, cm) -> gymtrack world (z up): ``X_zup = PANOPTIC_TO_ZUP @ X_panoptic``.
#: Maps the Panoptic axes x -> x, y -> -z, z -> y: a proper rotation (det +1) about x by +90 deg.
PANOPTIC_TO_ZUP: np.ndarray = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
PANOPTIC_TO_ZUP.setflags(write=False)


def _type_matches(cam_type: str, wanted: Sequence[str]) -> bool:
    return any(cam_type == w or cam_type.startswith(w + "-") for w in wanted)


def read_panoptic(
    path: str | Path, camera_types: Sequence[str] = ("hd",), report: CalibrationReport | None = None
) -> Rig:
    """Read a CMU Panoptic ``calibration_<seq>.json`` and convert it to metres, z up.

    The file holds ``{"cameras": [{name, type, resolution [w, h], K, distCoef, R, t}, ...]}``
    with ``t`` in centimetres in the Panoptic world, whose y axis points down (gravity +y).

    Conversion: world points map as ``X_zup = A @ X_panoptic / 100`` with
    ``A = PANOPTIC_TO_ZUP = [[1, 0, 0], [0, 0, 1], [0, -1, 0]]`` (x -> x, y -> -z, z -> y; a
    rotation by +90 degrees about x, det +1). A camera's extrinsics become
    ``R' = R @ A.T`` and ``t' = t / 100``, so ``R' X_zup + t' = (R X_panoptic + t) / 100``:
    every point projects to the same pixel as before, and the world's up (Panoptic -y) is +z.

    ``camera_types`` chooses the cameras kept: ``"hd"`` (default; the 31 1920x1080 HD cameras),
    ``"vga"`` (480 VGA cameras), ``"kinect"`` (matches ``kinect-color`` etc.). The others are
    counted per type in ``report.skipped``.
    """
    path = Path(path)
    text = read_calibration_text(path)
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise CalibrationError(f"not valid JSON: {exc.msg} (line {exc.lineno}, column {exc.colno})", source=path) from None
    if not isinstance(data, Mapping) or not isinstance(data.get("cameras"), list):
        raise CalibrationError("expected a mapping with a 'cameras' list", source=path, field="cameras")
    if isinstance(camera_types, str):
        camera_types = (camera_types,)
    A = PANOPTIC_TO_ZUP
    out, skipped, types_seen = [], {}, set()
    for i, c in enumerate(data["cameras"]):
        f = f"cameras[{i}]"
        if not isinstance(c, Mapping):
            raise CalibrationError(f"each camera must be a mapping, got {short_repr(c)}", source=path, field=f)
        ctype = c.get("type", "")
        if not isinstance(ctype, str):
            raise CalibrationError(f"type must be a string, got {short_repr(ctype)}", source=path, field=f"{f}.type")
        types_seen.add(ctype)
        if not _type_matches(ctype, camera_types):
            skipped[f"type {ctype or '(none)'}"] = skipped.get(f"type {ctype or '(none)'}", 0) + 1
            continue
        for k in ("name", "resolution", "K", "R", "t"):
            if k not in c:
                raise CalibrationError(f"missing key '{k}'", source=path, field=f"{f}.{k}")
        name = camera_name(c["name"], path, f"{f}.name")
        size = image_size(c["resolution"], path, f"{f}.resolution")
        K = as_array(c["K"], (3, 3), path, f"{f}.K", "K")
        R = as_array(c["R"], (3, 3), path, f"{f}.R", "R")
        t = as_array(c["t"], (3,), path, f"{f}.t", "t")
        dist = distortion(c.get("distCoef"), path, f"{f}.distCoef")
        out.append(build_camera(name, size, K, R @ A.T, t / 100.0, dist, path))
    if not out:
        raise CalibrationError(
            f"no camera of type {', '.join(camera_types)}; the file has types {', '.join(sorted(types_seen)) or '(none)'}",
            source=path, field="cameras",
        )
    if report is not None:
        report.units = "cm"
        report.skipped.update(skipped)
        report.notes.append("Panoptic world (y down, cm) rotated to z up and converted to metres: X_zup = A @ X / 100")
    return build_rig(out, path)



def _read(path: Path, report: CalibrationReport, **options: Any) -> Rig:
    return read_panoptic(path, report=report, **options)


FORMAT = CalibrationFormat("panoptic", frozenset({"camera_types"}), _read)
