"""Per-frame measures on the measurement and on Monte Carlo samples of it: the uncertainties.

Paper: Section III-D, last paragraph (the 3D pose and its quality per joint). Rule: every
measure carries ``<measure>_sd``, propagated from the pose stage's per-joint errors. Each joint is
redrawn ``SAMPLES`` times around its position with its own sigma (:func:`.joints.joint_sigma`,
isotropic, independent across joints and frames; a fixed seed, so a run is reproducible), and
every sample goes through the same filter, angles, centre of mass and unwrapping as the
measurement. A measure's sd is the samples' spread -- exact for the non-linear angles near 0 and
180 deg where a first-order Jacobian fails. Element measures are taken on every sample with the
element's frames fixed by the measurement (:mod:`.flights`, :mod:`.elements`).

Vectorised over samples x frames x joints; samples go in chunks of :data:`CHUNK_VALUES` coordinates to bound memory.
"""

from __future__ import annotations

import numpy as np

from .filtering import filter_joints
from .kinematics import centre_of_mass, frame_angles
from .rotation import raw_rotation, unwrap

SAMPLES = 32
CHUNK_VALUES = 4_000_000  #: joint coordinates per chunk of samples (about 32 MB of float64 per array)
MEASURES = ("com_x", "com_y", "com_z", "left_knee", "right_knee", "left_hip", "right_hip", "left_elbow", "right_elbow",
            "left_shoulder", "right_shoulder", "split", "inclination", "somersault", "twist")


def per_frame(X: np.ndarray, normal: np.ndarray | None, body: str) -> dict[str, np.ndarray]:
    """Per-frame measures of joints X (S, M, K, 3): (S, M) arrays; somersault and twist wrapped (radians)."""
    out = frame_angles(X)
    com, fb = centre_of_mass(X, body)
    out["com_x"], out["com_y"], out["com_z"] = com[..., 0], com[..., 1], com[..., 2]
    out["com_fallback"] = fb
    if normal is not None:
        rot = raw_rotation(X, normal, np.fmin(out["left_hip"], out["right_hip"]))
        out.update(rot)
    else:
        nan = np.full(X.shape[:-2], np.nan)
        out.update(somersault=nan, twist=nan.copy(), pelvis=np.zeros(nan.shape, bool), disagree=np.zeros(nan.shape, bool))
    return out


def measure_samples(J, segs, fps: float, cutoff_hz, normal, body: str, samples: int, seed: int):
    """Returns (cols, raw, Xf): cols name -> (1 + samples, M) (row 0 the measurement; somersault and
    twist unwrapped, degrees), raw: the measurement's per-frame flags (``com_fallback``, ``pelvis``,
    ``disagree``), Xf: the measurement's filtered joints (M, K, 3)."""
    rng = np.random.default_rng(seed)
    M = len(J.frame)
    sig = np.nan_to_num(J.sigma, nan=0.0)[None, :, :, None]
    cols = {m: np.empty((1 + samples, M)) for m in MEASURES}
    raw: dict = {}
    Xf0 = None
    valid = None
    done = 0
    chunk = max(1, CHUNK_VALUES // max(J.X.size, 1))
    while done < 1 + samples:
        n = min(chunk, 1 + samples - done)
        X = np.repeat(J.X[None], n, axis=0)
        k0 = 0
        if done == 0:  # row 0: the measurement itself
            k0 = 1
        if n > k0:
            X[k0:] += rng.standard_normal((n - k0,) + J.X.shape) * sig
        X = filter_joints(X, segs, fps, cutoff_hz)
        pf = per_frame(X, normal, body)
        if done == 0:
            Xf0 = X[0]
            raw = {"com_fallback": pf["com_fallback"][0], "pelvis": pf["pelvis"][0], "disagree": pf["disagree"][0]}
            valid_s, valid_t = np.isfinite(pf["somersault"][0]), np.isfinite(pf["twist"][0])
            valid = (valid_s, valid_t)
        for m in MEASURES:
            v = pf[m]
            if m == "somersault":
                v = np.degrees(unwrap(v, valid[0]))
            elif m == "twist":
                v = np.degrees(unwrap(v, valid[1]))
            cols[m][done:done + n] = v
        done += n
    return cols, raw, Xf0
