"""Lifting MVOR's real OpenPose keypoints (a few frames; skipped when the data is absent).

MVOR: Srivastav et al., MICCAI-LABELS 2018, arXiv:1808.08180 (CC BY-NC-SA 4.0), read from
shared/data/mvor, never copied here.
"""

from pathlib import Path

import numpy as np
import pytest

from gymtrack.eval.pose_mvor import lift_mvor, mvor_errors, mvor_markdown, run_mvor_pose

MVOR = Path(__file__).resolve().parents[2] / "shared" / "data" / "mvor"
if not (MVOR / "camma_mvor_2018.json").is_file():
    MVOR = Path("/work/shared/data/mvor")
pytestmark = pytest.mark.skipif(not (MVOR / "camma_mvor_2018.json").is_file(), reason="MVOR data (shared/data/mvor) is absent")


@pytest.fixture(scope="module")
def mv():
    from gymtrack.formats.mvor import read_mvor

    return read_mvor(MVOR, detectors=("openpose",), max_match_px=np.inf)


def test_robust_beats_dlt_on_real_openpose_keypoints(mv):
    r = lift_mvor(mv, "openpose", frames=np.arange(60))
    assert len(r["gt"]) > 50
    common = np.isfinite(r["dlt"]).all(-1) & np.isfinite(r["robust"]).all(-1)
    d, b = mvor_errors(r["dlt"], r["gt"], common), mvor_errors(r["robust"], r["gt"], common)
    assert d["joints_common"] > 100
    # on the same joints, dropping disagreeing views must help against wrong detections
    assert b["mpjpe_common_mm"] < d["mpjpe_common_mm"]
    assert b["mpjpe_mm"] < d["mpjpe_mm"]
    # a sane scale: metres, not millimetres, and most joints within half a metre
    assert 30 < b["median_mm"] < 300 and b["over_500mm"] < 0.25


def test_errors_by_hand():
    gt = np.zeros((1, 3, 3))
    est = np.array([[[0.1, 0, 0], [np.nan] * 3, [0, 0.6, 0]]])
    e = mvor_errors(est, gt)
    assert e["joints_gt"] == 3 and e["joints_estimated"] == 2
    assert e["mpjpe_mm"] == pytest.approx(350.0) and e["over_500mm"] == pytest.approx(0.5)


def test_section_without_data_says_why(tmp_path):
    d = run_mvor_pose(tmp_path)
    assert d["available"] is False and "MVOR" in mvor_markdown(d)
