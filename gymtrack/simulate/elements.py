"""The target's elements as the choreography made them: ``gt/elements.json``.

Paper: Section III-D, last paragraph and Fig. 8 (the 3D pose sequence segmented and measured for
the judges); the rules are ``shared/formats.md``, "Outputs of the analysis stage". This is the
ground truth the analysis stage is scored against (:mod:`gymtrack.eval.elements`).

Every element starts from a record the motion builder made while it appended the phase
(:meth:`~gymtrack.simulate.motion.MotionBuilder.record`): a ballistic flight, a floor landing, a
pose held on the feet or on a grip, a giant about a bar, a turn on the spot. Nothing is detected
from the motion. Where the contract's definition needs the motion, its rule is applied to the
simulator's exact state, never to a measured skeleton:

- flight: its frames are the ballistic ones (``Motion.flight``), kept when they last >= 0.15 s;
  saltos and twists are the contract's, on the true joints (:func:`joint_rotations`: the long axis
  H->S in the plane, the pelvis line about it; the simulator's body frame is the feet-to-head
  axis, which a crouch's trunk lean of 15-35 deg leaves upright, enough to flip a quarter-salto
  rounding), counted by the contract's rule from the most upright frame of the 1.5 s before take-off
  to that of the 1.5 s after landing. Inclination (A->S) and the hip, knee and split angles come
  from the true skeleton. Refinements: among frames whose inclination lies within
  :data:`UPRIGHT_TOL_DEG` of the window's smallest, the one nearest the flight is taken (standing
  still ties to 1e-12 deg, and a giant passes the hang twice in 1.5 s; the nearest is the one the
  judges count); the windows stop at the neighbouring flights (a vault's hurdle, pre-flight and
  post-flight lie within 1.5 s: each counts only its own support phases, never another flight's
  rotation); a flight that leaves from a handstand the body held (inclination >= 150 deg, the
  contract's handstand, the long axis A->S turning slower than :data:`STILL_DEG_S` over
  :data:`STILL_SPAN_S` either side) counts from that handstand where it is nearer the take-off than
  the upright frame: the rotation runs from the position the element starts from (the pommel
  horse's dismount from handstand over the horse is half a revolution). ``apex_z``, ``height_gain`` and ``distance`` are left out: they
  are the analysis' readings of the centre of mass (de Leva on the joints, which the simulator's
  flights keep on the parabola: :meth:`~gymtrack.simulate.motion.MotionBuilder.flight`), so the
  eval reads their truth off ``gt/keypoints_3d.csv`` itself.
- landing: the choreography never steps after a landing: ``steps`` 0, ``stuck``.
- hold: the still part (every true joint slower than 0.1 m/s, >= 1 s) of a held pose, extended
  over the slow ends of its neighbours.
- circle: one element per full 360 deg of the contract's somersault (as the flights') while the
  hands hold the bar (the builder's grip phases: giants, swings, casts, kips, holds), counted from
  the start of each run of one direction (by :func:`gymtrack.turns.full_turns`, the analysis' own
  rule: a giant from handstand to handstand, sampled, stops a degree or two short of 360): a cast to
  handstand that runs on into giants turns with them, and its half turn counts.
- turn: a turn on support and on the spot, of at least 90 deg (less 5 deg: :data:`MIN_TURN_DEG`),
  rounded to 90: a pivot (beam), a turn standing (to face the judges, the apparatus), and the
  heading's turn as a walk sets off when the body moves under 0.5 m while turning and 0.3 s after
  (a slow walk back along the beam; walking round a corner is no turn element). A turn that
  follows another the same way without a frame of rest is one turn with it (two half pivots back
  to back: the analysis reads turns from rest to rest).
"""

from __future__ import annotations

import numpy as np

from ..apparatus import Apparatus
from ..turns import full_turns

UPRIGHT_WINDOW_S = 1.5  #: the contract's window before take-off and after landing
UPRIGHT_TOL_DEG = 10.0  #: frames this close to the window's most upright one count as upright
HANDSTAND_DEG = 150.0  #: the contract's handstand
STILL_DEG_S = 45.0  #: deg/s: a long axis turning slower than this holds its position
STILL_SPAN_S = 0.1  #: s: the turn rate over this much either side of a frame
MIN_FLIGHT_S = 0.15
HOLD_SPEED = 0.1  #: m/s
MIN_HOLD_S = 1.0
MIN_TURN_DEG = 85.0  #: "at least 90 deg", less a frame's worth (a turn to face the judges ends a hair short)
NO_COM = ("a reading of the centre of mass (de Leva on the joints): "
          "the true value is the analysis of gt/keypoints_3d.csv")

# COCO-17 joint indices
_LS, _RS, _LH, _RH, _LK, _RK, _LA, _RA = 5, 6, 11, 12, 13, 14, 15, 16


