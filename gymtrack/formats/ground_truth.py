"""Ground truth of a routine: ``gt/persons_3d.csv`` and ``gt/boxes_2d/<camera>.txt``.

Paper: Section IV-A evaluates against ground-truth 3D tracklets and 2D boxes of the target
gymnast. Our ground truth comes from the simulator (``gymtrack.simulate``), either in memory or
written to a routine folder (``shared/formats.md``); this module holds it and reads it.

:class:`GroundTruth` holds it as columns: one row per person per frame (3D) and one row per
person per frame per view (2D boxes, centre form). Evaluation-only helpers (matching detections
to it, the oracle association) are :mod:`gymtrack.eval.gt`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Sequence

import numpy as np

from ..detections import Detections
from ..errors import RoutineError
from ..scene import in_box
from .motchallenge import read_gt_boxes
from .textfile import read_text

__all__ = ["GroundTruth", "ROLES", "load_ground_truth", "read_persons_3d"]

ROLES = ("target", "coach", "judge", "gymnast", "spectator")


@dataclass(frozen=True, eq=False)
class GroundTruth:
    """Columnar ground truth of one routine.

    Persons (P rows): ``frame`` (P,) int64, ``person_id`` (P,) int64, ``role`` (P,) str,
    ``xyz`` (P, 3) body centre in metres, ``top_z``/``bottom_z`` (P,) heights of the body's top and
    bottom, ``phase`` (P,) bool or None: the simulator's "performance phase" flag if it has one.

    Boxes (B rows): ``box_frame`` (B,) int64, ``box_camera`` (B,) int16 (index into
    ``camera_names``), ``box_person`` (B,) int64, ``box`` (B, 4) true box, centre form
    ``[x, y, w, h]`` pixels, ``box_visible`` (B,) bool.

    ``image_size``: (C, 2) ``(width, height)`` per camera, or None.
    """

    camera_names: tuple[str, ...]
    frame: np.ndarray
    person_id: np.ndarray
    role: np.ndarray
    xyz: np.ndarray
    top_z: np.ndarray
    bottom_z: np.ndarray
    box_frame: np.ndarray
    box_camera: np.ndarray
    box_person: np.ndarray
    box: np.ndarray
    box_visible: np.ndarray
    phase: np.ndarray | None = None
    image_size: np.ndarray | None = None

    def __post_init__(self) -> None:
        p = len(self.frame)
        for name in ("person_id", "role", "xyz", "top_z", "bottom_z"):
            if len(getattr(self, name)) != p:
                raise ValueError(f"GroundTruth.{name} has {len(getattr(self, name))} rows, frame has {p}")
        if self.phase is not None and len(self.phase) != p:
            raise ValueError(f"GroundTruth.phase has {len(self.phase)} rows, frame has {p}")
        b = len(self.box_frame)
        for name in ("box_camera", "box_person", "box", "box_visible"):
            if len(getattr(self, name)) != b:
                raise ValueError(f"GroundTruth.{name} has {len(getattr(self, name))} rows, box_frame has {b}")

    # ------------------------------------------------------------------ target
    @property
    def target_id(self) -> int:
        """The person id whose role is ``target``; RoutineError if there is none or several."""
        ids = np.unique(self.person_id[self.role == "target"])
        if ids.size != 1:
            raise RoutineError(f"ground truth must have exactly one person with role 'target', found {ids.size}", source="gt/persons_3d.csv", field="role")
        return int(ids[0])

    def target(self) -> "GroundTruth":
        """The target's rows only (persons and boxes), sorted by frame (then camera)."""
        tid = self.target_id
        pm = self.person_id == tid
        po = np.argsort(self.frame[pm], kind="stable")
        bm = self.box_person == tid
        bo = np.lexsort((self.box_camera[bm], self.box_frame[bm]))
        return self._take(np.flatnonzero(pm)[po], np.flatnonzero(bm)[bo])

    def _take(self, prow: np.ndarray, brow: np.ndarray) -> "GroundTruth":
        return replace(
            self,
            frame=self.frame[prow], person_id=self.person_id[prow], role=self.role[prow], xyz=self.xyz[prow],
            top_z=self.top_z[prow], bottom_z=self.bottom_z[prow],
            phase=None if self.phase is None else self.phase[prow],
            box_frame=self.box_frame[brow], box_camera=self.box_camera[brow], box_person=self.box_person[brow],
            box=self.box[brow], box_visible=self.box_visible[brow],
        )

    def performing(self, performance_space: Sequence[float]) -> np.ndarray:
        """(P,) bool: rows of the *target* inside ``S_perf`` (and in the phase, if flagged)."""
        ok = (self.person_id == self.target_id) & in_box(self.xyz, performance_space)
        if self.phase is not None:
            ok &= self.phase.astype(bool)
        return ok

    def subset_cameras(self, names: Sequence[str]) -> "GroundTruth":
        """The same ground truth restricted to (and re-indexed for) the cameras ``names``."""
        old = np.array([self.camera_names.index(n) for n in names], dtype=np.int64)
        remap = np.full(len(self.camera_names), -1, np.int64)
        remap[old] = np.arange(old.size)
        keep = remap[self.box_camera.astype(np.int64)] >= 0
        out = self._take(np.arange(len(self.frame)), np.flatnonzero(keep))
        return replace(
            out,
            camera_names=tuple(names),
            box_camera=remap[out.box_camera.astype(np.int64)].astype(np.int16),
            image_size=None if self.image_size is None else np.asarray(self.image_size)[old],
        )

    @property
    def frames(self) -> np.ndarray:
        return np.unique(self.frame)

    def __repr__(self) -> str:
        return f"GroundTruth({np.unique(self.person_id).size} persons, {len(self.frames)} frames, {len(self.box_frame)} boxes, cameras {list(self.camera_names)})"


