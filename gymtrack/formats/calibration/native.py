"""The native calibration ``cameras.yaml`` / ``cameras.json`` (``shared/formats.md``).

Paper: Section III-B's ``K_c`` (3, 3), ``R_c`` (3, 3) (or a Rodrigues ``rvec`` (3,)) and ``t_c``
(3,) per camera, with the length ``units`` stated; written back exactly by :func:`write_native`.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Mapping

import yaml

from ...errors import CalibrationError
from ..textfile import what_is
from ...geometry.camera import Rig
from .checks import (CalibrationFormat, as_array, build_camera, build_rig, camera_name, check_keys, distortion,
                     image_size, read_calibration_text, rotation, short_repr, units_scale)

__all__ = ["native_from_dict", "read_native", "native_to_dict", "write_native", "FORMAT"]

_NATIVE_TOP = {"units", "cameras"}
_NATIVE_CAMERA = {"name", "size", "K", "dist", "R", "rvec", "t"}


def native_from_dict(data: Any, source: str | Path = "cameras.yaml") -> Rig:
    """Validate a parsed native calibration mapping (keys of ``shared/formats.md``) into a Rig.

    ``units`` (``m | cm | mm``) is required; translations are converted to metres. Each camera
    needs ``name``, ``size`` ``[w, h]``, ``K`` (3x3), ``t`` (3) and either ``R`` (3x3) or
    ``rvec`` (Rodrigues, 3); ``dist`` (4, 5 or 8 OpenCV coefficients) is optional.
    """
    if not isinstance(data, Mapping):
        raise CalibrationError(f"expected a mapping with keys 'units' and 'cameras', got {what_is(data, 'an empty file')}", source=source)
    check_keys(data, _NATIVE_TOP, source, "")
    scale = units_scale(data.get("units"), source, "units")
    cams = data.get("cameras")
    if not isinstance(cams, list) or not cams:
        raise CalibrationError("'cameras' must be a non-empty list of cameras", source=source, field="cameras")
    out = []
    for i, c in enumerate(cams):
        f = f"cameras[{i}]"
        if not isinstance(c, Mapping):
            raise CalibrationError(f"each camera must be a mapping, got {short_repr(c)}", source=source, field=f)
        check_keys(c, _NATIVE_CAMERA, source, f)
        for key in ("name", "size", "K", "t"):
            if key not in c:
                raise CalibrationError(f"missing key '{key}'", source=source, field=f"{f}.{key}")
        name = camera_name(c["name"], source, f"{f}.name")
        size = image_size(c["size"], source, f"{f}.size")
        K = as_array(c["K"], (3, 3), source, f"{f}.K", "K")
        R = rotation(c.get("R"), c.get("rvec"), source, f)
        t = as_array(c["t"], (3,), source, f"{f}.t", "t") * scale
        dist = distortion(c.get("dist"), source, f"{f}.dist")
        out.append(build_camera(name, size, K, R, t, dist, source))
    return build_rig(out, source)


def read_native(path: str | Path) -> Rig:
    """Read a native ``cameras.yaml`` (or ``cameras.json`` with the same keys)."""
    path = Path(path)
    text = read_calibration_text(path)
    if path.suffix.lower() == ".json":
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise CalibrationError(f"not valid JSON: {exc.msg} (line {exc.lineno}, column {exc.colno})", source=path) from None
    else:
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark is not None else ""
            raise CalibrationError(f"not valid YAML: {getattr(exc, 'problem', None) or exc}{where}", source=path) from None
    return native_from_dict(data, source=path)


class _FlowListDumper(yaml.SafeDumper):
    """Writes lists of numbers (and matrices) on one line, everything else in block style."""


def _represent_list(dumper: yaml.SafeDumper, data: list):
    def is_num(x):
        return isinstance(x, (int, float)) and not isinstance(x, bool)

    flow = bool(data) and (all(is_num(x) for x in data) or all(isinstance(x, list) and all(is_num(y) for y in x) for x in data))
    return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=flow)


_FlowListDumper.add_representer(list, _represent_list)


def native_to_dict(rig: Rig) -> dict:
    """The native mapping of ``rig`` (units m, R as a matrix, floats exact)."""
    return {
        "units": "m",
        "cameras": [
            {
                "name": c.name,
                "size": [int(c.size[0]), int(c.size[1])],
                "K": c.K.tolist(),
                "dist": c.dist.tolist(),
                "R": c.R.tolist(),
                "t": c.t.tolist(),
            }
            for c in rig
        ],
    }


def write_native(rig: Rig, path: str | Path) -> Path:
    """Write ``rig`` as a native ``cameras.yaml`` (``units: m``; JSON when ``path`` ends in .json).

    Floats are written with Python's shortest round-trip repr, so :func:`read_native` gives back
    the same numbers bit for bit.
    """
    path = Path(path)
    d = native_to_dict(rig)
    if path.suffix.lower() == ".json":
        path.write_text(json.dumps(d, indent=1) + "\n")
    else:
        path.write_text(yaml.dump(d, Dumper=_FlowListDumper, sort_keys=False, width=200))
    return path



def _read(path: Path, report, **options: Any) -> Rig:
    return read_native(path)


FORMAT = CalibrationFormat("native", frozenset(), _read)
