"""MOTChallenge reader and writers: round trips, accepted variants, counted oddities, located errors."""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.errors import DetectionFormatError
from gymtrack.formats.motchallenge import (
    read_detections,
    read_gt_boxes,
    read_rig_detections,
    write_mot,
    write_mot_detections,
    write_mot_gt,
)


def _boxes(rng, n):
    xy = rng.uniform([0, 0], [1920, 1080], size=(n, 2))
    wh = rng.uniform([20, 40], [200, 400], size=(n, 2))
    return np.column_stack([xy, wh])


def test_write_then_read_round_trip(tmp_path, rng):
    n = 200
    frame = rng.integers(1, 60, n)
    tid = rng.integers(-1, 9, n)
    box = _boxes(rng, n)
    conf = rng.uniform(0, 1, n)
    p = write_mot(tmp_path / "cam0.txt", frame, tid, box, conf)
    d, r = read_detections(p, 1, ["a", "cam0"])
    order = np.lexsort((tid, frame))  # the writer sorts by (frame, id)
    np.testing.assert_array_equal(d.frame, frame[order])
    np.testing.assert_array_equal(d.track_id, tid[order])
    np.testing.assert_allclose(d.box, box[order], atol=0.0076)  # 2 decimals in the file
    np.testing.assert_allclose(d.score, conf[order], atol=6e-5)
    assert np.all(d.camera == 1) and d.camera_names == ("a", "cam0")
    assert (r.lines, r.boxes, r.columns, r.unsorted_lines) == (n, n, 10, 0)
    assert r.frames == np.unique(frame).size and r.frame_range == (frame.min(), frame.max())


def test_written_line_format(tmp_path):
    p = write_mot(tmp_path / "a.txt", [2, 1], [5, 7], [[25.0, 40.0, 30.0, 40.0], [1.0, 2.0, 2.0, 2.0]], [0.5, 0.9])
    assert p.read_text().splitlines() == [
        "1,7,0.00,1.00,2.00,2.00,0.9000,-1,-1,-1",
        "2,5,10.00,20.00,30.00,40.00,0.5000,-1,-1,-1",
    ]
    p = write_mot(tmp_path / "b.txt", [1], [3], [[25.0, 40.0, 30.0, 40.0]], extra=[[1.5, -2.25, 0.125]])
    assert p.read_text() == "1,3,10.00,20.00,30.00,40.00,1.0000,1.5000,-2.2500,0.1250\n"
    p = write_mot(tmp_path / "c.txt", [], [], np.zeros((0, 4)))
    assert p.read_text() == "" and len(read_detections(p)[0]) == 0


@pytest.mark.filterwarnings("ignore:Operation with tuple")  # inside motmetrics, with recent pandas
def test_written_file_reads_in_motmetrics(tmp_path, rng):
    mm_io = pytest.importorskip("motmetrics.io")
    box = _boxes(rng, 5)
    p = write_mot(tmp_path / "res.txt", [1, 1, 2, 3, 3], [1, 2, 1, 1, 2], box)
    df = mm_io.loadtxt(str(p), fmt="mot15-2D")
    tlwh = np.column_stack([box[:, 0] - box[:, 2] / 2, box[:, 1] - box[:, 3] / 2, box[:, 2], box[:, 3]])
    assert list(df.index) == [(1, 1), (1, 2), (2, 1), (3, 1), (3, 2)]
    tlwh[:, :2] -= 1.0  # motmetrics moves MOTChallenge's 1-based pixel coordinates to 0-based
    np.testing.assert_allclose(df[["X", "Y", "Width", "Height"]].to_numpy(), tlwh, atol=0.0051)


def test_accepts_fewer_columns_whitespace_and_blank_lines(tmp_path):
    p = tmp_path / "d.txt"
    p.write_text("1, -1, 10, 20, 30, 40\n\n2,-1,11,21,31,41\n   \n")
    d, r = read_detections(p)
    assert r.columns == 6 and r.lines == 2 and r.skipped == {"blank line": 2}
    np.testing.assert_allclose(d.score, [1.0, 1.0])
    np.testing.assert_allclose(d.box[0], [25.0, 40.0, 30.0, 40.0])
    p.write_text("1,-1,10,20,30,40,0.25\n")
    d, r = read_detections(p)
    assert r.columns == 7 and d.score[0] == pytest.approx(0.25)


def test_empty_file_gives_zero_boxes(tmp_path):
    p = tmp_path / "e.txt"
    p.write_text("")
    d, r = read_detections(p, 0, ["e"])
    assert len(d) == 0 and d.camera_names == ("e",) and r.boxes == 0 and r.frame_range is None


