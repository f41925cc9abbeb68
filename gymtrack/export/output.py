"""``gymtrack export``'s work: an output folder's skeleton to TRC, C3D, MOT or BVH files, written atomically.

Rule: ``shared/formats.md``, "Exports" (the paper's 3D pose of Section III-D, last paragraph, and
the analysis stage's angles, for the tools biomechanists and animators use). Reads
``<out>/poses_3d.csv`` (``gymtrack pose``) -- the target's rows, picked by ``target_3d.csv`` when
the file holds every track -- or ``<out>/analysis/angles.csv`` (``gymtrack analyse``) for MOT.

Files: ``<out>/export/target.<format>`` (``track<id>`` per track with ``all_tracks``), or the
name given; a track cut by a gap longer than 0.5 s (TRC, BVH) gets ``_part<k>`` files. Every file
is written under a temporary name beside its place and renamed into it only when all are
written; an existing file (or a part left by an earlier export under the same name) is replaced
only with ``overwrite``.
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import InputError
from ..formats.atomic import read_marker
from ..poses import Poses3D
from . import bvh as _bvh
from .series import MAX_GAP_S, TrackSeries, complete_parts, fill_gaps, track_series

__all__ = ["FORMATS", "ExportResult", "export_output", "resolve_fps"]

FORMATS: tuple[str, ...] = ("trc", "c3d", "mot", "bvh")
#: a frame's bones are "steady" when every length is within this of the rig's median (m): a quarter
#: millimetre, so that along the longest chain (4 bones, hip to wrist) the rig is within 1 mm
STEADY_M = 2.5e-4


@dataclass
class ExportResult:
    """What an export wrote and did: ``files``, ``lines`` (what the command prints), and counts:
    gaps / cells interpolated, parts, frames left out (in no part), invalid C3D points, NaN MOT
    cells, the BVH rig's largest forward-kinematics error (m) over all frames and over the frames
    whose bone lengths are within :data:`STEADY_M` of the rig's (and how many frames each)."""

    files: list[Path] = field(default_factory=list)
    lines: list[str] = field(default_factory=list)
    fk_errors: list = field(default_factory=list)  # per part: the joint errors (m) in frames not steady
    counts: dict = field(default_factory=lambda: {"gaps_filled": 0, "cells_filled": 0, "parts": 0, "frames_cut": 0,
                                                  "invalid": 0, "nan_cells": 0, "fk_max_m": 0.0,
                                                  "fk_steady_max_m": 0.0, "fk_frames_steady": 0, "fk_frames_other": 0,
                                                  "fk_other_median_m": 0.0})


def resolve_fps(out: Path, fps: float | None = None, routine: Path | None = None) -> tuple[float, str]:
    """The frame rate and where it came from: ``fps``, else ``routine``'s scene.yaml, else the
    scene.yaml of the routine the output's marker names, else ``analysis/elements.json``."""
    from ..formats.scene import load_scene

    if fps is not None:
        if not fps > 0:
            raise InputError(f"must be > 0, got {fps}", field="--fps")
        return float(fps), "--fps"
    candidates = []
    if routine is not None:
        candidates.append(Path(routine) / "scene.yaml")
    m = read_marker(out) or {}
    r = (m.get("inputs") or {}).get("routine")
    if r:
        candidates.append(Path(r) / "scene.yaml")
    for sc in candidates:
        if sc.is_file():
            return float(load_scene(sc).fps), str(sc)
        if routine is not None and sc == candidates[0]:
            raise InputError("no scene.yaml in the routine folder given by --routine", source=sc)
    el = out / "analysis" / "elements.json"
    if el.is_file():
        try:
            v = json.loads(el.read_text()).get("fps")
        except (ValueError, AttributeError):
            v = None
        if isinstance(v, (int, float)) and v > 0:
            return float(v), str(el)
    raise InputError("the frame rate is unknown (the output names no routine with a scene.yaml); "
                     "give --fps or --routine ROUTINE", source=out)


# ----------------------------------------------------------------------------- inputs
def _read_poses(out: Path, all_tracks: bool) -> list[tuple[str, Poses3D, int | None]]:
    """(file stem, poses, track id) per skeleton to export: the target, or every track."""
    from ..formats.outputs import of_target, read_target_3d
    from ..formats.poses3d import read_poses_3d

    src = out / "poses_3d.csv"
    if not src.is_file():
        raise InputError("no poses_3d.csv: run `gymtrack pose <routine> <out>` first (after `gymtrack track`)", source=out)
    poses = read_poses_3d(src)
    if len(poses) == 0:
        raise InputError("no 3D pose to export (the file has no rows)", source=src)
    if all_tracks:
        return [(f"track{t}", poses, int(t)) for t in np.unique(poses.track_id)]
    if np.unique(poses.frame).size != len(poses):  # every track's poses: the target's rows by target_3d.csv
        tp = out / "target_3d.csv"
        if not tp.is_file():
            raise InputError("poses_3d.csv holds several tracks a frame and target_3d.csv is missing: "
                             "pass --all-tracks, or run `gymtrack track` again", source=tp)
        t = read_target_3d(tp)
        poses = poses.subset(of_target(poses.frame, poses.track_id, t))
        if len(poses) == 0:
            raise InputError("no pose of the target: no (frame, track_id) of target_3d.csv has one; "
                             "pass --all-tracks to export every track", source=src)
    return [("target", poses, None)]


