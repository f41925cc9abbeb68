"""aniposelib ``calibration.toml`` (``CameraGroup.dump``).

Paper: Section III-B's ``K_c`` (3, 3), ``R_c`` (from a Rodrigues vector (3,)) and ``t_c`` (3,)
per camera, in the units the file (or the caller) states, converted to metres.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any, Mapping

import cv2

from ...errors import CalibrationError
from ...geometry.camera import Rig
from .checks import (CalibrationFormat, CalibrationReport, as_array, build_camera, build_rig, camera_name, distortion,
                     image_size, read_calibration_text, units_scale, warn_if_far)

__all__ = ["read_anipose", "FORMAT"]

_CAM_SECTION = re.compile(r"^cam_(\d+)$")


def read_anipose(path: str | Path, units: str | None = None, report: CalibrationReport | None = None) -> Rig:
    """Read an aniposelib ``calibration.toml`` (``CameraGroup.dump``).

    Layout: one table ``[cam_N]`` per camera with ``name``, ``size`` ``[w, h]``, ``matrix`` (3x3),
    ``distortions`` (OpenCV order), ``rotation`` (Rodrigues vector, world -> camera) and
    ``translation``; an optional ``[metadata]`` table. Cameras are ordered by ``N`` numerically
    (aniposelib itself sorts the keys as strings, which puts ``cam_10`` before ``cam_2``).

    Units: aniposelib stores translations in whatever unit the calibration board's
    ``square_length`` was given in (anipose's ``board_square_side_length``, which its
    documentation writes in millimetres); the file does not say which. gymtrack takes the unit
    from, in order: the ``units`` argument, a ``units`` key in ``[metadata]`` (a gymtrack
    extension that aniposelib ignores), else metres. A camera more than 200 m from the origin
    raises a warning suggesting the unit is wrong. Fisheye cameras (``fisheye = true``) use a
    different lens model and are rejected.
    """
    path = Path(path)
    text = read_calibration_text(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise CalibrationError(f"not valid TOML: {exc}", source=path) from None
    meta = data.get("metadata", {})
    if not isinstance(meta, Mapping):
        raise CalibrationError("[metadata] must be a table", source=path, field="metadata")
    if units is not None:
        units_used, origin = units, "the units argument"
        scale = units_scale(units, path, "units (argument)")
    elif "units" in meta:
        units_used, origin = meta["units"], "[metadata] units"
        scale = units_scale(meta["units"], path, "metadata.units")
    else:
        units_used, origin = "m", "the default (aniposelib files do not state their units)"
        scale = 1.0
    sections = []
    for key, val in data.items():
        if key == "metadata":
            continue
        m = _CAM_SECTION.match(key)
        if m is None or not isinstance(val, Mapping):
            raise CalibrationError("expected only [cam_N] camera tables and [metadata]", source=path, field=key)
        sections.append((int(m.group(1)), key, val))
    if not sections:
        raise CalibrationError("no [cam_N] camera tables", source=path)
    sections.sort()
    out = []
    for _, key, c in sections:
        if c.get("fisheye", False):
            raise CalibrationError("fisheye cameras are not supported (OpenCV pinhole model only)", source=path, field=f"{key}.fisheye")
        for k in ("name", "size", "matrix", "rotation", "translation"):
            if k not in c:
                raise CalibrationError(f"missing key '{k}'", source=path, field=f"{key}.{k}")
        nm = c["name"]
        # aniposelib's Camera.set_name stores str(name), so a bare integer name is its name as text
        nm = str(nm) if isinstance(nm, int) and not isinstance(nm, bool) else nm
        name = camera_name(nm, path, f"{key}.name")
        size = image_size(c["size"], path, f"{key}.size")
        K = as_array(c["matrix"], (3, 3), path, f"{key}.matrix", "matrix")
        R = cv2.Rodrigues(as_array(c["rotation"], (3,), path, f"{key}.rotation", "rotation (Rodrigues vector)"))[0]
        t = as_array(c["translation"], (3,), path, f"{key}.translation", "translation") * scale
        dist = distortion(c.get("distortions"), path, f"{key}.distortions")
        out.append(build_camera(name, size, K, R, t, dist, path))
    rig = build_rig(out, path)
    if report is not None:
        report.units = str(units_used)
        report.notes.append(f"translations read in {units_used} (from {origin})")
    if units is None and "units" not in meta:
        warn_if_far(rig, path, report, "metres")
    return rig



def _read(path: Path, report: CalibrationReport, **options: Any) -> Rig:
    return read_anipose(path, report=report, **options)


FORMAT = CalibrationFormat("anipose", frozenset({"units"}), _read)
