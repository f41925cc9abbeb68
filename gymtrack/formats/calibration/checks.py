"""Shared checks of the calibration readers: units, arrays, names, sizes, rotations, the report.

Paper: Section III-B needs, per camera ``c``, ``K_c`` (3, 3) and ``[R_c | t_c]`` ((3, 3), (3,));
every reader of :mod:`gymtrack.formats.calibration` validates them with these helpers, which
raise :class:`~gymtrack.errors.CalibrationError` naming the file and the field.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import cv2
import numpy as np

from ...errors import CalibrationError, GymtrackWarning
from ...geometry.camera import Camera, Rig
from ..textfile import read_text

#: Length units accepted by ``units:`` fields and ``units=`` arguments, as metres per unit.
UNITS: dict[str, float] = {"m": 1.0, "cm": 0.01, "mm": 0.001}

#: A camera further than this from the world origin (after unit conversion) is implausible in a
#: gymnastics hall and usually means translations in mm or cm read as metres.
IMPLAUSIBLE_DISTANCE_M = 200.0


@dataclass
class CalibrationReport:
    """What :func:`~gymtrack.formats.calibration.read_calibration` read, left out and guessed.

    Attributes
    ----------
    path: the calibration file or folder.
    format: one of :data:`~gymtrack.formats.calibration.FORMATS`.
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


@dataclass(frozen=True)
class CalibrationFormat:
    """One entry of the dispatch table of :func:`gymtrack.formats.calibration.read_calibration`.

    ``read(path, report, **options) -> Rig``; ``options``: the keyword options it accepts.
    """

    name: str
    options: frozenset[str]
    read: Callable[..., Rig]


def units_scale(units: Any, source: str | Path | None = None, field: str = "units") -> float:
    """Metres per unit of ``units`` (``"m" | "cm" | "mm"``); anything else is a CalibrationError."""
    if units is None:
        raise CalibrationError(f"units missing: give one of {', '.join(UNITS)}", source=source, field=field)
    if not isinstance(units, str) or units.strip().lower() not in UNITS:
        raise CalibrationError(f"unknown units {units!r}: use one of {', '.join(UNITS)}", source=source, field=field)
    return UNITS[units.strip().lower()]


def as_array(value: Any, shape: tuple[int, ...], source, field: str, what: str | None = None) -> np.ndarray:
    """``value`` as a finite float64 array of ``shape``; a vector shape ``(n,)`` also accepts
    ``(n, 1)`` / ``(1, n)`` (OpenCV column vectors)."""
    what = what or field
    if value is None:
        raise CalibrationError(f"{what} is missing", source=source, field=field)
    if isinstance(value, (str, bytes, Mapping)):
        raise CalibrationError(f"{what} must be numbers of shape {list(shape)}, got {short_repr(value)}", source=source, field=field)
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise CalibrationError(f"{what} must be numbers of shape {list(shape)}, got {short_repr(value)}", source=source, field=field) from None
    if len(shape) == 1 and arr.ndim == 2 and 1 in arr.shape and arr.size == shape[0]:
        arr = arr.reshape(shape)
    if arr.shape != shape:
        raise CalibrationError(f"{what} must have shape {list(shape)}, got {list(arr.shape)}", source=source, field=field)
    if not np.all(np.isfinite(arr)):
        raise CalibrationError(f"{what} contains NaN or infinity", source=source, field=field)
    return arr


def distortion(value: Any, source, field: str) -> np.ndarray:
    """Optional OpenCV distortion vector (4, 5 or 8 numbers; None or empty = no distortion)."""
    if value is None:
        return np.zeros(5)
    if isinstance(value, (str, bytes, Mapping)):
        raise CalibrationError(f"distortion must be a list of numbers, got {short_repr(value)}", source=source, field=field)
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise CalibrationError(f"distortion must be a list of numbers, got {short_repr(value)}", source=source, field=field) from None
    if arr.ndim > 2 or (arr.ndim == 2 and 1 not in arr.shape):
        raise CalibrationError(f"distortion must be a vector, got shape {list(arr.shape)}", source=source, field=field)
    arr = arr.reshape(-1)
    if arr.size not in (0, 4, 5, 8):
        raise CalibrationError(f"distortion must have 4, 5 or 8 coefficients (OpenCV order), got {arr.size}", source=source, field=field)
    if not np.all(np.isfinite(arr)):
        raise CalibrationError("distortion contains NaN or infinity", source=source, field=field)
    return arr if arr.size else np.zeros(5)