# ----------------------------------------------------------------------------- reading
def _parse_rows(path: Path, ncols: int, header_first: str | None) -> tuple[list[list[str]], list[int]]:
    """Comma-separated rows of ``path`` with at least ``ncols`` fields; skips a header line and blanks.

    Returns the rows and the 1-based line number of each, for error messages.
    """
    text = read_text(path, RoutineError)
    rows: list[list[str]] = []
    lines: list[int] = []
    for k, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        parts = [p.strip() for p in s.split(",")]
        if header_first is not None and k == 1 and parts[0] == header_first:
            continue
        if len(parts) != ncols:  # (more would be dropped unseen)
            raise RoutineError(f"expected {ncols} comma-separated values, got {len(parts)}", source=path, line=k)
        rows.append(parts)
        lines.append(k)
    return rows, lines


def _numeric(rows: list[list[str]], lines: list[int], cols: Sequence[int], names: Sequence[str], path: Path) -> np.ndarray:
    if not rows:
        return np.zeros((0, len(cols)))
    arr = np.array(rows, dtype=object)[:, list(cols)]
    try:
        num = arr.astype(np.float64)
    except ValueError:
        for r, ln in zip(rows, lines):
            for c, nm in zip(cols, names):
                try:
                    float(r[c])
                except ValueError:
                    raise RoutineError(f"{nm} must be a number, got {r[c]!r}", source=path, line=ln, field=nm) from None
        raise
    bad = np.isinf(num)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise RoutineError(f"{names[j]} must be finite, got {rows[i][cols[j]]!r}", source=path, line=lines[i],
                           field=names[j])
    return num


def _whole(v: np.ndarray, lines: list[int], name: str, path: Path) -> np.ndarray:
    """(n,) floats that must be whole numbers (ids, frames) -> int64, else the line is named."""
    bad = np.flatnonzero(~np.isfinite(v) | (v != np.round(v)) | (np.abs(v) > 2.0**53))
    if bad.size:
        k = int(bad[0])
        raise RoutineError(f"{name} must be a whole number, got {v[k]!r}", source=path, line=lines[k], field=name)
    return v.astype(np.int64)


def read_persons_3d(path: str | Path) -> dict[str, np.ndarray]:
    """``gt/persons_3d.csv`` (``frame,person_id,role,x,y,z,top_z,bottom_z``) -> columns.

    Returns a dict with ``frame``, ``person_id``, ``role``, ``xyz`` (P, 3), ``top_z``, ``bottom_z``
    and, if the file has a 9th column named ``phase`` in its header, ``phase`` (P,) bool.
    """
    path = Path(path)
    first = read_text(path, RoutineError).split("\n", 1)[0].strip().split(",")
    has_phase = len(first) >= 9 and first[0].strip() == "frame" and first[8].strip() == "phase"
    rows, lines = _parse_rows(path, 9 if has_phase else 8, "frame")
    names = ["frame", "person_id", "x", "y", "z", "top_z", "bottom_z"]
    num = _numeric(rows, lines, [0, 1, 3, 4, 5, 6, 7], names, path)
    role = np.array([r[2] for r in rows], dtype="<U12") if rows else np.zeros(0, "<U12")
    bad = ~np.isin(role, ROLES)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise RoutineError(f"role must be one of {', '.join(ROLES)}, got {role[k]!r}", source=path, line=lines[k], field="role")
    out = {
        "frame": _whole(num[:, 0], lines, "frame", path),
        "person_id": _whole(num[:, 1], lines, "person_id", path),
        "role": role,
        "xyz": num[:, 2:5].copy(),
        "top_z": num[:, 5].copy(),
        "bottom_z": num[:, 6].copy(),
    }
    if has_phase:
        out["phase"] = _numeric(rows, lines, [8], ["phase"], path)[:, 0] > 0.5
    return out


def load_ground_truth(routine: str | Path, camera_names: Sequence[str], image_size: np.ndarray | None = None) -> GroundTruth:
    """Read ``<routine>/gt/`` for the cameras ``camera_names`` (the rig's order).

    Boxes are read with :func:`gymtrack.formats.motchallenge.read_gt_boxes`. A camera without
    ``gt/boxes_2d/<camera>.txt`` is an error (the FR would silently lose that view).
    """
    gt_dir = Path(routine) / "gt"
    if not gt_dir.is_dir():
        raise RoutineError("routine has no gt/ folder (ground truth)", source=routine)
    p = read_persons_3d(gt_dir / "persons_3d.csv")
    boxes, visible = [], []
    for c, name in enumerate(camera_names):
        b, vis, _ = read_gt_boxes(gt_dir / "boxes_2d" / f"{name}.txt", c, camera_names)
        boxes.append(b)
        visible.append(vis)
    b = Detections.concat(boxes)
    return GroundTruth(
        camera_names=tuple(camera_names),
        frame=p["frame"], person_id=p["person_id"], role=p["role"], xyz=p["xyz"], top_z=p["top_z"], bottom_z=p["bottom_z"],
        phase=p.get("phase"),
        box_frame=b.frame, box_camera=b.camera, box_person=b.track_id, box=b.box, box_visible=np.concatenate(visible),
        image_size=image_size,
    )
