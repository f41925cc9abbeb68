"""The tracker's fast paths give what the general paths give."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import ring_rig, simple_scene

from gymtrack.detections import Detections
from gymtrack.tracking import undistort
from gymtrack.tracking._kernels.single_view import frame_rows_check
from gymtrack.tracking.target import TargetStage
from gymtrack.tracking.types import Tracks3D
from gymtrack.tracking.undistort import UndistortTables

DIST = [-0.2, 0.05, 0.001, -0.001, 0.0]


def test_undistort_tables_of_a_calibration_are_built_once_and_read_only():
    rig = ring_rig([0, 90, 200], dist=DIST)
    undistort._BUILT.clear()
    first = UndistortTables(rig)
    n_built = len(undistort._BUILT)
    assert n_built == 1  # three cameras of one calibration (K, distortion, size): one grid
    again = UndistortTables(ring_rig([0, 90, 200], dist=DIST))  # new Camera objects, same calibration
    assert len(undistort._BUILT) == n_built
    assert again.tables[0][0] is first.tables[0][0]
    with pytest.raises(ValueError):
        first.tables[0][0][0, 0, 0] = 1.0
    # a cached table undistorts exactly as a freshly built one
    uv = np.random.default_rng(0).uniform([0, 0], [1000, 700], (50, 2))
    cam = np.arange(50) % 3
    undistort._BUILT.clear()
    fresh = UndistortTables(rig)
    np.testing.assert_array_equal(again(cam, uv), fresh(cam, uv))
    other = UndistortTables(ring_rig([0], dist=[-0.1, 0.0, 0.0, 0.0, 0.0]))  # another calibration: its own grid
    assert len(undistort._BUILT) == 2 and other.tables[0][0] is not fresh.tables[0][0]


@pytest.mark.parametrize("index", [slice(1, 4), np.array([True, False, True, False, True]), np.array([4, 0, 0])])
def test_detections_select_keeps_columns_dtypes_and_checks_nothing_it_need_not(index):
    det = Detections.from_arrays([3, 3, 4, 5, 5], [0, 1, 1, 0, 2], np.arange(20.0).reshape(5, 4), ("a", "b", "c"),
                                 score=[0.1, 0.2, 0.3, 0.4, 0.5], track_id=[7, 8, 9, 10, 11])
    sub = det.select(index)
    ref = Detections.from_arrays(det.frame[index], det.camera[index], det.box[index], det.camera_names,
                                 score=det.score[index], track_id=det.track_id[index])
    for name in ("frame", "camera", "box", "score", "track_id"):
        np.testing.assert_array_equal(getattr(sub, name), getattr(ref, name))
        assert getattr(sub, name).dtype == getattr(ref, name).dtype
    assert sub.camera_names == ("a", "b", "c") and isinstance(sub, Detections)
    with pytest.raises(AttributeError):  # still frozen
        sub.frame = det.frame
    with pytest.raises(IndexError):  # a mask of the wrong length still fails
        det.select(np.ones(4, bool))


def _pause_by_search(stage: TargetStage, a: int, b: int, frame: np.ndarray):
    """The general search of :meth:`TargetStage._pause` (every gap between points looked at)."""
    held = stage._last_point is not None
    prev = stage._last_point if held else a - 1
    s = np.concatenate([[prev], np.unique(frame), [b + 1]])
    gap = np.flatnonzero(np.diff(s) - 1 > stage.settle)
    if not len(gap):
        return None
    k = int(gap[0])
    p, q = int(s[k]), int(s[k + 1])
    return (p if k > 0 or held else None), (q if q <= b else None)


def test_target_pause_shortcut_agrees_with_the_search():
    rig = ring_rig([0, 90])
    stage = TargetStage(rig, simple_scene())
    settle = stage.settle
    rng = np.random.default_rng(1)
    shortcuts = 0
    for _ in range(400):
        a = int(rng.integers(0, 100))
        b = a + int(rng.integers(0, 3 * settle))
        stage._last_point = None if rng.random() < 0.3 else a - 1 - int(rng.integers(0, 2 * settle))
        n = int(rng.integers(0, 6))
        frame = np.sort(rng.integers(a, b + 1, n)) if n else np.zeros(0, np.int64)
        lo = min([stage._last_point if stage._last_point is not None else a - 1, *frame.tolist()])
        shortcuts += max(b + 1, *frame.tolist(), b + 1) - lo - 1 <= settle
        assert stage._pause(a, b, frame) == _pause_by_search(stage, a, b, frame)
    assert 50 < shortcuts < 350  # both paths were taken


def test_tracks_concat_and_select_by_cached_field_names():
    t = Tracks3D(np.array([1, 2]), np.array([0, 1]), np.ones((2, 3)), np.zeros(2), np.zeros(2),
                 np.zeros(2, np.int8), np.ones(2, np.int8))
    both = Tracks3D.concat([t, t.select(np.array([1]))])
    assert both.frame.tolist() == [1, 2, 2] and both.xyz.shape == (3, 3) and both.n_views.dtype == np.int8
    assert Tracks3D.concat([t]).frame is not t.frame  # a copy, as before


def test_frame_rows_check_is_the_numpy_test():
    rng = np.random.default_rng(2)
    seen = set()
    for _ in range(300):
        n = int(rng.integers(0, 8))
        frame_col = np.where(rng.random(n) < 0.9, 5, rng.integers(0, 9, n)).astype(np.int64)
        camera = rng.integers(-2, 6, n).astype(np.int64)
        if rng.random() < 0.5:
            camera = np.clip(camera, 0, 3)
        ref = 1 if (frame_col != 5).any() else 2 if ((camera < 0) | (camera >= 4)).any() else 0
        assert frame_rows_check(frame_col, camera, 5, 4) == ref
        seen.add(ref)
    assert seen == {0, 1, 2}
