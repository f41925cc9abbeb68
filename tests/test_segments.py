"""de Leva's segments as joint weights (gymtrack.segments), the analysis' centre of mass and the
simulator's, which must be the same point."""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.analysis.joints import USED
from gymtrack.analysis.kinematics import centre_of_mass
from gymtrack.segments import com_weights
from gymtrack.simulate import body as B


@pytest.mark.parametrize("body", ["mean", "female", "male"])
def test_weights_sum_to_one(body):
    assert sum(com_weights(body).values()) == pytest.approx(1.0, abs=1e-12)


def test_the_heads_weight_is_its_mass_share_by_hand():
    # mean body (de Leva 1996, Table 4, the two columns averaged): head 6.81 %; the whole body
    # 6.81 + 43.015 + 2 x (2.63 + 1.50 + 0.585 + 14.47 + 4.57 + 1.33) = 99.995 %
    w = com_weights("mean")
    assert w["left_ear"] + w["right_ear"] == pytest.approx(6.81 / 99.995, abs=1e-12)
    # the hand's centre lies beyond the wrist along the forearm: the elbow's weight loses a part
    # (upper arm 2.63 % at 57.63 % from the shoulder, forearm 1.50 % at 45.665 % from the elbow,
    # hand 0.585 % at 76.87 % of a hand 0.31 forearms long)
    elbow = 2.63 * 0.5763 + 1.50 * (1 - 0.45665) - 0.585 * 0.7687 * 0.31
    assert w["left_elbow"] == pytest.approx(elbow / 99.995, abs=1e-12)


def test_the_simulated_centre_of_mass_is_the_analysis_one():
    rng = np.random.default_rng(0)
    body = B.BodyModel(1.62)
    n = 40
    angles = np.stack([B.posture_angles(int(k)) for k in rng.integers(0, len(B.POSTURES), n)]) + rng.normal(0, 10, (n, B.N_ANGLES))
    angles[:, 10] = np.clip(angles[:, 10], 0, 1)
    yaw, pitch, twist = rng.uniform(-np.pi, np.pi, (3, n))
    centre = rng.normal(0, 2, (n, 3))
    pts, _ = body.world_points(centre, angles, yaw, pitch, twist)
    com, fallback = centre_of_mass(pts[:, [B.COCO_JOINTS.index(j) for j in USED]])
    assert not fallback.any()
    np.testing.assert_allclose(centre + body.com_offset(angles, yaw, pitch, twist), com, atol=1e-12)
    # and it is not the box centre the tracker sees: a tuck or an arms-up stretch moves them apart
    assert np.linalg.norm(com - centre, axis=1).max() > 0.05
