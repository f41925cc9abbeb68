"""WILDTRACK reader: synthetic files in its layout, and the real data set when it is present."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from conftest import WILDTRACK, needs_data
from gymtrack.errors import CalibrationError, DetectionFormatError
from gymtrack.formats.calibration import detect_format, load_calibration
from gymtrack.formats.wildtrack import (
    WILDTRACK_VIEWS,
    position_from_id,
    read_wildtrack_annotations,
    read_wildtrack_calibration,
)
from gymtrack.geometry import Rig

needs_wildtrack = needs_data(WILDTRACK / "calibrations", "the WILDTRACK calibration")


def _write_wildtrack_calibration(root: Path, rig: Rig) -> None:
    """XML files as WILDTRACK ships them: plain rvec/tvec text (cm), opencv-matrix intrinsics."""
    for sub in ("extrinsic", "intrinsic_zero", "intrinsic_original"):
        (root / sub).mkdir(parents=True)
    for c in rig:
        rv, tv = " ".join(map(repr, c.rvec.tolist())), " ".join(repr(v * 100) for v in c.t.tolist())
        (root / "extrinsic" / f"extr_{c.name}.xml").write_text(
            f'<?xml version="1.0"?>\n<opencv_storage>\n  <rvec>\n    {rv}\n   </rvec> \n  <tvec>\n    {tv}\n  </tvec>\n</opencv_storage>\n'
        )
        K = " ".join(map(repr, c.K.reshape(-1).tolist()))
        for sub, dist in (("intrinsic_zero", np.zeros(5)), ("intrinsic_original", c.dist)):
            (root / sub / f"intr_{c.name}.xml").write_text(
                '<?xml version="1.0"?>\n<opencv_storage>\n<camera_matrix type_id="opencv-matrix">\n  <rows>3</rows>\n  <cols>3</cols>\n'
                f'  <dt>d</dt>\n  <data>{K}</data></camera_matrix>\n<distortion_coefficients type_id="opencv-matrix">\n'
                f'  <rows>5</rows>\n  <cols>1</cols>\n  <dt>d</dt>\n  <data>\n    {" ".join(map(repr, dist.tolist()))}</data></distortion_coefficients>\n'
                "</opencv_storage>\n"
            )


def test_wildtrack_calibration_layout_round_trip(tmp_path, rng, make_camera, make_points):
    names = ["IDIAP1", "CVLab2", "CVLab1", "extra"]
    rig = Rig([make_camera(rng, n, distortion=5) for n in names])
    root = tmp_path / "calibrations"
    _write_wildtrack_calibration(root, rig)
    assert detect_format(root) == "wildtrack" and detect_format(tmp_path) == "wildtrack"
    zero = load_calibration(tmp_path)
    assert zero.names == ("CVLab1", "CVLab2", "IDIAP1", "extra")  # viewNum order, others after
    orig = read_wildtrack_calibration(root, intrinsics="original")
    X = make_points(rng, rig, 30)
    for cam in rig:
        z, o = zero[cam.name], orig[cam.name]
        np.testing.assert_allclose(z.t, cam.t, rtol=1e-12, atol=1e-12)  # cm -> m
        np.testing.assert_allclose(z.R, cam.R, atol=1e-12)
        assert not z.has_distortion and o.has_distortion
        np.testing.assert_allclose(o.project(X), cam.project(X), atol=1e-6)
        np.testing.assert_allclose(z.project(X), cam.project(X, distort=False), atol=1e-6)
    (root / "intrinsic_zero" / "intr_extra.xml").unlink()
    with pytest.raises(CalibrationError, match="intr_extra.xml"):
        read_wildtrack_calibration(root)
    with pytest.raises(CalibrationError, match="intrinsics"):
        read_wildtrack_calibration(root, intrinsics="raw")


def test_wildtrack_annotations_columns_and_skips(tmp_path):
    ann = tmp_path / "annotations_positions"
    ann.mkdir()
    pid = 480 * 10 + 20  # X = -300 + 2.5 * 20 = -250 cm, Y = -900 + 2.5 * 10 = -875 cm
    views = [{"viewNum": v, "xmin": -1, "ymin": -1, "xmax": -1, "ymax": -1} for v in range(7)]
    views[2] = {"viewNum": 2, "xmin": 100, "ymin": 50, "xmax": 140, "ymax": 250}
    views[5] = {"viewNum": 5, "xmin": 10, "ymin": 20, "xmax": 30, "ymax": 80}
    (ann / "00000005.json").write_text(json.dumps([{"personID": 7, "positionID": pid, "views": views}]))
    (ann / "00000000.json").write_text(json.dumps([{"personID": 3, "positionID": 0, "views": views[:3]}]))
    a = read_wildtrack_annotations(tmp_path)
    assert a.files == 2
    assert a.skipped == {"not visible (-1)": 2 + 5}
    np.testing.assert_array_equal(a.frame, [0, 5])
    np.testing.assert_array_equal(a.person_id, [3, 7])
    np.testing.assert_allclose(a.position, [[-3.0, -9.0, 0.0], [-2.5, -8.75, 0.0]])
    d = a.detections
    assert len(d) == 3 and d.camera_names == WILDTRACK_VIEWS
    np.testing.assert_array_equal(d.frame, [0, 5, 5])
    np.testing.assert_array_equal(d.camera, [2, 2, 5])
    np.testing.assert_array_equal(d.track_id, [3, 7, 7])
    np.testing.assert_allclose(d.box[1], [120, 150, 40, 200])  # centre form of (100, 50)-(140, 250)
    np.testing.assert_array_equal(a.box_position, [0, 1, 1])
    np.testing.assert_allclose(position_from_id(np.array([pid])), [[-2.5, -8.75, 0.0]])

    views[5]["xmax"] = "30"
    (ann / "00000005.json").write_text(json.dumps([{"personID": 7, "positionID": pid, "views": views}]))
    with pytest.raises(DetectionFormatError, match=r"00000005.json: field '\[0\].views\[5\].xmax'"):
        read_wildtrack_annotations(ann)


@needs_wildtrack
def test_real_wildtrack_ground_positions_project_to_box_bottoms():
    rig = load_calibration(WILDTRACK / "calibrations")
    assert rig.names == WILDTRACK_VIEWS and all(c.size == (1920, 1080) for c in rig)
    assert np.all(rig.centres[:, 2] > 1.0)  # cameras above the ground: z is up
    a = read_wildtrack_annotations(WILDTRACK, limit=100)
    assert a.files == 100 and a.skipped.get("not visible (-1)", 0) > 0
    d = a.detections
    for c, cam in enumerate(rig):
        m = d.camera == c
        assert m.sum() > 100
        uv = cam.project(a.position[a.box_position[m]])
        err = np.linalg.norm(uv - d.bottom[m], axis=1)
        assert np.median(err) < 20.0, (cam.name, float(np.median(err)))
    orig = read_wildtrack_calibration(WILDTRACK, intrinsics="original")
    assert all(c.has_distortion for c in orig)
    np.testing.assert_allclose(orig.projections, rig.projections)  # same K, R, t


def test_xml_that_opencv_rejects_is_read_with_etree(tmp_path):
    from gymtrack.formats.calibration import read_opencv_xml_numbers

    p = tmp_path / "x.xml"
    # OpenCV insists on an <opencv_storage> root; the etree fallback does not
    p.write_text('<?xml version="1.0"?>\n<root><rvec>0.1 0.2 0.3</rvec><camera_matrix type_id="opencv-matrix"><rows>2</rows>'
                 "<cols>2</cols><dt>d</dt><data>1 2 3 4</data></camera_matrix></root>\n")
    np.testing.assert_allclose(read_opencv_xml_numbers(p, "rvec"), [0.1, 0.2, 0.3])
    np.testing.assert_allclose(read_opencv_xml_numbers(p, "camera_matrix"), [[1, 2], [3, 4]])
    assert read_opencv_xml_numbers(p, "tvec") is None
    p.write_text("<root><rvec>1 2 x</rvec></root>")
    with pytest.raises(CalibrationError, match="field 'rvec'"):
        read_opencv_xml_numbers(p, "rvec")
    p.write_text("not xml at all <")
    with pytest.raises(CalibrationError, match="not a readable OpenCV XML"):
        read_opencv_xml_numbers(p, "rvec")
