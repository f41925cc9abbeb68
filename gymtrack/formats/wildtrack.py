"""WILDTRACK: real multi-camera pedestrian data, read as per-view boxes and ground positions.

Paper: none directly; WILDTRACK (Chavdarova et al., CVPR 2018) is real, independently calibrated
multi-camera data on which the multi-view machinery of Section III-B (projection, epipolar
distance, triangulation, ray-plane intersection with the ground plane) can be checked against
something this project did not make. The calibration reader is
:mod:`gymtrack.formats.calibration.wildtrack` (re-exported here).

Layout (``shared/data/wildtrack/README.md``): ``annotations_positions/NNNNNNNN.json``: per video
frame, a list of ``{personID, positionID, views: [{viewNum, xmin, ymin, xmax, ymax}]}``; a view
where the person is not visible has all four values -1. Ground position in cm:
``X = -300 + 2.5 * (positionID % 480)``, ``Y = -900 + 2.5 * (positionID // 480)``, ``Z = 0``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from ..detections import Detections
from ..errors import DetectionFormatError
from .calibration.wildtrack import WILDTRACK_SIZE, WILDTRACK_VIEWS, read_wildtrack_calibration

__all__ = [
    "WILDTRACK_VIEWS", "WILDTRACK_SIZE", "GRID_WIDTH", "GRID_ORIGIN_CM", "GRID_STEP_CM", "read_wildtrack_calibration",
    "WildtrackAnnotations", "position_from_id", "read_wildtrack_annotations",
]

#: The ground grid: 480 x 1440 cells of 2.5 cm starting at (-300, -900) cm.
GRID_WIDTH = 480
GRID_ORIGIN_CM = (-300.0, -900.0)
GRID_STEP_CM = 2.5


@dataclass(frozen=True, eq=False)
class WildtrackAnnotations:
    """WILDTRACK ground truth in columnar form.

    Attributes
    ----------
    detections: every visible box (N rows): ``frame`` = video frame number (the file's number),
        ``camera`` = viewNum, ``box`` centre form, ``track_id`` = personID, ``score`` 1.
    frame: (P,) int64 video frame of each (frame, person) ground position.
    person_id: (P,) int64.
    position_id: (P,) int64 WILDTRACK grid cell.
    position: (P, 3) float64 ground position in metres (z = 0).
    box_position: (N,) int64 row of ``frame``/``position`` for each detection row.
    files: number of annotation files read.
    skipped: reason -> count of views not turned into boxes (``"not visible (-1)"``,
        ``"empty box"``).
    """

    detections: Detections
    frame: np.ndarray
    person_id: np.ndarray
    position_id: np.ndarray
    position: np.ndarray
    box_position: np.ndarray
    files: int
    skipped: dict[str, int] = field(default_factory=dict)


def position_from_id(position_id: np.ndarray) -> np.ndarray:
    """(...) WILDTRACK ``positionID`` -> (..., 3) ground position in metres (z = 0)."""
    pid = np.asarray(position_id, dtype=np.int64)
    x = GRID_ORIGIN_CM[0] + GRID_STEP_CM * (pid % GRID_WIDTH)
    y = GRID_ORIGIN_CM[1] + GRID_STEP_CM * (pid // GRID_WIDTH)
    return np.stack([x, y, np.zeros_like(x, dtype=np.float64)], axis=-1) / 100.0


def _annotations_dir(folder: Path) -> Path:
    if (folder / "annotations_positions").is_dir():
        return folder / "annotations_positions"
    if folder.is_dir():
        return folder
    raise DetectionFormatError("folder not found", source=folder)


def _int(value, source, field) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value != value or int(value) != value:
        raise DetectionFormatError(f"expected a whole number, got {value!r}", source=source, field=field)
    return int(value)


def read_wildtrack_annotations(
    folder: str | Path, camera_names: Sequence[str] = WILDTRACK_VIEWS, limit: int | None = None
) -> WildtrackAnnotations:
    """Read ``annotations_positions/*.json`` (``folder`` is it or the dataset folder).

    Parameters
    ----------
    folder: the annotations folder or its parent.
    camera_names: view names in ``viewNum`` order (the rig's order).
    limit: read only the first ``limit`` files (sorted by frame), for quick checks.

    Views with all four coordinates -1 (person not visible there) are skipped and counted, as are
    boxes with no area. A malformed entry raises DetectionFormatError naming the file and the
    entry (``[3].views[2].xmax``).
    """
    adir = _annotations_dir(Path(folder))
    paths = sorted(adir.glob("*.json"), key=lambda p: (len(p.stem), p.stem))
    if not paths:
        raise DetectionFormatError("no annotation .json files", source=adir)
    if limit is not None:
        paths = paths[: max(int(limit), 0)]
    n_views = len(camera_names)
    p_frame, p_person, p_pos = [], [], []
    b_rows: list[tuple[int, int, float, float, float, float, int, int]] = []
    skipped = {"not visible (-1)": 0, "empty box": 0}
    for path in paths:
        try:
            frame = int(path.stem)
        except ValueError:
            raise DetectionFormatError("file name must be the frame number (NNNNNNNN.json)", source=path) from None
        try:
            entries = json.loads(path.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise DetectionFormatError(f"not valid JSON: {exc}", source=path) from None
        if not isinstance(entries, list):
            raise DetectionFormatError("expected a list of persons", source=path)
        for i, e in enumerate(entries):
            if not isinstance(e, dict) or not isinstance(e.get("views"), list):
                raise DetectionFormatError("expected {personID, positionID, views: [...]}", source=path, field=f"[{i}]")
            person = _int(e.get("personID"), path, f"[{i}].personID")
            posid = _int(e.get("positionID"), path, f"[{i}].positionID")
            row = len(p_frame)
            p_frame.append(frame)
            p_person.append(person)
            p_pos.append(posid)
            for j, v in enumerate(e["views"]):
                f = f"[{i}].views[{j}]"
                if not isinstance(v, dict):
                    raise DetectionFormatError("expected {viewNum, xmin, ymin, xmax, ymax}", source=path, field=f)
                view = _int(v.get("viewNum"), path, f"{f}.viewNum")
                if not 0 <= view < n_views:
                    raise DetectionFormatError(f"viewNum {view} outside 0..{n_views - 1}", source=path, field=f"{f}.viewNum")
                xyxy = [_int(v.get(k), path, f"{f}.{k}") for k in ("xmin", "ymin", "xmax", "ymax")]
                if all(c == -1 for c in xyxy):
                    skipped["not visible (-1)"] += 1
                    continue
                if xyxy[2] <= xyxy[0] or xyxy[3] <= xyxy[1]:
                    skipped["empty box"] += 1
                    continue
                b_rows.append((frame, view, *map(float, xyxy), person, row))
    b = np.array(b_rows, dtype=np.float64).reshape(-1, 8)
    xyxy = b[:, 2:6]
    box = np.column_stack([(xyxy[:, 0] + xyxy[:, 2]) / 2, (xyxy[:, 1] + xyxy[:, 3]) / 2, xyxy[:, 2] - xyxy[:, 0], xyxy[:, 3] - xyxy[:, 1]])
    det = Detections.from_arrays(b[:, 0], b[:, 1], box, camera_names, track_id=b[:, 6])
    pos_id = np.asarray(p_pos, dtype=np.int64)
    return WildtrackAnnotations(
        detections=det,
        frame=np.asarray(p_frame, dtype=np.int64),
        person_id=np.asarray(p_person, dtype=np.int64),
        position_id=pos_id,
        position=position_from_id(pos_id),
        box_position=b[:, 7].astype(np.int64),
        files=len(paths),
        skipped={k: v for k, v in skipped.items() if v},
    )
