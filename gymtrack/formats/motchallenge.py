"""MOTChallenge text files: per-camera detections in, tracks and ground-truth boxes out.

Paper: Section III-A, the boxes ``b_{t,c,i} = [x, y, w, h]`` of every view ``c`` at frame ``t``
that the tracker starts from. Files carry MOTChallenge lines
``frame, id, bb_left, bb_top, bb_width, bb_height, conf, x, y, z`` (top-left form); inside the
code boxes are centre form (:mod:`gymtrack.detections`).

Frame numbers are checked, never allocated over: memory and time follow the lines, not the
frame range. A frame above :data:`MAX_FRAME` (10^8: 38 days at 30 fps -- a corrupt or mistyped
line, not a recording) is an error naming the line; long pauses are accepted and reported
(``ReadReport.largest_gap`` and its line; :meth:`ReadReport.gap_warning` words it at the
scene's fps), since the tracker skips them at no cost.

Parsing is vectorised: the non-blank lines are parsed at once by numpy's C text reader
(``np.loadtxt``); Python only touches a line again to name it in an error message.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from ..detections import Detections, tlwh_to_xywh, xywh_to_tlwh
from ..errors import DetectionFormatError
from .textfile import read_text

MIN_COLUMNS = 6
MAX_COLUMNS = 10
#: the largest frame number accepted (10^8 frames: 38 days at 30 fps)
MAX_FRAME = 10**8
#: seconds: a pause between two frames with boxes longer than this is worth a warning
LONG_GAP_SECONDS = 3600.0


@dataclass
class ReadReport:
    """What reading one MOTChallenge file found.

    Attributes
    ----------
    path: the file.
    camera: the camera name the boxes were assigned to ('' when not given).
    lines: non-blank lines read (one box each).
    boxes: boxes returned.
    columns: columns per line (6..10; 0 for an empty file).
    unsorted_lines: lines whose frame is smaller than the line before (accepted; the boxes are
        returned sorted by frame).
    frame_zero_lines: lines with frame 0 (MOTChallenge frames are 1-based; accepted as is).
    skipped: reason -> count of lines not turned into boxes (blank lines).
    frames: distinct frames with at least one box.
    frame_range: (first, last) frame, or None for no boxes.
    largest_gap: the most frames without a box between two frames with boxes (0: none).
    largest_gap_line: the line of the first box after that gap (0: no gap).
    """

    path: Path
    camera: str = ""
    lines: int = 0
    boxes: int = 0
    columns: int = 0
    unsorted_lines: int = 0
    frame_zero_lines: int = 0
    skipped: dict[str, int] = field(default_factory=dict)
    frames: int = 0
    frame_range: tuple[int, int] | None = None
    largest_gap: int = 0
    largest_gap_line: int = 0

    def gap_warning(self, fps: float, seconds: float = LONG_GAP_SECONDS) -> str | None:
        """A message naming the file and line when the largest gap exceeds ``seconds`` at ``fps``."""
        if self.largest_gap <= seconds * fps:
            return None
        return (f"{self.path}, line {self.largest_gap_line}: {self.largest_gap} frames without a box before this "
                f"line ({self.largest_gap / fps / 3600:.1f} h at {fps:g} fps); a wrong frame number?")


def _split_lines(path: Path, text: str) -> tuple[list[str], np.ndarray, int]:
    """Non-blank lines, their 1-based line numbers (array) and the number of blank lines."""
    raw = text.splitlines()
    keep = [i for i, s in enumerate(raw) if s.strip()]
    lines = [raw[i] for i in keep]
    return lines, np.asarray(keep, dtype=np.int64) + 1, len(raw) - len(keep)


def _locate_bad_number(path: Path, lines: list[str], lineno: np.ndarray) -> DetectionFormatError:
    """The first line holding something that is not a number (slow path, errors only)."""
    for s, n in zip(lines, lineno):
        for k, tok in enumerate(s.split(",")):
            try:
                float(tok)
            except ValueError:
                return DetectionFormatError(f"column {k + 1} is not a number: {tok.strip()!r}", source=path, line=int(n))
    return DetectionFormatError("could not read the numbers", source=path)


def parse_mot_table(path: str | Path, text: str | None = None, min_columns: int = MIN_COLUMNS) -> tuple[np.ndarray, np.ndarray, ReadReport]:
    """Parse a MOTChallenge-style text file into a float table.

    Parameters
    ----------
    path: the file (read unless ``text`` is given; then only used in messages).
    text: the file's content, when already in memory.
    min_columns: fewest columns a line may have (at most 10).

    Returns
    -------
    table: (L, C) float64, one row per non-blank line, in file order.
    lineno: (L,) int64 1-based line numbers of the rows.
    report: a :class:`ReadReport` with ``lines``, ``columns`` and blank lines in ``skipped``.

    Every line must have the same number of comma-separated columns (whitespace around values is
    accepted); a line with another count or a value that is not a number raises
    DetectionFormatError naming the line.
    """
    path = Path(path)
    if text is None:
        text = read_text(path, DetectionFormatError)
    lines, lineno, blank = _split_lines(path, text)
    report = ReadReport(path=path, skipped={"blank line": blank} if blank else {})
    if not lines:
        return np.zeros((0, min_columns)), lineno, report
    ncols = np.fromiter((s.count(",") for s in lines), np.int64, len(lines)) + 1
    ncol = int(ncols[0])
    if not min_columns <= ncol <= MAX_COLUMNS:
        raise DetectionFormatError(
            f"has {ncol} comma-separated columns; expected {min_columns} to {MAX_COLUMNS} "
            "(frame, id, bb_left, bb_top, bb_width, bb_height[, conf, x, y, z])",
            source=path, line=int(lineno[0]),
        )
    bad = np.flatnonzero(ncols != ncol)
    if bad.size:
        i = int(bad[0])
        raise DetectionFormatError(
            f"has {int(ncols[i])} columns, but line {int(lineno[0])} has {ncol}; every line needs the same columns",
            source=path, line=int(lineno[i]),
        )
    try:  # numpy's C reader; comments=None so a '#' is an error, not a silently cut line
        table = np.loadtxt(io.StringIO("\n".join(lines)), delimiter=",", comments=None, ndmin=2, dtype=np.float64)
    except ValueError:
        raise _locate_bad_number(path, lines, lineno) from None
    if table.shape != (len(lines), ncol):  # pragma: no cover - the column counts were checked above
        raise DetectionFormatError(f"read {table.shape} values, expected {(len(lines), ncol)}", source=path)
    report.lines = len(lines)
    report.columns = ncol
    return table, lineno, report


def _check_integer_column(table: np.ndarray, col: int, what: str, path: Path, lineno: np.ndarray) -> np.ndarray:
    v = table[:, col]
    bad = np.flatnonzero(~np.isfinite(v) | (v != np.round(v)) | (np.abs(v) > 2.0**53))
    if bad.size:
        i = int(bad[0])
        raise DetectionFormatError(f"{what} must be a whole number, got {float(v[i])!r}", source=path, line=int(lineno[i]))
    return v.astype(np.int64)


def _check_boxes(table: np.ndarray, path: Path, lineno: np.ndarray) -> None:
    tlwh = table[:, 2:6]
    bad = np.flatnonzero(~np.all(np.isfinite(tlwh), axis=1))
    if bad.size:
        i = int(bad[0])
        raise DetectionFormatError(f"box contains NaN or infinity: {tlwh[i].tolist()}", source=path, line=int(lineno[i]))
    bad = np.flatnonzero((tlwh[:, 2] <= 0) | (tlwh[:, 3] <= 0))
    if bad.size:
        i = int(bad[0])
        more = f" ({bad.size} such lines)" if bad.size > 1 else ""
        raise DetectionFormatError(
            f"box width and height must be positive, got w={tlwh[i, 2]:g}, h={tlwh[i, 3]:g}{more}", source=path, line=int(lineno[i])
        )


def _frames_and_order(table: np.ndarray, path: Path, lineno: np.ndarray, report: ReadReport) -> tuple[np.ndarray, np.ndarray]:
    frame = _check_integer_column(table, 0, "frame", path, lineno)
    neg = np.flatnonzero(frame < 0)
    if neg.size:
        i = int(neg[0])
        raise DetectionFormatError(f"frame must be >= 0 (MOTChallenge frames start at 1), got {int(frame[i])}", source=path, line=int(lineno[i]))
    big = np.flatnonzero(frame > MAX_FRAME)
    if big.size:
        i = int(big[0])
        raise DetectionFormatError(f"frame {int(frame[i])} is beyond {MAX_FRAME:.0e} (38 days at 30 fps): a wrong frame "
                                   "number?", source=path, line=int(lineno[i]))
    report.frame_zero_lines = int(np.count_nonzero(frame == 0))
    report.unsorted_lines = int(np.count_nonzero(np.diff(frame) < 0))
    order = np.argsort(frame, kind="stable")
    gap = np.diff(frame[order]) - 1
    if gap.size and gap.max() > 0:
        k = int(np.argmax(gap))
        report.largest_gap, report.largest_gap_line = int(gap[k]), int(lineno[order[k + 1]])
    return frame, order


def _finish_report(report: ReadReport, frame: np.ndarray) -> None:
    report.boxes = int(frame.size)
    if frame.size:
        report.frames = int(np.count_nonzero(np.diff(frame)) + 1)  # (sorted)
        report.frame_range = (int(frame[0]), int(frame[-1]))


def read_detections(
    path: str | Path, camera_index: int = 0, camera_names: Sequence[str] = ("cam0",)
) -> tuple[Detections, ReadReport]:
    """Read one MOTChallenge detection file (``detections/<camera>.txt``).

    Parameters
    ----------
    path: the file: ``frame, id, bb_left, bb_top, bb_width, bb_height[, conf[, x, y, z]]``,
        6 to 10 columns; a missing ``conf`` is 1. An empty file gives zero boxes.
    camera_index: index of this file's camera in ``camera_names`` (rig order).
    camera_names: the rig's camera names.

    Returns
    -------
    (detections, report): boxes sorted by frame (stable), centre form; ``track_id`` is the
    file's id column (-1 for raw detections).

    Errors (DetectionFormatError with the line number): wrong column count, a value that is not
    a number, a frame or id that is not a whole number, a negative frame, NaN / infinite boxes,
    zero or negative width or height, NaN confidence. Frames out of order are sorted and counted
    (``report.unsorted_lines``); frame 0 is accepted and counted (``report.frame_zero_lines``).
    """
    path = Path(path)
    names = tuple(camera_names)
    if not 0 <= camera_index < len(names):
        raise ValueError(f"camera_index {camera_index} outside the {len(names)} camera names")
    table, lineno, report = parse_mot_table(path)
    report.camera = names[camera_index]
    if table.shape[0] == 0:
        return Detections.empty(names), report
    frame, order = _frames_and_order(table, path, lineno, report)
    tid = _check_integer_column(table, 1, "id", path, lineno)
    _check_boxes(table, path, lineno)
    if table.shape[1] >= 7:
        score = table[:, 6]
        bad = np.flatnonzero(~np.isfinite(score))
        if bad.size:
            i = int(bad[0])
            raise DetectionFormatError(f"conf must be a finite number, got {float(score[i])!r}", source=path, line=int(lineno[i]))
    else:
        score = np.ones(table.shape[0])
    det = Detections.from_arrays(
        frame[order], camera_index, tlwh_to_xywh(table[order, 2:6]), names, score=score[order], track_id=tid[order]
    )
    _finish_report(report, det.frame)
    return det, report


def read_rig_detections(
    paths: Mapping[str, str | Path] | Sequence[str | Path], camera_names: Sequence[str]
) -> tuple[Detections, list[ReadReport]]:
    """Read one detection file per camera into one Detections over the rig.

    Parameters
    ----------
    paths: camera name -> file, or a sequence of files in ``camera_names`` order.
    camera_names: the rig's camera names; every camera needs a file.

    Returns
    -------
    (detections, reports): rows sorted by (frame, camera); one report per camera in rig order.
    """
    names = tuple(camera_names)
    if not isinstance(paths, Mapping):
        seq = list(paths)
        if len(seq) != len(names):
            raise ValueError(f"{len(seq)} files for {len(names)} cameras")
        paths = dict(zip(names, seq))
    missing = [n for n in names if n not in paths]
    if missing:
        raise ValueError(f"no detection file for cameras {missing}")
    parts, reports = [], []
    for i, n in enumerate(names):
        d, r = read_detections(paths[n], i, names)
        parts.append(d)
        reports.append(r)
    return Detections.concat(parts).sorted(), reports


def read_gt_boxes(
    path: str | Path, camera_index: int = 0, camera_names: Sequence[str] = ("cam0",)
) -> tuple[Detections, np.ndarray, ReadReport]:
    """Read a MOTChallenge ground-truth file ``gt/boxes_2d/<camera>.txt``.

    Lines: ``frame, person_id, bb_left, bb_top, w, h, visible[, -1, -1, -1]`` (7 to 10 columns).

    Returns
    -------
    (boxes, visible, report): ``boxes.track_id`` is the person id, ``boxes.score`` 1;
    ``visible`` (N,) bool from the visible column (non-zero = visible), rows sorted by frame.
    """
    path = Path(path)
    names = tuple(camera_names)
    table, lineno, report = parse_mot_table(path, min_columns=7)
    report.camera = names[camera_index]
    if table.shape[0] == 0:
        return Detections.empty(names), np.zeros(0, bool), report
    frame, order = _frames_and_order(table, path, lineno, report)
    pid = _check_integer_column(table, 1, "person_id", path, lineno)
    _check_boxes(table, path, lineno)
    vis = table[:, 6]
    bad = np.flatnonzero(~np.isin(vis, (0.0, 1.0)))
    if bad.size:
        i = int(bad[0])
        raise DetectionFormatError(f"visible must be 0 or 1, got {float(vis[i]):g}", source=path, line=int(lineno[i]))
    det = Detections.from_arrays(frame[order], camera_index, tlwh_to_xywh(table[order, 2:6]), names, track_id=pid[order])
    _finish_report(report, det.frame)
    return det, vis[order] != 0, report


# ============================================================================ writers
def _prepare(frame, ident, box_xywh) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    frame = np.asarray(frame, dtype=np.int64).reshape(-1)
    ident = np.asarray(ident, dtype=np.int64).reshape(-1)
    box = np.asarray(box_xywh, dtype=np.float64).reshape(-1, 4)
    if not (frame.size == ident.size == box.shape[0]):
        raise ValueError(f"frame ({frame.size}), id ({ident.size}) and box ({box.shape[0]}) rows differ")
    if not np.all(np.isfinite(box)):
        raise ValueError("boxes to write contain NaN or infinity")
    order = np.lexsort((ident, frame))
    return frame, ident, xywh_to_tlwh(box), order


def _write_table(path: Path, columns: list[np.ndarray], fmt: list[str]) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if columns[0].size == 0:
        path.write_text("")
        return path
    table = np.column_stack(columns).astype(np.float64)
    with open(path, "w") as fh:
        np.savetxt(fh, table, fmt=",".join(fmt))
    return path


def write_mot(path: str | Path, frame, track_id, box_xywh, conf=None, extra=None) -> Path:
    """Write MOTChallenge result lines ``frame,id,bb_left,bb_top,w,h,conf,x,y,z``.

    Parameters
    ----------
    frame: (N,) frame numbers (the input's numbering).
    track_id: (N,) ids.
    box_xywh: (N, 4) centre-form boxes in pixels; written top-left form with 2 decimals.
    conf: (N,) confidences (4 decimals), or None for 1.
    extra: (N, 3) the x, y, z columns (e.g. world position in metres, 4 decimals), or None for -1.

    Lines are sorted by (frame, id). Returns the path.
    """
    frame, ident, tlwh, order = _prepare(frame, track_id, box_xywh)
    n = frame.size
    conf = np.ones(n) if conf is None else np.asarray(conf, dtype=np.float64).reshape(-1)
    if conf.size != n:
        raise ValueError(f"conf has {conf.size} rows, expected {n}")
    if extra is None:
        xyz, xyz_fmt = np.full((n, 3), -1.0), ["%d"] * 3
    else:
        xyz = np.asarray(extra, dtype=np.float64).reshape(n, 3)
        xyz_fmt = ["%.4f"] * 3
    cols = [frame[order], ident[order], tlwh[order, 0], tlwh[order, 1], tlwh[order, 2], tlwh[order, 3], conf[order],
            xyz[order, 0], xyz[order, 1], xyz[order, 2]]
    return _write_table(Path(path), cols, ["%d", "%d", "%.2f", "%.2f", "%.2f", "%.2f", "%.4f", *xyz_fmt])


def write_mot_detections(path: str | Path, detections: Detections, camera: int | str | None = None) -> Path:
    """Write (one camera of) a :class:`Detections` as a MOTChallenge detection file (ids as stored)."""
    d = detections if camera is None else detections.for_camera(camera)
    return write_mot(path, d.frame, d.track_id, d.box, conf=d.score)


def write_mot_gt(path: str | Path, frame, person_id, box_xywh, visible=None) -> Path:
    """Write MOTChallenge ground-truth lines ``frame,person_id,bb_left,bb_top,w,h,visible,-1,-1,-1``.

    Parameters
    ----------
    frame, person_id: (N,).
    box_xywh: (N, 4) centre-form true boxes (whether or not a detector found them).
    visible: (N,) bool / 0-1, or None for all visible.
    """
    frame, ident, tlwh, order = _prepare(frame, person_id, box_xywh)
    n = frame.size
    vis = np.ones(n, np.int64) if visible is None else np.asarray(visible).reshape(-1).astype(bool).astype(np.int64)
    if vis.size != n:
        raise ValueError(f"visible has {vis.size} rows, expected {n}")
    minus = np.full(n, -1)
    cols = [frame[order], ident[order], tlwh[order, 0], tlwh[order, 1], tlwh[order, 2], tlwh[order, 3], vis[order], minus, minus, minus]
    return _write_table(Path(path), cols, ["%d", "%d", "%.2f", "%.2f", "%.2f", "%.2f", "%d", "%d", "%d", "%d"])
