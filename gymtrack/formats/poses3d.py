"""``poses_3d.csv``: the 3D poses the pose stage writes (``shared/formats.md``, pose stage outputs).

Paper: Section III-D, last paragraph -- the 3D pose triangulated from the 2D keypoints a pose
model finds in the target's expanded boxes; this is its file form.

::

    frame,track_id,joint,x,y,z,score,n_views,reproj_px,how

One line per estimated joint of a :class:`gymtrack.poses.Poses3D` row (a joint that could not be
estimated has no line); metres with 4 decimals, score with 3, reprojection error in pixels with
2 (empty when unknown). ``how`` (triangulated | plane | fused) is gymtrack's addition to the
formats.md columns: the issue asks to report per joint which way it was estimated. The reader
also takes the 9 formats.md columns without it (``how`` then reads as ``none``).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Sequence

import numpy as np

from ..errors import InputError
from ..poses import HOW_NAMES, HOW_NONE, Poses3D
from ..skeletons import SKELETONS, Skeleton, custom_skeleton
from .textfile import fixed as _fmt, read_text

__all__ = ["POSES_3D_COLUMNS", "write_poses_3d", "read_poses_3d"]

POSES_3D_COLUMNS: tuple[str, ...] = ("frame", "track_id", "joint", "x", "y", "z", "score", "n_views", "reproj_px", "how")


def write_poses_3d(path: str | Path, poses: Poses3D) -> Path:
    """Write ``poses_3d.csv`` (rows ordered by frame, track, joint); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    p = poses.sorted()
    ok = np.all(np.isfinite(p.xyz), axis=-1)  # (M, J) joints estimated
    r, j = np.nonzero(ok)
    names = np.asarray(p.skeleton.joints, dtype=object)
    how = np.asarray(HOW_NAMES, dtype=object)[p.how[r, j].astype(np.int64)]
    xyz = p.xyz[r, j]
    cols = [p.frame[r].tolist(), p.track_id[r].tolist(), names[j].tolist(), _fmt(xyz[:, 0], 4), _fmt(xyz[:, 1], 4),
            _fmt(xyz[:, 2], 4), _fmt(p.score[r, j], 3), p.n_views[r, j].tolist(), _fmt(p.reproj_px[r, j], 2), how.tolist()]
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(POSES_3D_COLUMNS)
        w.writerows(zip(*cols))
    return path


def _skeleton_for(names: Sequence[str], path: Path) -> Skeleton:
    """The named skeleton holding every joint name (the smallest), else a custom one in file order."""
    have = set(names)
    fits = [s for s in SKELETONS.values() if have <= set(s.joints)]
    if fits:
        return min(fits, key=lambda s: len(s.joints))
    try:
        return custom_skeleton(list(dict.fromkeys(names)))
    except InputError as e:  # e.g. an empty joint name: the file and the column named
        raise InputError(e.problem, source=path, field="joint") from None


