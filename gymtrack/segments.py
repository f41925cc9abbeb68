"""Body segment parameters (de Leva 1996) and the centre of mass as a weighted sum of COCO-17 joints.

Rule: ``shared/formats.md``, "Outputs of the analysis stage" -- ``com`` is de Leva's whole-body
centre of mass. The analysis measures it on a skeleton (:func:`gymtrack.analysis.kinematics.centre_of_mass`)
and the simulator moves it on a parabola in flight (:meth:`gymtrack.simulate.body.BodyModel.com_offset`):
both read these weights, so a simulated flight is ballistic by the analysis' own measure.

COCO-17 has no vertex, cervicale, heel or toe, so the segments are placed on the joints it has:
head at the mid-ears, trunk from the mid-shoulder (for the cervicale) to the mid-hip, hands along
the forearm beyond the wrist (hand length :data:`HAND_OVER_FOREARM` x the forearm), feet at the ankles.
"""

from __future__ import annotations

#: de Leva (1996), Table 4, segment parameters adjusted to joint centres:
#: segment -> (mass % female, mass % male, CM % from the proximal end female, male)
DE_LEVA: dict[str, tuple[float, float, float, float]] = {
    "head": (6.68, 6.94, 58.94, 59.76),  # vertex -> cervicale
    "trunk": (42.57, 43.46, 41.51, 44.86),  # cervicale -> mid-hip
    "upper_arm": (2.55, 2.71, 57.54, 57.72),  # shoulder -> elbow
    "forearm": (1.38, 1.62, 45.59, 45.74),  # elbow -> wrist
    "hand": (0.56, 0.61, 74.74, 79.00),  # wrist -> 3rd metacarpal head
    "thigh": (14.78, 14.16, 36.12, 40.95),  # hip -> knee
    "shank": (4.81, 4.33, 44.16, 44.59),  # knee -> lateral malleolus
    "foot": (1.29, 1.37, 40.14, 44.15),  # heel -> toe tip
}
#: hand length (wrist to 3rd metacarpal head) over forearm length (de Leva's mean lengths)
HAND_OVER_FOREARM = 0.31
BODIES = ("mean", "female", "male")
#: the joints whose mid-point is the head's centre
HEAD = ("left_ear", "right_ear")


def segment_table(body: str = "mean") -> dict[str, tuple[float, float]]:
    """segment -> (mass fraction, CM fraction from the proximal end) for ``body`` (mean | female | male)."""
    if body not in BODIES:
        raise ValueError(f"body must be one of {', '.join(BODIES)}, got {body!r}")
    out = {}
    for seg, (mf, mm, cf, cm) in DE_LEVA.items():
        m, c = {"female": (mf, cf), "male": (mm, cm), "mean": ((mf + mm) / 2, (cf + cm) / 2)}[body]
        out[seg] = (m / 100.0, c / 100.0)
    return out


def com_weights(body: str = "mean") -> dict[str, float]:
    """COCO-17 joint name -> weight (the weights sum to 1): the centre of mass is ``sum w_j X_j``
    over these 14 joints (ears, shoulders, elbows, wrists, hips, knees, ankles) when all are present."""
    T = segment_table(body)
    w: dict[str, float] = {}

    def add(name: str, m: float) -> None:
        w[name] = w.get(name, 0.0) + m

    m, c = T["head"]
    for j in HEAD:
        add(j, m / 2)
    m, c = T["trunk"]  # mid-shoulder + c (mid-hip - mid-shoulder)
    for side in ("left", "right"):
        add(f"{side}_shoulder", m * (1 - c) / 2)
        add(f"{side}_hip", m * c / 2)
    for side in ("left", "right"):
        for seg, a, b in (("upper_arm", "shoulder", "elbow"), ("forearm", "elbow", "wrist"),
                          ("thigh", "hip", "knee"), ("shank", "knee", "ankle")):
            m, c = T[seg]
            add(f"{side}_{a}", m * (1 - c))
            add(f"{side}_{b}", m * c)
        m, c = T["hand"]  # wrist + c h (wrist - elbow), h = HAND_OVER_FOREARM
        add(f"{side}_wrist", m * (1 + c * HAND_OVER_FOREARM))
        add(f"{side}_elbow", -m * c * HAND_OVER_FOREARM)
        add(f"{side}_ankle", T["foot"][0])
    total = sum(w.values())  # each segment's weights sum to its mass
    return {k: v / total for k, v in w.items()}