def _included(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(n,) the angle at ``b`` between b->a and b->c, degrees; inputs (n, 3)."""
    u, v = a - b, c - b
    cos = np.einsum("ij,ij->i", u, v) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def body_angles(kp: np.ndarray) -> dict[str, np.ndarray]:
    """The contract's per-frame hip (n, 2), knee (n, 2), split (n,) and inclination (n,) angles of
    COCO-17 joints ``kp`` (n, 17, 3), degrees."""
    S = 0.5 * (kp[:, _LS] + kp[:, _RS])
    A = 0.5 * (kp[:, _LA] + kp[:, _RA])
    hip = np.column_stack([_included(S, kp[:, _LH], kp[:, _LK]), _included(S, kp[:, _RH], kp[:, _RK])])
    knee = np.column_stack([_included(kp[:, _LH], kp[:, _LK], kp[:, _LA]), _included(kp[:, _RH], kp[:, _RK], kp[:, _RA])])
    split = _included(kp[:, _LA] - kp[:, _LH], np.zeros_like(S), kp[:, _RA] - kp[:, _RH])
    axis = S - A
    incl = np.degrees(np.arccos(np.clip(axis[:, 2] / np.linalg.norm(axis, axis=1), -1.0, 1.0)))
    return {"hip": hip, "knee": knee, "split": split, "inclination": incl, "axis": axis}


def held_handstand(axis: np.ndarray, incl: np.ndarray, fps: float) -> np.ndarray:
    """(n,) bool: a handstand held -- inclination >= :data:`HANDSTAND_DEG` and the long axis
    ``axis`` (n, 3) turning slower than :data:`STILL_DEG_S` between the frames :data:`STILL_SPAN_S`
    before and after (frames without both are not held)."""
    k = max(1, int(round(STILL_SPAN_S * fps)))
    out = np.zeros(len(incl), bool)
    if len(incl) <= 2 * k:
        return out
    u = axis / np.linalg.norm(axis, axis=1, keepdims=True)
    a, b = u[:-2 * k], u[2 * k:]
    turn = np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.sum(a * b, 1)))
    out[k:-k] = (turn * fps / (2 * k) < STILL_DEG_S) & (incl[k:-k] >= HANDSTAND_DEG)
    return out


def rotations(yaw: np.ndarray, pitch: np.ndarray, twist: np.ndarray, normal) -> tuple[np.ndarray, np.ndarray]:
    """(n,) somersault and twist (degrees, 0 at the first frame): the angular velocity of the body
    frame ``Rz(yaw) Ry(pitch) Rz(twist)`` integrated about ``normal`` (right-hand rule) and about
    the body's long axis, frame to frame at the mid-step orientation."""
    n = np.asarray(normal, float)
    dy, dp, dt = np.diff(yaw), np.diff(pitch), np.diff(twist)
    ym, pm = 0.5 * (yaw[1:] + yaw[:-1]), 0.5 * (pitch[1:] + pitch[:-1])
    left = np.column_stack([-np.sin(ym), np.cos(ym), np.zeros_like(ym)])  # the pitch axis
    long = np.column_stack([np.sin(pm) * np.cos(ym), np.sin(pm) * np.sin(ym), np.cos(pm)])  # the twist axis
    d_som = dp * (left @ n) + dt * (long @ n) + dy * n[2]
    d_tw = dt + dy * np.cos(pm)
    return (np.degrees(np.concatenate([[0.0], np.cumsum(d_som)])),
            np.degrees(np.concatenate([[0.0], np.cumsum(d_tw)])))


def joint_rotations(kp: np.ndarray, normal) -> tuple[np.ndarray, np.ndarray]:
    """(n,) somersault and twist (degrees, 0 at the first frame) by the contract, on the joints ``kp``
    (n, 17, 3): the long axis L = H->S (mid-hip to mid-shoulder), the somersault its angle in the
    plane about ``normal`` from +z (right-hand), the twist the pelvis line's angle about L from the
    normal made perpendicular to L (the simulated pelvis and shoulder lines stay parallel), both
    unwrapped frame to frame. Frames with L within 15 deg of the normal (no somersault defined)
    keep the previous value."""
    n = np.asarray(normal, float)
    z = np.array([0.0, 0.0, 1.0])
    e = np.cross(n, z)
    S = 0.5 * (kp[:, _LS] + kp[:, _RS])
    H = 0.5 * (kp[:, _LH] + kp[:, _RH])
    L = (S - H) / np.linalg.norm(S - H, axis=1, keepdims=True)
    som = np.arctan2(L @ e, L @ z)
    ref = n[None] - (L @ n)[:, None] * L
    ref /= np.maximum(np.linalg.norm(ref, axis=1, keepdims=True), 1e-12)
    pe = kp[:, _LH] - kp[:, _RH]
    pe = pe - np.sum(pe * L, 1, keepdims=True) * L
    tw = np.arctan2(np.sum(np.cross(ref, pe) * L, 1), np.sum(ref * pe, 1))
    ok = np.abs(L @ n) <= np.cos(np.radians(15.0))
    idx = np.maximum.accumulate(np.where(ok, np.arange(len(ok)), 0))  # a locked frame takes the last defined one
    som, tw = np.unwrap(som[idx]), np.unwrap(tw[idx])
    return np.degrees(som - som[0]), np.degrees(tw - tw[0])


def upright_frame(incl: np.ndarray, lo: int, hi: int, near: int, held: np.ndarray | None = None) -> int | None:
    """The frame of ``lo..hi`` (clipped to the routine) closest to upright, by the contract's rule
    with :data:`UPRIGHT_TOL_DEG`'s refinement (the nearest to ``near`` of the near-most-upright)
    and, with ``held`` (n,) bool, the frames of a held handstand among the candidates; None where
    the window has no frame."""
    lo, hi = max(lo, 0), min(hi, incl.size - 1)
    if hi < lo:
        return None
    w = incl[lo:hi + 1]
    ok = w <= np.nanmin(w) + UPRIGHT_TOL_DEG
    if held is not None:
        ok |= held[lo:hi + 1]
    cand = np.flatnonzero(ok) + lo
    return int(cand[np.argmin(np.abs(cand - near))])


def _flight(s: int, e: int, bounds: tuple[int, int], fps: float, ang: dict, som: np.ndarray, tw: np.ndarray) -> dict:
    win = int(round(UPRIGHT_WINDOW_S * fps))
    incl = ang["inclination"]
    pre = upright_frame(incl, max(s - win, bounds[0]), s - 1, s - 1, held_handstand(ang["axis"], incl, fps))
    post = upright_frame(incl, e + 1, min(e + win, bounds[1]), e + 1)
    pre, post = (s if pre is None else pre), (e if post is None else post)
    som_deg, tw_deg = float(som[post] - som[pre]), float(tw[post] - tw[pre])
    hip, knee = ang["hip"][s:e + 1], ang["knee"][s:e + 1]
    hmax, kmax = hip.max(axis=1), knee.max(axis=1)
    c = int(np.argmin(hmax + kmax))  # the most closed frame
    L = e - s + 1
    mid = np.minimum(hip, knee).min(axis=1)[L // 4: L - L // 4]
    if hmax[c] < 90 and kmax[c] < 90:
        shape = "tuck"
    elif hmax[c] < 90 and knee[c].min() >= 135:
        shape = "pike"
    elif mid.size and mid.min() >= 135:
        shape = "layout"
    else:
        shape = "open"
    return {"kind": "flight", "start_frame": s + 1, "end_frame": e + 1, "duration_s": round(L / fps, 4),
            "somersault_deg": round(som_deg, 2), "saltos": float(np.round(som_deg / 90.0) / 4),
            "twist_deg": round(tw_deg, 2), "twists": float(np.round(tw_deg / 180.0) / 2),
            "airborne_somersault_deg": round(float(som[e] - som[s]), 2), "airborne_twist_deg": round(float(tw[e] - tw[s]), 2),
            "shape": shape, "min_hip": round(float(hip.min()), 2), "min_knee": round(float(knee.min()), 2),
            "max_split": round(float(ang["split"][s:e + 1].max()), 2),
            "upright_frames": [pre + 1, post + 1]}


def still_runs(kp: np.ndarray, fps: float) -> np.ndarray:
    """(R, 2) first and last index of every run of frames in which every joint moves slower than
    :data:`HOLD_SPEED` from frame to frame (a run of one frame has no speed and is left out)."""
    speed = np.linalg.norm(np.diff(kp, axis=0), axis=2).max(axis=1) * fps
    slow = np.concatenate([[0], (speed < HOLD_SPEED).astype(np.int8), [0]])
    d = np.diff(slow)
    starts, stops = np.flatnonzero(d == 1), np.flatnonzero(d == -1)  # slow steps starts..stops-1 (step i: i -> i+1)
    return np.column_stack([starts, stops])


def _hold(a: int, b: int, fps: float, incl: np.ndarray) -> dict:
    m = float(np.mean(incl[a:b + 1]))
    if m >= 150:
        position, dev = "handstand", 180.0 - incl[a:b + 1]
    elif 60 <= m <= 120:
        position, dev = "horizontal", np.abs(90.0 - incl[a:b + 1])
    elif m <= 30:
        position, dev = "upright", incl[a:b + 1]
    else:
        position, dev = "other", None
    out = {"kind": "hold", "start_frame": a + 1, "end_frame": b + 1, "duration_s": round((b - a + 1) / fps, 4),
           "position": position}
    if dev is not None:
        out["deviation"] = round(float(np.mean(dev)), 2)
    return out


def grip_runs(grips: list[dict]) -> list[tuple[int, int]]:
    """(first, last) frames of the runs of contiguous grip records: the hands on the bar or rings
    throughout (a flight or a stand in between ends a run)."""
    runs: list[list[int]] = []
    for r in sorted(grips, key=lambda r: r["start"]):
        if runs and r["start"] <= runs[-1][1] + 1:
            runs[-1][1] = max(runs[-1][1], r["end"])
        else:
            runs.append([r["start"], r["end"]])
    return [(a, b) for a, b in runs]


def _circles(grips: list[dict], som: np.ndarray, fps: float) -> list[dict]:
    """One element per full turn of somersault while the hands hold the bar: the analysis' rule
    (:func:`gymtrack.turns.full_turns`) on each grip run (:func:`grip_runs`)."""
    out = []
    for a, b in grip_runs(grips):
        for start, end, _ in full_turns(som[a:b + 1], np.arange(a, b + 1), fps):
            out.append({"kind": "circle", "start_frame": a + start + 1, "end_frame": a + end + 1, "turns": 1})
    return out


def _joined_turns(turns: list[dict]) -> list[dict]:
    """Turn records in frame order, a turn that follows another the same way with no frame of rest
    between joined to it: two half pivots back to back are one full turn to the eye."""
    out: list[dict] = []
    for r in sorted(turns, key=lambda r: r["start"]):
        if out and r["start"] == out[-1]["end"] + 1 and np.sign(r["degrees"]) == np.sign(out[-1]["degrees"]):
            out[-1] = dict(out[-1], end=r["end"], degrees=out[-1]["degrees"] + r["degrees"])
        else:
            out.append(dict(r))
    return out


def ground_truth_elements(records: list[dict], yaw: np.ndarray, pitch: np.ndarray, twist: np.ndarray, keypoints: np.ndarray,
                          app: Apparatus, fps: float, track_id: int) -> dict:
    """The ``gt/elements.json`` document of the target.

    records: the motion builder's element records (0-based frames); yaw, pitch, twist: (T,) the
    target's orientation, radians (unused: the contract's rotations are the joints'; kept for the
    callers); keypoints: (T, 17, 3) its true COCO-17 joints (drift included,
    as written to ``gt/keypoints_3d.csv``); app: the apparatus (its
    :attr:`~gymtrack.apparatus.Apparatus.somersault_axis`: the plane's normal, the pommel horse's length).
    """
    ang = body_angles(keypoints)
    som, tw = joint_rotations(keypoints, app.somersault_axis)  # the contract's somersault and twist
    els: list[dict] = []
    flights = sorted((r["start"], r["end"]) for r in records if r["kind"] == "flight")
    for i, (s, e) in enumerate(flights):
        if (e - s + 1) / fps >= MIN_FLIGHT_S - 1e-9:  # the upright windows stop at the flights before and after
            bounds = (flights[i - 1][1] + 1 if i else 0, flights[i + 1][0] - 1 if i + 1 < len(flights) else len(som) - 1)
            els.append(_flight(s, e, bounds, fps, ang, som, tw))
    for r in records:
        if r["kind"] == "landing":
            els.append({"kind": "landing", "frame": r["start"] + 1, "steps": 0, "largest_step": 0.0, "stuck": True})
    for r in _joined_turns([r for r in records if r["kind"] == "turn"]):
        if abs(r["degrees"]) >= MIN_TURN_DEG - 1e-6:
            els.append({"kind": "turn", "start_frame": r["start"] + 1, "end_frame": r["end"] + 1,
                        "degrees": float(90 * np.round(abs(r["degrees"]) / 90.0))})
    runs = still_runs(keypoints, fps)
    held = set()
    for r in records:
        if r["kind"] == "still":
            hit = np.flatnonzero((runs[:, 0] <= r["end"]) & (runs[:, 1] >= r["start"]))
            held.update(int(i) for i in hit)
    for i in sorted(held):
        a, b = int(runs[i, 0]), int(runs[i, 1])
        if (b - a + 1) / fps >= MIN_HOLD_S - 1e-9:
            els.append(_hold(a, b, fps, ang["inclination"]))
    els += _circles([r for r in records if r["kind"] == "grip"], som, fps)
    return {"track_id": int(track_id), "fps": float(fps), "apparatus": app.name, "source": "ground truth",
            "elements": els, "missing": {"apex_z": NO_COM, "height_gain": NO_COM, "distance": NO_COM}}
