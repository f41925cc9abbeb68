"""Reading the simulator's 3D joint ground truth, ``gt/keypoints_3d.csv``.

Paper: Section III-D and Fig. 7-8 (the 3D pose triangulated from the 2D keypoints of the
target's boxes); the pose error is measured against these joints, and the simulated
pose model needs every person's joints to show the person a crop really holds.

Format (``shared/formats.md``): a header ``frame,person_id,joint,x,y,z`` then one row per
(frame, person, COCO-17 joint), world metres; a person has rows only at frames where they
exist. Returned dense: frames (T,) the sorted distinct frame numbers, person_id (P,) sorted,
joints (P, T, 17, 3) with NaN where a row is absent.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..skeletons import COCO17_JOINTS
from .textfile import read_text

HEADER = ("frame", "person_id", "joint", "x", "y", "z")


_CODE = 1_000_000  # joint names become _CODE + index in the fast path


def _fast(text: str) -> np.ndarray | None:
    """(R, 6) float rows of a well-formed file (joint column = _CODE + joint index) parsed in C,
    or None when anything is unusual (then the checking path finds and names the problem)."""
    body = text.split("\n", 1)[1] if "\n" in text else ""
    for i, name in sorted(enumerate(COCO17_JOINTS), key=lambda x: -len(x[1])):
        body = body.replace(f",{name},", f",{_CODE + i},")
    body = body.strip()
    if not body:
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            v = np.fromstring(body.replace("\n", ","), sep=",")
        except (ValueError, DeprecationWarning):
            return None
    n = body.count("\n") + 1
    if v.size != 6 * n:
        return None
    v = v.reshape(n, 6)
    j = v[:, 2] - _CODE
    whole = np.all(np.abs(v[:, :2]) <= 2.0**53) and np.all(v[:, :2] == np.round(v[:, :2]))
    if not whole or np.any((j < 0) | (j > 16) | (j != np.round(j))) or np.isinf(v[:, 3:]).any():
        return None
    v[:, 2] = j
    return v


def _rows(path: Path, lines: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """(R, 6) string fields and (R,) 1-based line numbers of ``lines`` after the header."""
    keep = [k for k in range(1, len(lines)) if lines[k].strip()]
    parts = [lines[k].split(",") for k in keep]
    bad = [i for i, p in enumerate(parts) if len(p) != 6]
    if bad:
        i = bad[0]
        raise InputError(f"expected 6 comma-separated values (frame,person_id,joint,x,y,z), got {len(parts[i])}",
                         source=path, line=keep[i] + 1)
    arr = np.array(parts, dtype=str).reshape(-1, 6)
    return np.char.strip(arr), np.array(keep, dtype=np.int64) + 1


def _numbers(col: np.ndarray, lines: np.ndarray, name: str, path: Path, integer: bool) -> np.ndarray:
    try:
        v = col.astype(np.float64)
    except ValueError:
        v = None
    if v is not None and integer:
        v_ok = (np.abs(v) <= 2.0**53) & (v == np.round(v))  # (NaN fails both)
    elif v is not None:
        v_ok = ~np.isinf(v)
    if v is None or not np.all(v_ok):
        for s, ln in zip(col, lines):  # find the first bad value for the message
            try:
                x = float(s)
            except ValueError:
                x = None
            if x is None or np.isinf(x) or (integer and (not np.isfinite(x) or x != round(x) or abs(x) > 2.0**53)):
                what = "a whole number" if integer else "a number"
                raise InputError(f"{name} must be {what}, got {s!r}", source=path, line=int(ln), field=name)
    return v.astype(np.int64) if integer else v


def _checked(path: Path, lines: list[str]):
    """The slow path: every field checked, the first bad one named by line."""
    f, ln = _rows(path, lines)
    frame = _numbers(f[:, 0], ln, "frame", path, True)
    pid = _numbers(f[:, 1], ln, "person_id", path, True)
    xyz = np.column_stack([_numbers(f[:, k], ln, n, path, False) for k, n in ((3, "x"), (4, "y"), (5, "z"))]).reshape(-1, 3)
    names = np.asarray(COCO17_JOINTS)
    order = np.argsort(names)
    pos = np.clip(np.searchsorted(names[order], f[:, 2]), 0, names.size - 1)
    ok = names[order][pos] == f[:, 2]
    if not np.all(ok):
        i = int(np.flatnonzero(~ok)[0])
        raise InputError(f"joint must be a COCO-17 joint name (nose, left_eye, ..., right_ankle), got {f[i, 2]!r}",
                         source=path, line=int(ln[i]), field="joint")
    return frame, pid, order[pos], xyz, ln


def read_keypoints_3d(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read ``gt/keypoints_3d.csv``.

    Returns ``frames`` (T,) int64 sorted, ``person_id`` (P,) int64 sorted and ``joints``
    (P, T, 17, 3) float64 COCO-17 world joints, NaN where absent.

    Raises InputError naming the file and line for a missing file or header, a row without six
    fields, a frame or person id that is not a whole number, a joint not of COCO-17, a
    coordinate that is not a number, or a (frame, person, joint) given twice.
    """
    path = Path(path)
    text = read_text(path)
    first = text.split("\n", 1)[0]
    if tuple(c.strip() for c in first.split(",")) != HEADER:
        raise InputError(f"expected the header {','.join(HEADER)!r}, got {first or 'an empty file'!r}", source=path, line=1)
    v = _fast(text)
    if v is not None:
        frame, pid, ji, xyz = v[:, 0].astype(np.int64), v[:, 1].astype(np.int64), v[:, 2].astype(np.int64), v[:, 3:]
        lines = np.arange(2, len(v) + 2)
    else:
        frame, pid, ji, xyz, lines = _checked(path, text.splitlines())
    frames, ti = np.unique(frame, return_inverse=True)
    names = np.asarray(COCO17_JOINTS)
    persons, pi = np.unique(pid, return_inverse=True)
    flat = (pi * frames.size + ti) * 17 + ji
    u, first, count = np.unique(flat, return_index=True, return_counts=True)
    if np.any(count > 1):
        k = u[np.flatnonzero(count > 1)[0]]
        dup = np.flatnonzero(flat == k)
        raise InputError(f"frame {frame[dup[0]]}, person {pid[dup[0]]}, joint {names[ji[dup[0]]]} is given twice "
                         f"(lines {lines[dup[0]]} and {lines[dup[1]]})", source=path, line=int(lines[dup[1]]))
    joints = np.full((persons.size, frames.size, 17, 3), np.nan)
    joints.reshape(-1, 3)[flat] = xyz
    return frames.astype(np.int64), persons.astype(np.int64), joints
