"""Camera calibration files: every supported format read into a :class:`~gymtrack.geometry.Rig`.

Paper: Section III-B needs, per camera ``c``, the intrinsics ``K_c`` and the extrinsics
``[R_c | t_c]`` (``P_c = K_c [R_c | t_c]``); this module reads them from the files people have.
Every reader returns cameras in the conventions of ``shared/formats.md``: metres, world z up,
extrinsics world -> camera (``X_cam = R @ X_world + t``), OpenCV distortion order.

Formats (``format=`` name, how :func:`load_calibration` recognises the file):

* ``native``    ``cameras.yaml`` / ``cameras.yml`` / ``cameras.json`` (:func:`read_native`)
* ``anipose``   aniposelib ``calibration.toml`` / any ``*.toml`` (:func:`read_anipose`)
* ``easymocap`` OpenCV FileStorage ``intri.yml`` + ``extri.yml`` (:func:`read_easymocap`)
* ``panoptic``  CMU Panoptic ``calibration_<seq>.json`` (:func:`read_panoptic`)
* ``wildtrack`` a WILDTRACK ``calibrations/`` folder (:func:`gymtrack.formats.wildtrack.read_wildtrack_calibration`)

Each reader validates what it reads and raises :class:`~gymtrack.errors.CalibrationError` naming
the file and the field (``cameras[2].R``, ``cam_1.translation``, ``K_cam3``...) for missing keys,
wrong shapes, non-numbers, NaN, a singular ``K``, a rotation that is not a rotation, and missing or
unknown units. What a reader leaves out on purpose (Panoptic cameras of another type) or guesses
(an EasyMocap image size) is counted in the :class:`CalibrationReport` of
:func:`read_calibration`.
"""

from __future__ import annotations

import json
import re
import tomllib
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import cv2
import numpy as np
import yaml

from ..errors import CalibrationError
from ..geometry.camera import Camera, Rig
from .textfile import read_text

#: Length units accepted by ``units:`` fields and ``units=`` arguments, as metres per unit.
UNITS: dict[str, float] = {"m": 1.0, "cm": 0.01, "mm": 0.001}

FORMATS: tuple[str, ...] = ("native", "anipose", "easymocap", "panoptic", "wildtrack")

#: Panoptic world (y down, cm) -> gymtrack world (z up): ``X_zup = PANOPTIC_TO_ZUP @ X_panoptic``.
#: Maps the Panoptic axes x -> x, y -> -z, z -> y: a proper rotation (det +1) about x by +90 deg.
PANOPTIC_TO_ZUP: np.ndarray = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
PANOPTIC_TO_ZUP.setflags(write=False)

# A camera further than this from the world origin (after unit conversion) is implausible in a
# gymnastics hall and usually means translations in mm or cm read as metres.
_IMPLAUSIBLE_DISTANCE_M = 200.0