def read_poses_3d(path: str | Path, skeleton: Skeleton | None = None) -> Poses3D:
    """Read ``poses_3d.csv`` back into a :class:`Poses3D` (one row per (frame, track_id)).

    skeleton: the joint layout; by default the smallest of coco17 / body25 / halpe26 that names
    every joint in the file, else a custom skeleton of the file's joint names. Raises
    InputError naming the line for a wrong header, column count, number, unknown joint or
    ``how``, or a (frame, track_id, joint) given twice.
    """
    path = Path(path)
    reader = csv.reader(io.StringIO(read_text(path), newline=""))
    try:
        rows = list(reader)
    except csv.Error as exc:
        raise InputError(f"not CSV: {exc}", source=path, line=reader.line_num) from None
    if not rows:
        raise InputError(f"empty file; expected the header {','.join(POSES_3D_COLUMNS)}", source=path, line=1)
    header = tuple(rows[0])
    if header not in (POSES_3D_COLUMNS, POSES_3D_COLUMNS[:-1]):
        raise InputError(f"expected the header {','.join(POSES_3D_COLUMNS)} (how optional)", source=path, line=1)
    body = rows[1:]
    ncol = len(header)
    for i, r in enumerate(body):
        if len(r) != ncol:
            raise InputError(f"expected {ncol} values, got {len(r)}", source=path, line=i + 2)
    names = [r[2] for r in body]
    if skeleton is None:
        skeleton = _skeleton_for(names, path)
    pos = {n: k for k, n in enumerate(skeleton.joints)}
    for i, n in enumerate(names):
        if n not in pos:
            raise InputError(f"joint {n!r} is not in the {skeleton.name} skeleton", source=path, line=i + 2, field="joint")

    def num(k: int, name: str) -> np.ndarray:
        out = np.empty(len(body))
        for i, r in enumerate(body):
            try:
                out[i] = float(r[k]) if r[k] != "" else np.nan
            except ValueError:
                raise InputError(f"{name} must be a number, got {r[k]!r}", source=path, line=i + 2, field=name) from None
        return out

    frame, track = num(0, "frame"), num(1, "track_id")
    for col, name in ((frame, "frame"), (track, "track_id")):
        bad = np.flatnonzero(~(np.abs(col) <= 2.0**53) | (col != np.round(col)))
        if bad.size:
            raise InputError(f"{name} must be a whole number", source=path, line=int(bad[0]) + 2, field=name)
    xyz = np.column_stack([num(3, "x"), num(4, "y"), num(5, "z")]) if body else np.zeros((0, 3))
    bad = np.flatnonzero(~np.all(np.isfinite(xyz), axis=1))
    if bad.size:
        raise InputError("x, y, z must be numbers (a joint not estimated has no line)", source=path, line=int(bad[0]) + 2)
    score, n_views, reproj = num(6, "score"), num(7, "n_views"), num(8, "reproj_px")
    for col, name, bad in ((score, "score", np.isinf(score)), (reproj, "reproj_px", np.isinf(reproj)),
                           (n_views, "n_views", ~(np.isnan(n_views) | ((n_views >= 0) & (n_views <= 2**31)
                                                                       & (n_views == np.round(n_views)))))):
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"{name} must be {'a whole number >= 0' if name == 'n_views' else 'finite'} or empty, "
                             f"got {body[i][POSES_3D_COLUMNS.index(name)]!r}", source=path, line=i + 2, field=name)
    how = np.full(len(body), HOW_NONE, np.int8)
    if ncol == len(POSES_3D_COLUMNS):
        code = {n: k for k, n in enumerate(HOW_NAMES)}
        for i, r in enumerate(body):
            if r[9] not in code:
                raise InputError(f"how must be one of {', '.join(HOW_NAMES)}, got {r[9]!r}", source=path, line=i + 2, field="how")
            how[i] = code[r[9]]
    j = np.array([pos[n] for n in names], np.int64)
    key = np.column_stack([frame, track]).astype(np.int64) if body else np.zeros((0, 2), np.int64)
    uniq, row = np.unique(key, axis=0, return_inverse=True)
    row = row.reshape(-1)
    flat = row * len(skeleton.joints) + j
    u, first, cnt = np.unique(flat, return_index=True, return_counts=True)
    if np.any(cnt > 1):
        dup = np.flatnonzero(flat == u[np.argmax(cnt > 1)])[1]
        raise InputError("this (frame, track_id, joint) is given twice", source=path, line=int(dup) + 2)
    M, J = len(uniq), len(skeleton.joints)
    out_xyz = np.full((M, J, 3), np.nan)
    out_score, out_reproj = np.zeros((M, J)), np.full((M, J), np.nan)
    out_views, out_how = np.zeros((M, J), np.int64), np.zeros((M, J), np.int8)
    out_xyz[row, j], out_score[row, j], out_reproj[row, j] = xyz, np.nan_to_num(score), reproj
    out_views[row, j] = np.nan_to_num(n_views).astype(np.int64)
    out_how[row, j] = how
    return Poses3D(uniq[:, 0], uniq[:, 1], out_xyz, out_score, out_views, out_reproj, out_how, skeleton)