# ----------------------------------------------------------------------------- writing
class _Staged:
    """Files written under temporary names, renamed into place together (or all removed)."""

    def __init__(self, overwrite: bool) -> None:
        self.overwrite, self.items = overwrite, []  # (final, temp)

    def path(self, final: Path) -> Path:
        tmp = final.with_name(f".{final.stem}.gymtrack-tmp-{os.getpid()}{final.suffix}")  # ezc3d wants .c3d
        self.items.append((final, tmp))
        return tmp

    def check(self, finals: list[Path], stale: list[Path]) -> None:
        clash = [p for p in finals if p.exists()] + [p for p in stale if p not in finals]
        if clash and not self.overwrite:
            more = f" (and {len(clash) - 1} more)" if len(clash) > 1 else ""
            raise InputError(f"already exists{more}; pass --overwrite to replace it", source=clash[0])
        for p in {p.parent for p in finals}:
            try:
                p.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise InputError(f"cannot create the folder: {exc.strerror or exc}", source=p) from None

    def commit(self, stale: list[Path]) -> None:
        for final, tmp in self.items:
            os.replace(tmp, final)
        finals = {f for f, _ in self.items}
        for p in stale:
            if p not in finals:
                p.unlink(missing_ok=True)

    def abort(self) -> None:
        for _, tmp in self.items:
            tmp.unlink(missing_ok=True)


def _names(dest: Path | None, out: Path, stem: str, n_tracks: int) -> tuple[Path, str]:
    """(folder, stem) of one track's files."""
    if dest is None:
        return out / "export", stem
    if dest.is_dir():  # -o a folder: the default names in it
        return dest, stem
    return dest.parent, (dest.stem if n_tracks == 1 else f"{dest.stem}_{stem}")


def _stale(folder: Path, stem: str, suffix: str) -> list[Path]:
    """Files an earlier export of this name left: ``stem.suffix`` and ``stem_part<k>.suffix``."""
    if not folder.is_dir():
        return []
    pat = re.compile(re.escape(stem) + r"(_part\d+)?" + re.escape(suffix) + "$")
    return sorted(p for p in folder.iterdir() if pat.match(p.name))


def _frames_text(frames: np.ndarray, parts: list[slice]) -> str:
    return ", ".join(f"{frames[s.start]}-{frames[s.stop - 1]}" for s in parts)


def _series_files(series: TrackSeries, fmt: str, fps: float, folder: Path, stem: str,
                  res: ExportResult) -> list[tuple[Path, Callable[[Path], None]]]:
    """The files of one track for trc / bvh / c3d: (final path, writer of a temp path)."""
    from .c3d import write_c3d
    from .trc import write_trc

    label = "target" if series.track_id is None else f"track {series.track_id}"
    if fmt == "c3d":
        def w(tmp: Path) -> None:
            _, bad = write_c3d(tmp, int(series.frames[0]), series.xyz, series.joints, fps)
            res.counts["invalid"] += bad
            res.lines.append(f"{label}: {len(series.frames)} frames x {len(series.joints)} joints; "
                             f"{bad} without an estimate written as invalid (residual -1)")
        return [(folder / f"{stem}.c3d", w)]
    keep = [k for k in range(len(series.joints)) if np.isfinite(series.xyz[:, k]).all(-1).any()]
    joints = tuple(series.joints[k] for k in keep)
    if fmt == "bvh":  # the rig's joints: the body, and the face when the track has all five
        face = _bvh.FACE_JOINTS if all(n in joints for n in _bvh.FACE_JOINTS) else ()
        names = [n for n in _bvh.BODY_JOINTS + face if n in joints]
        keep = [series.joints.index(n) for n in names]
        joints = tuple(names)
    dropped = [n for n in series.joints if n not in joints]
    xyz = series.xyz[:, keep]
    filled, gf = fill_gaps(xyz, int(np.floor(MAX_GAP_S * fps + 1e-9)))
    parts = complete_parts(filled)
    cut = len(series.frames) - sum(s.stop - s.start for s in parts)
    res.counts["gaps_filled"] += gf.gaps
    res.counts["cells_filled"] += gf.cells
    res.counts["parts"] += len(parts)
    res.counts["frames_cut"] += cut
    msg = f"{label}: {len(series.frames)} frames; {gf.gaps} gaps up to {MAX_GAP_S:g} s interpolated ({gf.cells} joint-frames)"
    if len(parts) > 1 or cut:
        msg += (f"; gaps longer than {MAX_GAP_S:g} s split it into {len(parts)} parts (frames {_frames_text(series.frames, parts)}), "
                f"{cut} frames in no part")
    if dropped:
        msg += f"; left out: {', '.join(dropped)}" + (" (never estimated)" if fmt == "trc" else "")
    res.lines.append(msg)
    if not parts:
        return []
    rig = _bvh.fit_rig(xyz, joints) if fmt == "bvh" else None
    out = []
    for k, s in enumerate(parts, 1):
        name = f"{stem}.{fmt}" if len(parts) == 1 else f"{stem}_part{k}.{fmt}"
        fr, xs = series.frames[s], filled[s]
        if fmt == "trc":
            out.append((folder / name, lambda tmp, fr=fr, xs=xs: write_trc(tmp, fr, xs, joints, fps)))
        else:
            def wb(tmp: Path, xs=xs) -> None:
                m = _bvh.solve_motion(rig, xs, joints)
                every = _bvh.fk_error(rig, m, xs, joints)  # (T, J)
                err = np.nanmax(every, axis=1)  # (T,)
                steady = _bvh.bone_deviation(rig, xs, joints) < STEADY_M
                c = res.counts
                res.fk_errors.append(every[~steady][np.isfinite(every[~steady])])
                c["fk_frames_steady"] += int(steady.sum())
                c["fk_frames_other"] += int((~steady).sum())
                c["fk_steady_max_m"] = max(c["fk_steady_max_m"], float(err[steady].max(initial=0.0)))
                c["fk_max_m"] = max(c["fk_max_m"], float(err.max(initial=0.0)))
                _bvh.write_bvh(tmp, rig, m, fps)
            out.append((folder / name, wb))
    if fmt == "bvh":
        res.lines.append(f"{label}: rig of median bone lengths ({', '.join(f'{b} {v:.3f} m' for b, v in rig.lengths.items())})")
    return out


