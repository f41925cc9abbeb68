"""Writing (and reading back) the outputs of ``gymtrack track`` (``shared/formats.md``).

::

    <out>/
      tracks_3d.csv              frame,track_id,x,y,z,top_z,bottom_z,source,n_views
      tracks_2d/<camera>.txt     MOTChallenge result lines; the id is the 3D track id
      target_3d.csv              frame,track_id,x,y,z,source
      target_2d/<camera>.txt     MOTChallenge lines of the target's expanded box b_buf (Eq. 14)
      summary.json               counts, timings, frames per second, the gymtrack version

CSV files have a header line; numbers are metres with 4 decimals, pixels with 2. Unknown
heights are written empty. Frame numbers are the input's.
"""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from ..detections import Detections
from ..errors import InputError
from ..version import version
from .motchallenge import write_mot
from .textfile import fixed as _fmt, read_text, write_csv as _write_csv

TRACKS_3D_COLUMNS = ("frame", "track_id", "x", "y", "z", "top_z", "bottom_z", "source", "n_views")
TARGET_3D_COLUMNS = ("frame", "track_id", "x", "y", "z", "source")


def write_tracks_3d(path: str | Path, tracks) -> Path:
    """``tracks_3d.csv`` from a :class:`gymtrack.tracking.types.Tracks3D`."""
    t = tracks
    return _write_csv(Path(path), TRACKS_3D_COLUMNS, [
        t.frame.tolist(), t.track_id.tolist(), _fmt(t.xyz[:, 0], 4), _fmt(t.xyz[:, 1], 4), _fmt(t.xyz[:, 2], 4),
        _fmt(t.top_z, 4), _fmt(t.bottom_z, 4), t.source_name.tolist(), t.n_views.tolist(),
    ])


def write_target_3d(path: str | Path, target) -> Path:
    """``target_3d.csv`` from a :class:`gymtrack.tracking.types.Target`."""
    t = target
    return _write_csv(Path(path), TARGET_3D_COLUMNS, [
        t.frame.tolist(), t.track_id.tolist(), _fmt(t.xyz[:, 0], 4), _fmt(t.xyz[:, 1], 4), _fmt(t.xyz[:, 2], 4),
        t.source_name.tolist(),
    ])


def write_boxes_per_camera(folder: str | Path, boxes: Detections) -> list[Path]:
    """One MOTChallenge file per camera (``<folder>/<camera>.txt``, also for cameras without boxes)."""
    folder = Path(folder)
    out = []
    for c, name in enumerate(boxes.camera_names):
        d = boxes.select(boxes.camera == c)
        out.append(write_mot(folder / f"{name}.txt", d.frame, d.track_id, d.box, conf=d.score))
    return out