def image_size(value: Any, source, field: str) -> tuple[int, int]:
    """``[width, height]``: two positive whole numbers."""
    if isinstance(value, (str, bytes, Mapping)) or value is None:
        raise CalibrationError(f"size must be [width, height] in pixels, got {short_repr(value)}", source=source, field=field)
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise CalibrationError(f"size must be [width, height] in pixels, got {short_repr(value)}", source=source, field=field) from None
    if arr.size != 2 or not np.all(np.isfinite(arr)) or np.any(arr <= 0) or np.any(arr != np.round(arr)) or np.any(arr > 1e6):
        raise CalibrationError(f"size must be [width, height], two positive whole numbers, got {short_repr(value)}", source=source, field=field)
    return int(arr[0]), int(arr[1])


def camera_name(value: Any, source, field: str) -> str:
    if not isinstance(value, str) or not value.strip():
        hint = " (quote it in YAML so leading zeros are kept)" if isinstance(value, (int, float)) and not isinstance(value, bool) else ""
        raise CalibrationError(f"camera name must be a non-empty string, got {short_repr(value)}{hint}", source=source, field=field)
    if any(c in value for c in "/\\\n\r\t"):
        raise CalibrationError(f"camera name {value!r} must not contain path separators or control characters", source=source, field=field)
    return value.strip()


def rotation(R: Any, rvec: Any, source, field: str) -> np.ndarray:
    """A (3, 3) matrix from ``R`` or from a Rodrigues vector ``rvec`` (exactly one of them)."""
    if R is not None and rvec is not None:
        raise CalibrationError("give either R (matrix) or rvec (Rodrigues vector), not both", source=source, field=field)
    if R is None and rvec is None:
        raise CalibrationError("rotation missing: give R (3x3 matrix) or rvec (Rodrigues vector)", source=source, field=field)
    if R is not None:
        return as_array(R, (3, 3), source, f"{field}.R" if field else "R", "R")
    v = as_array(rvec, (3,), source, f"{field}.rvec" if field else "rvec", "rvec")
    return cv2.Rodrigues(v)[0]


def build_camera(name: str, size, K, R, t, dist, source) -> Camera:
    """Build a Camera; its own validation errors (not a rotation, singular K...) get the file."""
    try:
        return Camera(name, size, K, R, t, dist)
    except CalibrationError as exc:
        raise exc.located(source=source) from None


def build_rig(cameras: Sequence[Camera], source) -> Rig:
    try:
        return Rig(cameras)
    except CalibrationError as exc:
        raise exc.located(source=source) from None


def short_repr(value: Any, n: int = 60) -> str:
    s = repr(value)
    return s if len(s) <= n else s[: n - 3] + "..."


def read_calibration_text(path: Path) -> str:
    return read_text(path, CalibrationError)


def check_keys(d: Mapping, allowed: set[str], source, field: str) -> None:
    extra = [k for k in d if k not in allowed]
    if extra:
        raise CalibrationError(
            f"unknown key {extra[0]!r}; expected only {', '.join(sorted(allowed))}", source=source,
            field=f"{field}.{extra[0]}" if field else str(extra[0]),
        )


def warn_if_far(rig: Rig, source, report: CalibrationReport | None, units_hint: str) -> None:
    far = float(np.max(np.linalg.norm(rig.centres, axis=1)))
    if far > IMPLAUSIBLE_DISTANCE_M:
        msg = (
            f"{source}: a camera is {far:.0f} m from the world origin; if the translations are not in "
            f"{units_hint}, give the units explicitly (--units mm or cm; units='mm' in Python)"
        )
        warnings.warn(msg, GymtrackWarning, stacklevel=3)
        if report is not None:
            report.notes.append(msg)

