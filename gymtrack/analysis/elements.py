"""Landings, holds, circles about a bar and turns on support.

Paper: Section III-D, last paragraph and Fig. 8 (the pose sequence segmented into what the Code
of Points judges). Rules (``shared/formats.md``) and their refinements (``docs/analysis.md``):

* landing: after a flight that ends on the floor; ``steps`` = foot relocations over
  :data:`STEP_M` in the 2 s after the first contact. Refined: a relocation is a foot *lifted*
  (:data:`LIFT_M` above its planted height) and put down elsewhere, between two stationary
  phases; the slide of the landing's absorption and a pivot on the spot are not steps.
* hold: at least 1.0 s with every joint slower than 0.1 m/s. Refined: the speed over
  +-:data:`SPEED_HALF_S` and "slower" within three standard deviations of its noise, so a still
  body measured with 2 cm joint noise is still.
* circle: one element per full 360 deg of somersault while both hands hold a bar, counted inside
  each run of one rotation direction (a swing's reversal starts a new run); a grip lost for up to
  0.15 s (joint noise) is one grip.
* turn: at least 90 deg about the vertical on support, rounded to 90. Refined: on the spot (the
  centre of mass is within 0.6 m of where the turn began 1 s after it ends), so turning into a walk is not a turn; 85 deg count
  (a turn sampled at the frame rate ends a few degrees short).

Inputs are (S, M) per-frame columns (row 0 the measurement, rows 1.. Monte Carlo samples) and
the measurement's joints ``X`` (M, K, 3).
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d

from ..turns import full_turns
from .flights import runs
from .support import ANKLES, NONE

STEP_M, LIFT_M, LANDING_S = 0.10, 0.05, 2.0
STILL_MPS = 0.30  #: a foot slower than this (and on the floor) is planted
HOLD_S, HOLD_MPS, SPEED_HALF_S = 1.0, 0.10, 0.1
HOLD_SDS, HOLD_GAP = 3.0, 2  #: a joint is fast when its speed less 3 sd of noise passes HOLD_MPS; gaps of 2 rows close
TURN_MIN_DEG, TURN_RATE_DEG_S, TURN_TRAVEL_M, TURN_AFTER_S = 85.0, 30.0, 0.5, 0.3
TURN_SMOOTH_S = 0.05  #: the heading's Gaussian smoothing (s) before its rate is read
GRIP_GAP_S = 0.15  #: a hand seen off the bar this briefly (joint noise) still holds it


def _sd(v: np.ndarray) -> float | None:
    return round(float(np.nanstd(v[1:])), 4) if len(v) > 1 and np.isfinite(v[1:]).any() else None


def landings(frame: np.ndarray, X: np.ndarray, sigma: np.ndarray, feet_h: np.ndarray, fps: float,
             rows: list[int]) -> list[dict]:
    """A landing record for each first-contact row in ``rows``."""
    out = []
    for r in rows:
        w = np.flatnonzero((frame >= frame[r]) & (frame <= frame[r] + LANDING_S * fps))
        steps, largest = 0, 0.0
        missing = {}
        for side, k in enumerate(ANKLES):
            xy, h = X[w, k, :2], feet_h[w, side]
            if not np.isfinite(xy).all():
                missing["steps"] = "an ankle is missing in the 2 s after the landing"
                continue
            v = np.linalg.norm(np.gradient(xy, axis=0), axis=1) * fps if len(w) > 1 else np.zeros(len(w))
            planted = (v < STILL_MPS) & (h < 0.10)
            phases = runs(planted, frame[w])
            for (a0, a1), (b0, b1) in zip(phases[:-1], phases[1:]):
                d = float(np.linalg.norm(xy[b0] - xy[a1]))
                lifted = np.nanmax(h[a1:b0 + 1]) - max(h[a1], h[b0]) > LIFT_M
                if d > STEP_M and lifted:
                    steps += 1
                    largest = max(largest, d)
        el = {"kind": "landing", "frame": int(frame[r])}
        if "steps" in missing:
            el.update(steps=None, largest_step=None, stuck=None, missing=missing | {"largest_step": missing["steps"],
                                                                                   "stuck": missing["steps"]})
        else:
            s_ank = np.nanmean(sigma[w][:, list(ANKLES)]) if len(w) else np.nan
            el.update(steps=steps, largest_step=round(largest, 4), stuck=steps == 0,
                      largest_step_sd=round(float(np.sqrt(2) * s_ank), 4) if np.isfinite(s_ank) else None)
        out.append(el)
    return out


def merge_touching(spans: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """Inclusive spans, overlapping or adjacent ones joined."""
    return merge(sorted(spans), 0)


def joint_speed(frame: np.ndarray, X: np.ndarray, sigma: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """(M, K) each joint's speed (m/s) over +-SPEED_HALF_S and its noise sd (NaN at the ends)."""
    h = max(1, int(round(SPEED_HALF_S * fps)))
    M = len(frame)
    v = np.full(X.shape[:2], np.nan)
    sd = np.full(X.shape[:2], np.nan)
    if M > 2 * h:
        dt = (frame[2 * h:] - frame[:-2 * h]) / fps
        v[h:-h] = np.linalg.norm(X[2 * h:] - X[:-2 * h], axis=-1) / dt[:, None]
        sd[h:-h] = np.sqrt(sigma[2 * h:] ** 2 + sigma[:-2 * h] ** 2) / dt[:, None]
    return v, sd


def holds(frame: np.ndarray, X: np.ndarray, sigma: np.ndarray, incl: np.ndarray, fps: float) -> list[dict]:
    """Hold records: at least HOLD_S with every joint still; incl (S, M) inclination samples."""
    v, sd = joint_speed(frame, X, sigma, fps)
    with np.errstate(invalid="ignore"):
        fast = np.nan_to_num(v - HOLD_SDS * np.nan_to_num(sd), nan=0.0) >= HOLD_MPS
        seen = np.isfinite(v).sum(1) >= 8
    still = ~fast.any(1) & seen
    # the +-h window blurs a hold's ends by up to h rows: extend a run while each one-row step is still
    h = max(1, int(round(SPEED_HALF_S * fps)))
    step = np.linalg.norm(np.diff(X, axis=0), axis=-1) * fps / np.maximum(np.diff(frame), 1)[:, None]
    with np.errstate(invalid="ignore"):
        calm = ~np.any(np.nan_to_num(step, nan=0.0) >= HOLD_MPS, axis=1)  # (M-1,) strict: no noise allowance
    spans = []
    for a, b in merge(runs(still, frame), HOLD_GAP):
        for _ in range(h):
            if a > 0 and calm[a - 1]:
                a -= 1
        for _ in range(h):
            if b < len(frame) - 1 and calm[b]:
                b += 1
        spans.append((a, b))
    out = []
    for a, b in merge_touching(spans):
        dur = (frame[b] - frame[a] + 1) / fps
        if dur < HOLD_S - 1e-9:
            continue
        inc = np.nanmean(incl[:, a:b + 1], axis=1)
        m = inc[0]
        pos = "handstand" if m >= 150 else "horizontal" if 60 <= m <= 120 else "upright" if m <= 30 else "other"
        dev = {"handstand": 180 - inc, "horizontal": np.abs(90 - inc), "upright": inc}.get(pos)
        el = {"kind": "hold", "start_frame": int(frame[a]), "end_frame": int(frame[b]), "duration_s": round(dur, 4),
              "position": pos, "inclination": round(float(m), 2)}
        if dev is None:
            el["deviation"] = None
            el["missing"] = {"deviation": "a hold in no named position has no reference to deviate from"}
        else:
            el["deviation"] = round(float(dev[0]), 2)
            if (s := _sd(dev)) is not None:
                el["deviation_sd"] = round(s, 2)
        out.append(el)
    return out


def circles(frame: np.ndarray, som: np.ndarray, grip: np.ndarray, fps: float) -> list[dict]:
    """One circle record per full turn of somersault (degrees, (M,)) while the hands hold a bar
    (:func:`gymtrack.turns.full_turns` on each run of grip, brief gaps of :data:`GRIP_GAP_S` closed
    and the somersault interpolated across them)."""
    out = []
    for a, b in merge(runs(grip & np.isfinite(som), frame), int(round(GRIP_GAP_S * fps))):
        ok = np.isfinite(som[a:b + 1])
        s = np.interp(np.arange(a, b + 1), np.flatnonzero(ok) + a, som[a:b + 1][ok])
        for start, end, d in full_turns(s, frame[a:b + 1], fps):
            out.append({"kind": "circle", "start_frame": int(frame[a + start]), "end_frame": int(frame[a + end]),
                        "turns": 1, "direction": int(d)})
    return out


def merge(spans: list[tuple[int, int]], gap: int) -> list[tuple[int, int]]:
    """Inclusive spans joined where fewer than ``gap`` rows separate them."""
    out: list[list[int]] = []
    for p, q in spans:
        if out and p - out[-1][1] - 1 <= gap:
            out[-1][1] = q
        else:
            out.append([p, q])
    return [(p, q) for p, q in out]


def turns(frame: np.ndarray, heading: np.ndarray, support: np.ndarray, incl: np.ndarray, com: np.ndarray,
          fps: float) -> list[dict]:
    """Turn (pivot) records from the heading (radians, (M,)) on support while upright."""
    out = []
    ok = (support != NONE) & np.isfinite(heading) & (np.nan_to_num(incl, nan=180) < 45)
    for a, b in runs(ok, frame):
        hd = np.degrees(np.unwrap(heading[a:b + 1]))
        if len(hd) < 3:
            continue
        hd = gaussian_filter1d(hd, TURN_SMOOTH_S * fps, mode="nearest")  # a turn takes 0.4 s or more
        rate = np.gradient(hd) * fps
        gap = int(round(0.2 * fps))  # one turn's pauses; a turn back the other way is another turn
        spans = sorted(merge(runs(rate > TURN_RATE_DEG_S, frame[a:b + 1]), gap)
                       + merge(runs(rate < -TURN_RATE_DEG_S, frame[a:b + 1]), gap))
        for p, q in spans:
            sign = np.sign(hd[q] - hd[p])
            p0, q1 = p, q  # the slow ends of the same turn (up to 0.2 s): a turn starts and ends at rest
            while p0 > max(0, p - gap) and sign * rate[p0 - 1] > TURN_RATE_DEG_S / 10:
                p0 -= 1
            while q1 < min(len(hd) - 1, q + gap) and sign * rate[q1 + 1] > TURN_RATE_DEG_S / 10:
                q1 += 1
            delta = hd[q1] - hd[p0]
            if abs(delta) < TURN_MIN_DEG:
                continue
            if frame[-1] < frame[a + q] + TURN_AFTER_S * fps:  # the data end before "on the spot" can be told
                continue
            after = np.flatnonzero((frame >= frame[a + p]) & (frame <= frame[a + q] + TURN_AFTER_S * fps))
            travel = np.linalg.norm(com[after[-1], :2] - com[a + p, :2])  # walking on after turning is no turn
            if not travel <= TURN_TRAVEL_M:
                continue
            out.append({"kind": "turn", "start_frame": int(frame[a + p]), "end_frame": int(frame[a + q]),
                        "degrees": float(90 * round(abs(delta) / 90)), "direction": int(np.sign(delta)),
                        "turn_deg": round(float(delta), 1)})
    return out
