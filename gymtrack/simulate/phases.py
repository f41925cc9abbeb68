"""Phase labels of a person's frames, gravity, and the smooth ramps the motion builder shares.

Paper: the phases of a routine in the gymnastics setting of Section IV (walking in, salute,
mount, skills, dismount, landing...); :data:`PERFORMING` are those in which the target must stay
inside the performance space ``S_perf`` (Section III-D). Re-exported by :mod:`.motion`.
"""

from __future__ import annotations

import numpy as np

G = 9.81  #: gravity, m/s^2

# Phase labels of the target's frames.
WALK, SALUTE, MOUNT, SKILL, DISMOUNT, LANDING, OFF_PLANE, WAIT, RUN_UP = range(9)
PHASE_NAMES = ("walk", "salute", "mount", "skill", "dismount", "landing", "off_plane", "wait", "run_up")
#: Phases in which the target performs (its centre must stay in the performance space). The
#: vault's run-up is not among them: a vault is judged from the take-off from the springboard
#: (the run is not evaluated), and on the runway the gymnast runs on the floor like anyone
#: else, so no height rule (paper Eq. 13) can single her out before the hurdle.
PERFORMING = (MOUNT, SKILL, DISMOUNT, LANDING, OFF_PLANE)


def smoothstep(x: np.ndarray) -> np.ndarray:
    """Minimum-jerk ramp 0 -> 1 for ``x`` in [0, 1] (zero velocity and acceleration at both ends)."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * x * (10 - 15 * x + 6 * x * x)


def wrap_angle(a):
    """Angles to (-pi, pi]."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi
