"""``gt/keypoints_3d.csv``: reading it back dense, and clear errors for bad files."""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.errors import InputError
from gymtrack.formats.gt_keypoints import read_keypoints_3d

HEAD = "frame,person_id,joint,x,y,z\n"


def _write(tmp_path, body: str, head: str = HEAD):
    p = tmp_path / "keypoints_3d.csv"
    p.write_text(head + body)
    return p


def test_reads_dense_with_nan_where_absent(tmp_path):
    body = "3,7,nose,1.0,2.0,3.0\n1,7,left_ankle,-1.5,0.25,0.1\n\n1,2,right_ankle,4,5,6\n"
    frames, pid, j = read_keypoints_3d(_write(tmp_path, body))
    assert frames.tolist() == [1, 3] and pid.tolist() == [2, 7] and j.shape == (2, 2, 17, 3)
    np.testing.assert_array_equal(j[1, 1, 0], [1, 2, 3])
    np.testing.assert_array_equal(j[1, 0, 15], [-1.5, 0.25, 0.1])
    np.testing.assert_array_equal(j[0, 0, 16], [4, 5, 6])
    assert np.isnan(j).sum() == 3 * (2 * 2 * 17 - 3)


def test_header_only_is_empty(tmp_path):
    frames, pid, j = read_keypoints_3d(_write(tmp_path, ""))
    assert frames.size == 0 and pid.size == 0 and j.shape == (0, 0, 17, 3)


@pytest.mark.parametrize("body,head,match,line", [
    ("1,1,nose,0,0,0\n", "frame,person,joint,x,y,z\n", "header", 1),
    ("1,1,nose,0,0,0\n1,1,nose,0,0\n", HEAD, "6 comma-separated", 3),
    ("1,1,nose,0,0,0\n1.5,1,nose,0,0,0\n", HEAD, "frame must be a whole number", 3),
    ("1,x,nose,0,0,0\n", HEAD, "person_id must be a whole number", 2),
    ("1,1,nose,0,abc,0\n", HEAD, "y must be a number", 2),
    ("1,1,neck,0,0,0\n", HEAD, "COCO-17 joint", 2),
    ("1,1,nose,0,0,0\n2,1,nose,0,0,0\n1,1,nose,1,1,1\n", HEAD, "given twice", 4),
])
def test_bad_files_name_file_and_line(tmp_path, body, head, match, line):
    p = _write(tmp_path, body, head)
    with pytest.raises(InputError, match=match) as e:
        read_keypoints_3d(p)
    assert e.value.line == line and e.value.source == str(p)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_keypoints_3d(tmp_path / "nope.csv")