def write_outputs(result, out: str | Path) -> dict[str, Path]:
    """Write every output of a :class:`gymtrack.tracking.types.TrackResult` under ``out``.

    Returns the paths written, by name.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError("the output path exists and is not a folder", source=out)
    out.mkdir(parents=True, exist_ok=True)
    paths = {
        "tracks_3d": write_tracks_3d(out / "tracks_3d.csv", result.tracks),
        "target_3d": write_target_3d(out / "target_3d.csv", result.target),
    }
    write_boxes_per_camera(out / "tracks_2d", result.boxes)
    write_boxes_per_camera(out / "target_2d", result.target_boxes)
    paths["tracks_2d"] = out / "tracks_2d"
    paths["target_2d"] = out / "target_2d"
    summary = out / "summary.json"
    summary.write_text(json.dumps({**result.summary, "version": version()}, indent=2) + "\n")
    paths["summary"] = summary
    return paths


def read_tracks_3d(path: str | Path) -> dict[str, np.ndarray]:
    """Read ``tracks_3d.csv`` back into columns (frame, track_id, xyz (N,3), top_z, bottom_z, source, n_views)."""
    return _read_csv(Path(path), TRACKS_3D_COLUMNS)


def read_target_3d(path: str | Path) -> dict[str, np.ndarray]:
    """Read ``target_3d.csv`` back into columns (frame, track_id, xyz (N,3), source)."""
    return _read_csv(Path(path), TARGET_3D_COLUMNS)


def of_target(frame: np.ndarray, track_id: np.ndarray, target: dict[str, np.ndarray]) -> np.ndarray:
    """(N,) bool: the rows (frame, track_id) that are the target's in ``target`` (read_target_3d's
    columns), e.g. the target's poses among every track's."""
    key = np.asarray(target["frame"], np.int64) * (1 << 32) + np.asarray(target["track_id"], np.int64)
    return np.isin(np.asarray(frame, np.int64) * (1 << 32) + np.asarray(track_id, np.int64), key)


#: the ``source`` values the tracker writes (``tracking.types.SOURCE_NAMES``; formats sits below tracking)
SOURCES = ("triangulation", "plane", "interpolated")


def _read_csv(path: Path, columns: tuple[str, ...]) -> dict[str, np.ndarray]:
    """Columns of a tracker output CSV; an InputError names the line and column of the first bad value."""
    reader = csv.reader(io.StringIO(read_text(path), newline=""))
    try:
        rows = [(reader.line_num, r) for r in reader if r]  # (blank lines carry nothing)
    except csv.Error as exc:
        raise InputError(f"not CSV: {exc}", source=path, line=reader.line_num) from None
    if not rows or tuple(rows[0][1]) != columns:
        raise InputError(f"expected the header {','.join(columns)}", source=path, line=1)
    body = [r for _, r in rows[1:]]
    lines = np.array([n for n, _ in rows[1:]], np.int64)
    for i, r in enumerate(body):
        if len(r) != len(columns):
            raise InputError(f"expected {len(columns)} values, got {len(r)}", source=path, line=int(lines[i]))
    col = {name: [r[j] for r in body] for j, name in enumerate(columns)}

    def num(name: str, whole: bool = False) -> np.ndarray:
        v = np.full(len(body), np.nan)
        for i, text in enumerate(col[name]):
            try:
                v[i] = float(text) if text.strip() != "" or whole else np.nan
            except ValueError:
                raise InputError(f"{name} must be a number, got {text!r}", source=path, line=int(lines[i]),
                                 field=name) from None
        bad = ~(np.abs(v) <= 2.0**53) | (v != np.round(v)) if whole else np.isinf(v)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            what = "a whole number" if whole else "a finite number or empty"
            raise InputError(f"{name} must be {what}, got {col[name][i]!r}", source=path, line=int(lines[i]), field=name)
        return v.astype(np.int64) if whole else v

    source = np.array(col["source"], dtype=object)
    bad = ~np.isin(source.astype(str), SOURCES)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"source must be one of {', '.join(SOURCES)}, got {source[i]!r}", source=path,
                         line=int(lines[i]), field="source")
    out = {
        "frame": num("frame", True),
        "track_id": num("track_id", True),
        "xyz": np.column_stack([num("x"), num("y"), num("z")]) if body else np.zeros((0, 3)),
        "source": source,
    }
    for extra in ("top_z", "bottom_z"):
        if extra in columns:
            out[extra] = num(extra)
    if "n_views" in columns:
        out["n_views"] = num("n_views", True)
    return out


# ----------------------------------------------------------------------------- reading a whole folder
@dataclass(frozen=True, eq=False)
class OutputColumns:
    """3D points read back from ``tracks_3d.csv`` or ``target_3d.csv``.

    frame (N,) int64, track_id (N,) int64, xyz (N, 3) metres, source (N,) str; for
    ``tracks_3d.csv`` also top_z, bottom_z (N,) metres and n_views (N,) int64 (None for the target).
    """

    frame: np.ndarray
    track_id: np.ndarray
    xyz: np.ndarray
    source: np.ndarray
    top_z: np.ndarray | None = None
    bottom_z: np.ndarray | None = None
    n_views: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.frame)


@dataclass(frozen=True, eq=False)
class OutputFolder:
    """An output folder of ``gymtrack track`` read back, shaped like a ``TrackResult``.

    tracks, target: :class:`OutputColumns`; boxes, target_boxes: :class:`Detections` of
    ``tracks_2d/`` and ``target_2d/`` (centre form, ``track_id`` = 3D track id) over
    ``camera_names``; summary: ``summary.json`` ({} when absent); extra_files: per-camera files
    for cameras not in ``camera_names`` (listed, not read).
    """

    path: Path
    tracks: OutputColumns
    boxes: Detections
    target: OutputColumns
    target_boxes: Detections
    camera_names: tuple[str, ...]
    summary: dict = field(default_factory=dict)
    extra_files: tuple[Path, ...] = ()


def _columns(d: dict) -> OutputColumns:
    return OutputColumns(d["frame"], d["track_id"], d["xyz"], d["source"], d.get("top_z"), d.get("bottom_z"), d.get("n_views"))


def _read_boxes(folder: Path, names: tuple[str, ...]) -> tuple[Detections, list[Path]]:
    from .motchallenge import read_detections

    if not folder.is_dir():
        raise InputError(f"folder {folder.name}/ not found (one MOTChallenge file per camera expected)", source=folder)
    parts = []
    for c, name in enumerate(names):
        p = folder / f"{name}.txt"
        if not p.is_file():
            raise InputError(f"no file for camera {name!r} (cameras: {', '.join(names)})", source=p)
        parts.append(read_detections(p, c, names)[0])
    extra = sorted(p for p in folder.glob("*.txt") if p.stem not in names)
    return (Detections.concat(parts).sorted() if parts else Detections.empty(names)), extra


def read_outputs(out: str | Path, camera_names: Sequence[str]) -> OutputFolder:
    """Read what :func:`write_outputs` wrote under ``out`` for the cameras ``camera_names``.

    Every file but ``summary.json`` is required; a missing or malformed one is an
    :class:`InputError` naming it. Numbers come back with the files' precision (4 decimals
    for metres, 2 for pixels).
    """
    out = Path(out)
    if not out.is_dir():
        raise InputError("output folder not found", source=out)
    names = tuple(camera_names)
    tracks, target = _columns(read_tracks_3d(out / "tracks_3d.csv")), _columns(read_target_3d(out / "target_3d.csv"))
    boxes, extra1 = _read_boxes(out / "tracks_2d", names)
    target_boxes, extra2 = _read_boxes(out / "target_2d", names)
    summary: dict = {}
    sp = out / "summary.json"
    if sp.is_file():
        try:
            summary = json.loads(sp.read_text())
        except json.JSONDecodeError as exc:
            raise InputError(f"not valid JSON: {exc.msg}", source=sp, line=exc.lineno) from None
    return OutputFolder(out, tracks, boxes, target, target_boxes, names, summary, tuple(extra1 + extra2))