@dataclass
class CalibrationReport:
    """What :func:`read_calibration` read, left out and guessed.

    Attributes
    ----------
    path: the calibration file or folder.
    format: one of :data:`FORMATS`.
    cameras: number of cameras in the returned rig.
    units: the length unit the file's translations were read in (converted to metres).
    skipped: reason -> number of cameras left out (e.g. ``{"type vga": 480}`` for Panoptic).
    notes: anything else a user should know (guessed image sizes, where the units came from).
    """

    path: Path
    format: str
    cameras: int = 0
    units: str = "m"
    skipped: dict[str, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


# ============================================================================ validation helpers
def units_scale(units: Any, source: str | Path | None = None, field: str = "units") -> float:
    """Metres per unit of ``units`` (``"m" | "cm" | "mm"``); anything else is a CalibrationError."""
    if units is None:
        raise CalibrationError(f"units missing: give one of {', '.join(UNITS)}", source=source, field=field)
    if not isinstance(units, str) or units.strip().lower() not in UNITS:
        raise CalibrationError(f"unknown units {units!r}: use one of {', '.join(UNITS)}", source=source, field=field)
    return UNITS[units.strip().lower()]


def _array(value: Any, shape: tuple[int, ...], source, field: str, what: str | None = None) -> np.ndarray:
    """``value`` as a finite float64 array of ``shape``; a vector shape ``(n,)`` also accepts
    ``(n, 1)`` / ``(1, n)`` (OpenCV column vectors)."""
    what = what or field
    if value is None:
        raise CalibrationError(f"{what} is missing", source=source, field=field)
    if isinstance(value, (str, bytes, Mapping)):
        raise CalibrationError(f"{what} must be numbers of shape {list(shape)}, got {_short(value)}", source=source, field=field)
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise CalibrationError(f"{what} must be numbers of shape {list(shape)}, got {_short(value)}", source=source, field=field) from None
    if len(shape) == 1 and arr.ndim == 2 and 1 in arr.shape and arr.size == shape[0]:
        arr = arr.reshape(shape)
    if arr.shape != shape:
        raise CalibrationError(f"{what} must have shape {list(shape)}, got {list(arr.shape)}", source=source, field=field)
    if not np.all(np.isfinite(arr)):
        raise CalibrationError(f"{what} contains NaN or infinity", source=source, field=field)
    return arr


def _dist(value: Any, source, field: str) -> np.ndarray:
    """Optional OpenCV distortion vector (4, 5 or 8 numbers; None or empty = no distortion)."""
    if value is None:
        return np.zeros(5)
    if isinstance(value, (str, bytes, Mapping)):
        raise CalibrationError(f"distortion must be a list of numbers, got {_short(value)}", source=source, field=field)
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise CalibrationError(f"distortion must be a list of numbers, got {_short(value)}", source=source, field=field) from None
    if arr.ndim > 2 or (arr.ndim == 2 and 1 not in arr.shape):
        raise CalibrationError(f"distortion must be a vector, got shape {list(arr.shape)}", source=source, field=field)
    arr = arr.reshape(-1)
    if arr.size not in (0, 4, 5, 8):
        raise CalibrationError(f"distortion must have 4, 5 or 8 coefficients (OpenCV order), got {arr.size}", source=source, field=field)
    if not np.all(np.isfinite(arr)):
        raise CalibrationError("distortion contains NaN or infinity", source=source, field=field)
    return arr if arr.size else np.zeros(5)


def _size(value: Any, source, field: str) -> tuple[int, int]:
    """``[width, height]``: two positive whole numbers."""
    if isinstance(value, (str, bytes, Mapping)) or value is None:
        raise CalibrationError(f"size must be [width, height] in pixels, got {_short(value)}", source=source, field=field)
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise CalibrationError(f"size must be [width, height] in pixels, got {_short(value)}", source=source, field=field) from None
    if arr.size != 2 or not np.all(np.isfinite(arr)) or np.any(arr <= 0) or np.any(arr != np.round(arr)) or np.any(arr > 1e6):
        raise CalibrationError(f"size must be [width, height], two positive whole numbers, got {_short(value)}", source=source, field=field)
    return int(arr[0]), int(arr[1])


def _name(value: Any, source, field: str) -> str:
    if not isinstance(value, str) or not value.strip():
        hint = " (quote it in YAML so leading zeros are kept)" if isinstance(value, (int, float)) and not isinstance(value, bool) else ""
        raise CalibrationError(f"camera name must be a non-empty string, got {_short(value)}{hint}", source=source, field=field)
    if any(c in value for c in "/\\\n\r\t"):
        raise CalibrationError(f"camera name {value!r} must not contain path separators or control characters", source=source, field=field)
    return value.strip()


def _rotation(R: Any, rvec: Any, source, field: str) -> np.ndarray:
    """A (3, 3) matrix from ``R`` or from a Rodrigues vector ``rvec`` (exactly one of them)."""
    if R is not None and rvec is not None:
        raise CalibrationError("give either R (matrix) or rvec (Rodrigues vector), not both", source=source, field=field)
    if R is None and rvec is None:
        raise CalibrationError("rotation missing: give R (3x3 matrix) or rvec (Rodrigues vector)", source=source, field=field)
    if R is not None:
        return _array(R, (3, 3), source, f"{field}.R" if field else "R", "R")
    v = _array(rvec, (3,), source, f"{field}.rvec" if field else "rvec", "rvec")
    return cv2.Rodrigues(v)[0]


def _camera(name: str, size, K, R, t, dist, source) -> Camera:
    """Build a Camera; its own validation errors (not a rotation, singular K...) get the file."""
    try:
        return Camera(name, size, K, R, t, dist)
    except CalibrationError as exc:
        raise exc.located(source=source) from None


def _rig(cameras: Sequence[Camera], source) -> Rig:
    try:
        return Rig(cameras)
    except CalibrationError as exc:
        raise exc.located(source=source) from None


def _short(value: Any, n: int = 60) -> str:
    s = repr(value)
    return s if len(s) <= n else s[: n - 3] + "..."


def _read_text(path: Path) -> str:
    return read_text(path, CalibrationError)


def _check_keys(d: Mapping, allowed: set[str], source, field: str) -> None:
    extra = [k for k in d if k not in allowed]
    if extra:
        raise CalibrationError(
            f"unknown key {extra[0]!r}; expected only {', '.join(sorted(allowed))}", source=source,
            field=f"{field}.{extra[0]}" if field else str(extra[0]),
        )


def _warn_if_far(rig: Rig, source, report: CalibrationReport | None, units_hint: str) -> None:
    far = float(np.max(np.linalg.norm(rig.centres, axis=1)))
    if far > _IMPLAUSIBLE_DISTANCE_M:
        msg = (
            f"{source}: a camera is {far:.0f} m from the world origin; if the translations are not in "
            f"{units_hint}, give the units explicitly (units='mm' or 'cm')"
        )
        warnings.warn(msg, stacklevel=3)
        if report is not None:
            report.notes.append(msg)


# ============================================================================ native
_NATIVE_TOP = {"units", "cameras"}
_NATIVE_CAMERA = {"name", "size", "K", "dist", "R", "rvec", "t"}


def native_from_dict(data: Any, source: str | Path = "cameras.yaml") -> Rig:
    """Validate a parsed native calibration mapping (keys of ``shared/formats.md``) into a Rig.

    ``units`` (``m | cm | mm``) is required; translations are converted to metres. Each camera
    needs ``name``, ``size`` ``[w, h]``, ``K`` (3x3), ``t`` (3) and either ``R`` (3x3) or
    ``rvec`` (Rodrigues, 3); ``dist`` (4, 5 or 8 OpenCV coefficients) is optional.
    """
    if not isinstance(data, Mapping):
        raise CalibrationError(f"expected a mapping with keys 'units' and 'cameras', got {type(data).__name__}", source=source)
    _check_keys(data, _NATIVE_TOP, source, "")
    scale = units_scale(data.get("units"), source, "units")
    cams = data.get("cameras")
    if not isinstance(cams, list) or not cams:
        raise CalibrationError("'cameras' must be a non-empty list of cameras", source=source, field="cameras")
    out = []
    for i, c in enumerate(cams):
        f = f"cameras[{i}]"
        if not isinstance(c, Mapping):
            raise CalibrationError(f"each camera must be a mapping, got {_short(c)}", source=source, field=f)
        _check_keys(c, _NATIVE_CAMERA, source, f)
        for key in ("name", "size", "K", "t"):
            if key not in c:
                raise CalibrationError(f"missing key '{key}'", source=source, field=f"{f}.{key}")
        name = _name(c["name"], source, f"{f}.name")
        size = _size(c["size"], source, f"{f}.size")
        K = _array(c["K"], (3, 3), source, f"{f}.K", "K")
        R = _rotation(c.get("R"), c.get("rvec"), source, f)
        t = _array(c["t"], (3,), source, f"{f}.t", "t") * scale
        dist = _dist(c.get("dist"), source, f"{f}.dist")
        out.append(_camera(name, size, K, R, t, dist, source))
    return _rig(out, source)


def read_native(path: str | Path) -> Rig:
    """Read a native ``cameras.yaml`` (or ``cameras.json`` with the same keys)."""
    path = Path(path)
    text = _read_text(path)
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


# ============================================================================ aniposelib
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
    text = _read_text(path)
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
        name = _name(nm, path, f"{key}.name")
        size = _size(c["size"], path, f"{key}.size")
        K = _array(c["matrix"], (3, 3), path, f"{key}.matrix", "matrix")
        R = cv2.Rodrigues(_array(c["rotation"], (3,), path, f"{key}.rotation", "rotation (Rodrigues vector)"))[0]
        t = _array(c["translation"], (3,), path, f"{key}.translation", "translation") * scale
        dist = _dist(c.get("distortions"), path, f"{key}.distortions")
        out.append(_camera(name, size, K, R, t, dist, path))
    rig = _rig(out, path)
    if report is not None:
        report.units = str(units_used)
        report.notes.append(f"translations read in {units_used} (from {origin})")
    if units is None and "units" not in meta:
        _warn_if_far(rig, path, report, "metres")
    return rig


# ============================================================================ EasyMocap (OpenCV FileStorage)
def _open_fs(path: Path) -> cv2.FileStorage:
    if not path.is_file():
        raise CalibrationError("file not found", source=path)
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as exc:  # OpenCV's parse errors surface as either
        cause = exc.__cause__ or exc
        msg = str(cause).strip().splitlines()[-1] if str(cause).strip() else "unreadable"
        raise CalibrationError(f"not a readable OpenCV FileStorage file: {msg}", source=path) from None
    if not fs.isOpened() or not fs.root().isMap():
        raise CalibrationError("not a readable OpenCV FileStorage file (no top-level mapping)", source=path)
    return fs


def _fs_node_numbers(node: cv2.FileNode, source, field: str) -> np.ndarray | None:
    """Numbers of a FileStorage node: an ``opencv-matrix``, a plain sequence or a scalar; None if
    the node is absent."""
    if node.empty() or node.isNone():
        return None
    if node.isMap():
        try:
            m = node.mat()
        except cv2.error:
            m = None
        if m is None:
            raise CalibrationError("expected an opencv-matrix (rows, cols, dt, data)", source=source, field=field)
        return np.asarray(m, dtype=np.float64)
    if node.isSeq():
        vals = []
        for i in range(node.size()):
            item = node.at(i)
            if not (item.isReal() or item.isInt()):
                raise CalibrationError(f"item {i} is not a number", source=source, field=field)
            vals.append(item.real())
        return np.asarray(vals, dtype=np.float64)
    if node.isReal() or node.isInt():
        return np.asarray(node.real(), dtype=np.float64)
    raise CalibrationError("expected numbers", source=source, field=field)


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
    fi, fe = _open_fs(intri), _open_fs(extri)
    try:
        names = _fs_names(fi, intri)
        out, guessed = [], []
        for nm in names:
            name = _name(nm, intri, "names")
            K = _array(_fs_node_numbers(fi.getNode(f"K_{nm}"), intri, f"K_{nm}"), (3, 3), intri, f"K_{nm}", "K")
            dnode = fi.getNode(f"dist_{nm}")
            dfield = f"dist_{nm}"
            if dnode.empty() or dnode.isNone():
                dnode, dfield = fi.getNode(f"D_{nm}"), f"D_{nm}"
            dist = _dist(_fs_node_numbers(dnode, intri, dfield), intri, dfield)
            W = _fs_node_numbers(fi.getNode(f"W_{nm}"), intri, f"W_{nm}")
            H = _fs_node_numbers(fi.getNode(f"H_{nm}"), intri, f"H_{nm}")
            if W is not None and H is not None and W.size == 1 and H.size == 1 and W > 0 and H > 0:
                sz = _size([W.item(), H.item()], intri, f"W_{nm}, H_{nm}")
            elif size is not None:
                sz = _size(size, intri, "size (argument)")
            else:
                sz = (int(round(2 * K[0, 2])), int(round(2 * K[1, 2])))
                guessed.append(name)
            rvec = _fs_node_numbers(fe.getNode(f"R_{nm}"), extri, f"R_{nm}")
            rot = _fs_node_numbers(fe.getNode(f"Rot_{nm}"), extri, f"Rot_{nm}")
            if rvec is None and rot is None:
                raise CalibrationError(f"no rotation for camera {nm!r}: need R_{nm} (Rodrigues) or Rot_{nm} (matrix)", source=extri, field=f"R_{nm}")
            if rvec is not None:
                R = cv2.Rodrigues(_array(rvec, (3,), extri, f"R_{nm}", "R (Rodrigues vector)"))[0]
                if rot is not None:
                    Rm = _array(rot, (3, 3), extri, f"Rot_{nm}", "Rot")
                    if np.abs(Rm - R).max() > 1e-4:
                        raise CalibrationError(
                            f"Rot_{nm} and R_{nm} disagree by {np.abs(Rm - R).max():.3g}: they must be the same rotation",
                            source=extri, field=f"Rot_{nm}",
                        )
            else:
                R = _array(rot, (3, 3), extri, f"Rot_{nm}", "Rot")
            t = _array(_fs_node_numbers(fe.getNode(f"T_{nm}"), extri, f"T_{nm}"), (3,), extri, f"T_{nm}", "T") * scale
            out.append(_camera(name, sz, K, R, t, dist, intri))
    finally:
        fi.release()
        fe.release()
    if guessed:
        msg = f"{intri}: no W_/H_ image size for {', '.join(guessed)}; guessed as twice the principal point"
        warnings.warn(msg, stacklevel=2)
        if report is not None:
            report.notes.append(msg)
    if report is not None:
        report.units = units
    return _rig(out, intri)


# ============================================================================ CMU Panoptic
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
    text = _read_text(path)
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
            raise CalibrationError(f"each camera must be a mapping, got {_short(c)}", source=path, field=f)
        ctype = c.get("type", "")
        if not isinstance(ctype, str):
            raise CalibrationError(f"type must be a string, got {_short(ctype)}", source=path, field=f"{f}.type")
        types_seen.add(ctype)
        if not _type_matches(ctype, camera_types):
            skipped[f"type {ctype or '(none)'}"] = skipped.get(f"type {ctype or '(none)'}", 0) + 1
            continue
        for k in ("name", "resolution", "K", "R", "t"):
            if k not in c:
                raise CalibrationError(f"missing key '{k}'", source=path, field=f"{f}.{k}")
        name = _name(c["name"], path, f"{f}.name")
        size = _size(c["resolution"], path, f"{f}.resolution")
        K = _array(c["K"], (3, 3), path, f"{f}.K", "K")
        R = _array(c["R"], (3, 3), path, f"{f}.R", "R")
        t = _array(c["t"], (3,), path, f"{f}.t", "t")
        dist = _dist(c.get("distCoef"), path, f"{f}.distCoef")
        out.append(_camera(name, size, K, R @ A.T, t / 100.0, dist, path))
    if not out:
        raise CalibrationError(
            f"no camera of type {', '.join(camera_types)}; the file has types {', '.join(sorted(types_seen)) or '(none)'}",
            source=path, field="cameras",
        )
    if report is not None:
        report.units = "cm"
        report.skipped.update(skipped)
        report.notes.append("Panoptic world (y down, cm) rotated to z up and converted to metres: X_zup = A @ X / 100")
    return _rig(out, path)


# ============================================================================ detection and dispatch
def detect_format(path: str | Path) -> str:
    """The calibration format of ``path`` from its name (see the module docstring).

    A folder is a WILDTRACK calibration when it (or its ``calibrations/`` sub-folder) holds
    ``extrinsic/`` and ``intrinsic_zero/``; any other folder is searched with
    :func:`find_calibration`.
    """
    path = Path(path)
    if path.is_dir():
        if _is_wildtrack_dir(path):
            return "wildtrack"
        return detect_format(find_calibration(path))
    name = path.name.lower()
    if name in ("cameras.yaml", "cameras.yml", "cameras.json"):
        return "native"
    if name.endswith(".toml"):
        return "anipose"
    if name in ("intri.yml", "intri.yaml", "extri.yml", "extri.yaml"):
        return "easymocap"
    if re.fullmatch(r"calibration_.+\.json", name):
        return "panoptic"
    raise CalibrationError(
        "cannot tell the calibration format from the file name; name it cameras.yaml / cameras.json (native), "
        "calibration.toml (aniposelib), intri.yml + extri.yml (EasyMocap), calibration_<seq>.json (CMU Panoptic), "
        f"or pass format= one of {', '.join(FORMATS)}",
        source=path,
    )


def _is_wildtrack_dir(path: Path) -> bool:
    return ((path / "extrinsic").is_dir() and (path / "intrinsic_zero").is_dir()) or (
        (path / "calibrations" / "extrinsic").is_dir() and (path / "calibrations" / "intrinsic_zero").is_dir()
    )


#: Calibration file names searched in a folder, in this order.
CALIBRATION_NAMES: tuple[str, ...] = ("cameras.yaml", "cameras.yml", "cameras.json", "calibration.toml", "intri.yml", "intri.yaml")


def find_calibration(folder: str | Path, error=CalibrationError) -> Path:
    """The one calibration inside ``folder``: a file named in :data:`CALIBRATION_NAMES`, a
    ``calibration_*.json`` or a WILDTRACK ``calibrations/`` folder. None or several is an error."""
    folder = Path(folder)
    found = [folder / n for n in CALIBRATION_NAMES if (folder / n).is_file()]
    found += sorted(folder.glob("calibration_*.json"))
    if (folder / "calibrations").is_dir() and _is_wildtrack_dir(folder / "calibrations"):
        found.append(folder / "calibrations")
    if not found:
        raise error(
            "no calibration found: add cameras.yaml (see shared/formats.md) or one of "
            f"{', '.join(CALIBRATION_NAMES[3:])}, calibration_<seq>.json, calibrations/",
            source=folder,
        )
    if len(found) > 1:
        raise error(f"several calibrations found ({', '.join(p.name for p in found)}); keep one", source=folder)
    return found[0]


def read_calibration(path: str | Path, format: str | None = None, **options: Any) -> tuple[Rig, CalibrationReport]:
    """Read any supported calibration; returns the rig and a :class:`CalibrationReport`.

    Parameters
    ----------
    path: a calibration file, a WILDTRACK calibrations folder, or a folder holding exactly one
        calibration (see :func:`find_calibration`).
    format: one of :data:`FORMATS`; detected from the name when None.
    options: passed to the reader: ``units`` (anipose, easymocap), ``size`` (easymocap),
        ``camera_types`` (panoptic), ``intrinsics`` (wildtrack: ``"zero"`` or ``"original"``).
    """
    path = Path(path)
    if not path.exists():
        raise CalibrationError("file not found", source=path)
    if format is None:
        format = detect_format(path)
        if path.is_dir() and format != "wildtrack":
            path = find_calibration(path)
    if format not in FORMATS:
        raise CalibrationError(f"unknown calibration format {format!r}; use one of {', '.join(FORMATS)}", source=path, field="format")
    report = CalibrationReport(path=path, format=format)
    allowed = {"native": set(), "anipose": {"units"}, "easymocap": {"units", "size", "extri"}, "panoptic": {"camera_types"},
               "wildtrack": {"intrinsics"}}[format]
    bad = sorted(set(options) - allowed)
    if bad:
        raise CalibrationError(f"option {bad[0]!r} does not apply to the {format} format (accepted: {', '.join(sorted(allowed)) or 'none'})",
                               source=path, field=bad[0])
    if format == "native":
        rig = read_native(path)
    elif format == "anipose":
        rig = read_anipose(path, report=report, **options)
    elif format == "easymocap":
        intri = path
        if path.name.lower().startswith("extri"):
            intri = path.with_name("intri" + path.suffix)
            options.setdefault("extri", path)
        rig = read_easymocap(intri, report=report, **options)
    elif format == "panoptic":
        rig = read_panoptic(path, report=report, **options)
    else:
        from .wildtrack import read_wildtrack_calibration

        rig = read_wildtrack_calibration(path, **options)
        report.units = "cm"
    report.cameras = len(rig)
    return rig, report


def load_calibration(path: str | Path, format: str | None = None, **options: Any) -> Rig:
    """Read any supported calibration into a Rig (metres, z up); see :func:`read_calibration`."""
    return read_calibration(path, format, **options)[0]


# ============================================================================ OpenCV XML (shared with wildtrack)
def read_opencv_xml_numbers(path: Path, key: str, error=CalibrationError) -> np.ndarray | None:
    """Numbers stored under ``key`` in an OpenCV FileStorage XML file (matrix or plain list).

    Reads with ``cv2.FileStorage``; when OpenCV cannot parse the file, falls back to
    ``xml.etree`` (``<key>`` text or its ``<data>`` child). None when ``key`` is absent.
    """
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
        ok = fs.isOpened() and fs.root().isMap()
    except (cv2.error, SystemError):
        ok, fs = False, None
    if ok:
        try:
            return _fs_node_numbers(fs.getNode(key), path, key)
        finally:
            fs.release()
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise error(f"not a readable OpenCV XML file: {exc}", source=path) from None
    el = root.find(key)
    if el is None:
        return None
    data = el.find("data")
    text = (data.text if data is not None else el.text) or ""
    try:
        vals = np.array(text.split(), dtype=np.float64)
    except ValueError:
        raise error("expected numbers", source=path, field=key) from None
    rows, cols = el.find("rows"), el.find("cols")
    if data is not None and rows is not None and cols is not None:
        try:
            vals = vals.reshape(int(rows.text), int(cols.text))
        except (TypeError, ValueError):
            raise error("rows x cols does not match the data", source=path, field=key) from None
    return vals