def export_output(out: str | Path, fmt: str, all_tracks: bool = False, dest: str | Path | None = None,
                  overwrite: bool = False, fps: float | None = None, routine: str | Path | None = None) -> ExportResult:
    """Export the output folder ``out`` as ``fmt`` (one of :data:`FORMATS`); see the module doc."""
    out = Path(out)
    fmt = fmt.lower()
    if fmt not in FORMATS:
        raise InputError(f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}", field="--format")
    if not out.is_dir():
        raise InputError("output folder not found (run `gymtrack track` and `gymtrack pose` into it first)", source=out)
    dest = None if dest is None else Path(dest)
    res = ExportResult()
    stage = _Staged(overwrite)
    if fmt == "mot":
        src = _angles_file(out, all_tracks)
        rate, where = resolve_fps(out, fps, None if routine is None else Path(routine))
        jobs = _mot_jobs(src, out, dest, res, rate)
    else:
        tracks = _read_poses(out, all_tracks)
        rate, where = resolve_fps(out, fps, None if routine is None else Path(routine))
        jobs = []
        for stem, poses, tid in tracks:
            folder, name = _names(dest, out, stem, len(tracks))
            jobs.append((folder, name, _series_files(track_series(poses, tid), fmt, rate, folder, name, res)))
    res.lines.insert(0, f"frame rate {rate:g} fps (from {where})")
    finals = [f for _, _, files in jobs for f, _ in files]
    stale = [p for folder, name, _ in jobs for p in _stale(folder, name, f".{fmt}")]
    stage.check(finals, stale)
    try:
        for _, _, files in jobs:
            for final, write in files:
                write(stage.path(final))
        stage.commit(stale)
    except BaseException:
        stage.abort()
        raise
    res.files = finals
    if res.fk_errors and sum(e.size for e in res.fk_errors):
        res.counts["fk_other_median_m"] = float(np.median(np.concatenate(res.fk_errors)))
    return res


def _angles_file(out: Path, all_tracks: bool) -> Path:
    if all_tracks:
        raise InputError("the analysis stage measures the target only: --all-tracks does not apply to --format mot",
                         field="--all-tracks")
    src = out / "analysis" / "angles.csv"
    if not src.is_file():
        raise InputError("no analysis/angles.csv: run `gymtrack analyse <routine> <out>` first", source=out)
    return src


def _mot_jobs(src: Path, out: Path, dest: Path | None, res: ExportResult, rate: float) -> list:
    from ..formats.elements import read_angles
    from .mot import write_mot

    angles = read_angles(src)
    folder, stem = _names(dest, out, "target", 1)

    def w(tmp: Path) -> None:
        _, nan = write_mot(tmp, angles, rate)
        res.counts["nan_cells"] += nan
        res.lines.append(f"target: {len(angles['frame'])} rows of joint angles from {src}; "
                         f"{nan} measures that could not be computed written as NaN")
    return [(folder, stem, [(folder / f"{stem}.mot", w)])]