def test_unsorted_frames_are_sorted_and_counted(tmp_path):
    p = tmp_path / "u.txt"
    frames = [3, 1, 2, 2, 5, 4, 0]  # descending steps: 3->1, 5->4, 4->0
    p.write_text("".join(f"{f},{i},{i},0,10,10,1,-1,-1,-1\n" for i, f in enumerate(frames)))
    d, r = read_detections(p)
    np.testing.assert_array_equal(d.frame, sorted(frames))
    np.testing.assert_array_equal(d.track_id, [6, 1, 2, 3, 0, 5, 4])  # stable
    assert r.unsorted_lines == 3 and r.frame_zero_lines == 1


BAD_LINES = {
    "too few columns": ("1,-1,10,20,30\n", 1, "columns"),
    "too many columns": ("1,-1,10,20,30,40,1,-1,-1,-1,9\n", 1, "columns"),
    "mixed columns": ("1,-1,10,20,30,40,1\n2,-1,10,20,30,40\n", 2, "same columns"),
    "not a number": ("1,-1,10,20,30,40\n2,-1,1O,20,30,40\n", 2, "column 3 is not a number"),
    "trailing comma": ("1,-1,10,20,30,40,\n", 1, "column 7"),
    "space separated": ("1 -1 10 20 30 40\n", 1, "columns"),
    "NaN box": ("1,-1,10,20,30,40\n1,-1,nan,20,30,40\n", 2, "NaN"),
    "zero width": ("1,-1,10,20,0,40\n", 1, "positive"),
    "negative height": ("1,-1,10,20,30,40\n\n1,-1,10,20,30,-4\n", 3, "positive"),
    "fractional frame": ("1.5,-1,10,20,30,40\n", 1, "frame must be a whole number"),
    "negative frame": ("-2,-1,10,20,30,40\n", 1, "frame must be >= 0"),
    "fractional id": ("1,0.5,10,20,30,40\n", 1, "id must be a whole number"),
    "NaN conf": ("1,-1,10,20,30,40,nan\n", 1, "conf"),
}


@pytest.mark.parametrize("case", sorted(BAD_LINES))
def test_bad_lines_name_file_and_line(tmp_path, case):
    text, line, problem = BAD_LINES[case]
    p = tmp_path / "cam3.txt"
    p.write_text(text)
    with pytest.raises(DetectionFormatError) as e:
        read_detections(p)
    msg = str(e.value)
    assert msg.startswith(f"{p}: line {line}: ") and problem in msg, msg
    assert e.value.line == line


def test_missing_file_is_an_error(tmp_path):
    with pytest.raises(DetectionFormatError, match="file not found"):
        read_detections(tmp_path / "nope.txt")


def test_gt_round_trip_with_visible_flag(tmp_path, rng):
    box = _boxes(rng, 6)
    vis = np.array([1, 0, 1, 1, 0, 1], bool)
    p = write_mot_gt(tmp_path / "gt.txt", [1, 1, 2, 2, 3, 3], [4, 9, 4, 9, 4, 9], box, vis)
    assert p.read_text().splitlines()[1].endswith(",0,-1,-1,-1")
    d, v, r = read_gt_boxes(p, 0, ["cam0"])
    np.testing.assert_array_equal(v, vis)
    np.testing.assert_array_equal(d.track_id, [4, 9, 4, 9, 4, 9])
    np.testing.assert_allclose(d.box, box, atol=0.0076)
    p.write_text("1,4,10,20,30,40,2,-1,-1,-1\n")
    with pytest.raises(DetectionFormatError, match="line 1: visible must be 0 or 1"):
        read_gt_boxes(p)


def test_rig_detections_merge_cameras(tmp_path, rng):
    names = ["left", "right", "top"]
    paths = {}
    counts = {"left": 5, "right": 0, "top": 3}
    for n in names:
        k = counts[n]
        paths[n] = write_mot(tmp_path / f"{n}.txt", rng.integers(1, 4, k), np.full(k, -1), _boxes(rng, k))
    d, reports = read_rig_detections(paths, names)
    assert d.counts_per_camera() == counts
    assert [r.camera for r in reports] == names
    assert np.all(np.diff(d.frame) >= 0)
    again = write_mot_detections(tmp_path / "again.txt", d, "top")
    d2, _ = read_detections(again, 2, names)
    np.testing.assert_allclose(np.sort(d2.box[:, 0]), np.sort(d.for_camera("top").box[:, 0]), atol=0.0076)
