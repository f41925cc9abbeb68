"""Flights: airborne runs, their timing (sub-frame from the ballistic parabola), height, distance,
saltos, twists and shape.

Paper: Section III-D, last paragraph and Fig. 8. Rules (``shared/formats.md``, ``flight``): a
maximal run of rows with support ``none`` lasting at least :data:`MIN_FLIGHT_S`; ``somersault_deg``
and ``twist_deg`` from the most upright frame of the 1.5 s before take-off to that of the 1.5 s
after landing; saltos rounded to 0.25, twists to 0.5; shape tuck / pike / layout / open.
Refinements (``docs/analysis.md``): the windows stop at a neighbouring flight; of the frames within
:data:`UPRIGHT_TOL` of a window's most upright one, the one nearest the flight is taken (a turn to
the judges after standing up is not the salto's twist). A flight that leaves from a handstand the
body held (inclination at least :data:`HANDSTAND`, the long axis turning slower than
:data:`STILL_DEG_S`) counts from that handstand where it is nearer the take-off than the upright
frame: the rotation runs from the position the element starts from (a pommel horse dismount over
the horse from handstand is half a revolution, not the quarters its circles' tilt would add).

Measures are computed on every Monte Carlo sample at once: ``cols[name]`` is (S, M), row 0 the
measurement, rows 1.. the samples (:mod:`.uncertainty`).
"""

from __future__ import annotations

import numpy as np

from .support import FLOOR, NONE

G = 9.81  #: m/s^2
MIN_FLIGHT_S = 0.15
BALLISTIC = 0.5  #: a flight's fitted vertical acceleration lies within this share of g from -g
WINDOW_S = 1.5
UPRIGHT_TOL = 10.0  #: degrees (the simulator's ground truth uses the same)
SHAPE_CLOSED, SHAPE_OPEN = 90.0, 135.0
SHAPE_SDS = 2.0  #: a middle-half frame breaks a layout only this many sd under SHAPE_OPEN
SHAPE_HELD_S = 1.0 / 6.0  #: s: a noisy measurement's shape is read as held over this long (5 frames at 30 Hz)
SHAPE_NOISY_DEG = 5.0  #: deg: the angles' median sd from which a flight's shape is read as held
V_MAX = 12.0  #: m/s: the centre of mass moves no faster (a sprinter's top speed; a vault's run-up reaches 8-9)
HANDSTAND = 150.0  #: degrees: the contract's handstand (its hold position)
STILL_DEG_S = 45.0  #: deg/s: a long axis turning slower than this holds its position (a giant passes its handstand at 150+)
STILL_SPAN_S = 0.1  #: s: the turn rate over this much either side of a frame
NO_TURN_DEG = 45.0  #: degrees: a run whose somersault spans less does not turn over (its box centre keeps to its centre of mass)
PARABOLA_CHI = 2.0  #: the centre of mass' weighted rms residual (in sd) within which one parabola holds


def runs(mask: np.ndarray, frame: np.ndarray, max_gap: int = 2) -> list[tuple[int, int]]:
    """[(first, last)] inclusive row ranges where ``mask`` holds over rows without a frame gap > max_gap."""
    if not mask.any():
        return []
    brk = np.concatenate([[True], (np.diff(frame) > max_gap) | ~mask[:-1]])
    start = mask & brk
    end = mask & np.concatenate([(np.diff(frame) > max_gap) | ~mask[1:], [True]])
    return list(zip(np.flatnonzero(start).tolist(), np.flatnonzero(end).tolist()))


def fall_rate(t: np.ndarray, z: np.ndarray, sigma: float | np.ndarray = 0.0) -> tuple[float, float]:
    """The vertical acceleration (m/s^2) of a free quadratic fitted to z(t) and its sd, for heights
    known to ``sigma`` (m; a scalar, or (n,) per row: then the fit is weighted by 1 / sigma^2, so
    a row the pose stage measured badly -- one view, a high reprojection error -- counts little);
    NaN under 4 points."""
    sig = np.broadcast_to(np.asarray(sigma, float), z.shape)
    ok = np.isfinite(z) & np.isfinite(sig)
    if ok.sum() < 4:
        return float("nan"), float("nan")
    tt = t[ok] - t[ok].mean()
    A = np.column_stack([np.ones(tt.size), tt, tt ** 2])
    s = sig[ok]
    if np.all(s > 0):
        w = 1.0 / s
        coef, *_ = np.linalg.lstsq(A * w[:, None], z[ok] * w, rcond=None)
        cov = np.linalg.pinv((A * w[:, None] ** 2).T @ A)
        return float(2 * coef[2]), float(2 * np.sqrt(cov[2, 2]))
    coef, *_ = np.linalg.lstsq(A, z[ok], rcond=None)
    cov = np.linalg.pinv(A.T @ A)
    return float(2 * coef[2]), float(2 * float(np.nanmax(s, initial=0.0)) * np.sqrt(cov[2, 2]))


def _seen(frame, com, fps, i, j) -> bool:
    """Row i (supported, next to the airborne row j) is the same body's take-off or landing: within
    MAX_GAP frames of it and within the reach of the fastest run (:data:`V_MAX`)."""
    if not (0 <= i < len(frame)) or abs(frame[i] - frame[j]) > 2:
        return False
    d = np.linalg.norm(com[i] - com[j])
    return bool(np.isfinite(d) and d <= V_MAX * abs(frame[i] - frame[j]) / fps)


def _thrown(t: np.ndarray, z: np.ndarray, xy: np.ndarray | None, sz) -> bool | None:
    """Whether one point (heights ``z``, horizontal path ``xy`` (n, 2) or None) moves like a thrown
    body: fitted vertical acceleration within BALLISTIC x g of -g and horizontal acceleration within
    BALLISTIC x g of 0, each or within 3 sd of it; None where the heights are too few to tell."""
    az, sd = fall_rate(t, z, sz)
    if not np.isfinite(az):
        return None
    if abs(az + G) > max(BALLISTIC * G, 3 * sd):
        return False
    if xy is None or not np.isfinite(xy).all():
        return True
    (ax, sx), (ay, sy) = fall_rate(t, xy[:, 0], sz), fall_rate(t, xy[:, 1], sz)
    ah = np.hypot(ax, ay)
    sh = np.hypot(ax * sx, ay * sy) / ah if ah > 0 else max(sx, sy)
    return bool(ah <= max(BALLISTIC * G, 3 * sh))


def find_flights(frame: np.ndarray, support: np.ndarray, fps: float, com_z: np.ndarray, box_z: np.ndarray,
                 sigma_z: np.ndarray | None = None, com: np.ndarray | None = None, may_hold: np.ndarray | None = None,
                 box_xy: np.ndarray | None = None, somersault: np.ndarray | None = None
                 ) -> tuple[list[tuple[int, int]], list[tuple[int, int]]]:
    """Row ranges (first, last) of the flights -- support none for at least MIN_FLIGHT_S, and the
    centre of mass or the centre of the joints' box falling like a thrown body (fitted acceleration
    within BALLISTIC x g of -g, or within 3 sd of it where the heights are too noisy to tell) -- and
    the runs off every surface that do not fall so (a coach's lift, a support the geometry misses)
    or whose take-off and landing are both unseen (no supported row next to the run that the same
    body could reach: poses of someone else, or of nobody).
    sigma_z: (M,) the heights' sd (m) per row (the fits are weighted by it); com: (M, 3) the centre
    of mass (None: the take-off and landing are not checked); may_hold: (M,) bool, a hand lies within
    reach of a bar given its noise (:func:`.support.hands_may_hold`): a run through which a hand
    may hold the bar at every row is a grip the noise hid, not a flight; box_xy: (M, 2) the horizontal
    centre of the joints' box; somersault: (M,) degrees. In the air no horizontal force acts: where
    the body does not turn over (the somersault spans under :data:`NO_TURN_DEG` through the run),
    the point read (the centre of mass with ``com``'s x, y, the box centre with ``box_xy``) must
    also keep its horizontal speed (acceleration within BALLISTIC x g of 0, or 3 sd). A coach's
    lift whose start the pose stage measured late (the skeleton left standing, then catching up by
    0.3 m in a frame) fits -g vertically, but the catch-up swings the upright body's centre sideways
    and back at 6-20 m/s^2. A body turning over moves its box centre (and a body model's centre of
    mass) off a line: the simulated vault's pre-flight turns the body over from the springboard to
    the table in 0.25 s, its box centre 5-6 m/s^2 off a line."""
    flights, lifted = [], []
    for a, b in runs(support == NONE, frame):
        if (frame[b] - frame[a] + 1) / fps < MIN_FLIGHT_S - 1e-9:
            continue
        if com is not None and not (_seen(frame, com, fps, a - 1, a) or _seen(frame, com, fps, b + 1, b)):
            lifted.append((a, b))  # neither the take-off nor the landing seen: poses of an unknown body
            continue
        if may_hold is not None and may_hold[a:b + 1].all():
            lifted.append((a, b))  # a hand never left the bar's reach: a grip lost in the noise
            continue
        t = frame[a:b + 1] / fps
        sz = sigma_z[a:b + 1] if sigma_z is not None and np.isfinite(sigma_z[a:b + 1]).all() else 0.0
        som = somersault[a:b + 1] if somersault is not None else np.array([np.nan])
        upright = bool(np.isfinite(som).any() and np.nanmax(som) - np.nanmin(som) < NO_TURN_DEG)
        verdicts = [_thrown(t, com_z[a:b + 1], com[a:b + 1, :2] if upright and com is not None else None, sz),
                    _thrown(t, box_z[a:b + 1], box_xy[a:b + 1] if upright and box_xy is not None else None, sz)]
        free = any(v is True for v in verdicts) or all(v is None for v in verdicts)
        (flights if free else lifted).append((a, b))
    return flights, lifted


def held_handstand(frame: np.ndarray, axis: np.ndarray, incl: np.ndarray, fps: float) -> np.ndarray:
    """(M,) bool: the body holds a handstand -- inclination at least :data:`HANDSTAND` and the long
    axis ``axis`` (M, 3; A->S) turning slower than :data:`STILL_DEG_S` between the rows
    :data:`STILL_SPAN_S` before and after (rows without both neighbours are not held)."""
    k = max(1, int(round(STILL_SPAN_S * fps)))
    out = np.zeros(len(frame), bool)
    if len(frame) <= 2 * k:
        return out
    with np.errstate(invalid="ignore", divide="ignore"):
        u = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
        a, b = u[:-2 * k], u[2 * k:]
        turn = np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, -1)))
        rate = turn / ((frame[2 * k:] - frame[:-2 * k]) / fps)
        out[k:-k] = (rate < STILL_DEG_S) & (incl[k:-k] >= HANDSTAND)
    return out


def _window_frame(frame, incl, rows, nearest_last: bool, held: np.ndarray | None = None) -> tuple[int | None, str]:
    """The row of ``rows`` closest to upright (within UPRIGHT_TOL of the least inclination) or, with
    ``held`` (M,) bool, in a held handstand: the one nearest the flight, and its position
    (``upright`` | ``handstand``); None if no row has an inclination."""
    rows = rows[np.isfinite(incl[rows])]
    if rows.size == 0:
        return None, "upright"
    near = rows[incl[rows] <= incl[rows].min() + UPRIGHT_TOL]
    if held is not None:
        near = np.union1d(near, rows[held[rows]])
    i = int(near[-1] if nearest_last else near[0])
    return i, "handstand" if held is not None and held[i] and incl[i] >= HANDSTAND else "upright"


def _crossing(t_a: float, z_a: float, v_a: float, coef: np.ndarray, lo: float, hi: float) -> float | None:
    """The time in [lo, hi] where the line z_a + v_a (t - t_a) meets the parabola coef (c0, c1) - g t^2 / 2."""
    c0, c1 = coef
    # -g/2 t^2 + (c1 - v_a) t + (c0 - z_a + v_a t_a) = 0
    r = np.roots([-G / 2, c1 - v_a, c0 - z_a + v_a * t_a])
    r = r[np.isreal(r)].real
    r = r[(r >= lo) & (r <= hi)]
    return float(r[np.argmin(np.abs(r - (lo + hi) / 2))]) if r.size else None


def parabola(t: np.ndarray, z: np.ndarray, w: np.ndarray | None = None):
    """Least-squares (c0, c1) of ``z = c0 + c1 t - g t^2 / 2`` (g = 9.81 fixed) and the rms residual;
    with weights ``w`` (1 / sd per row) also the rms of the weighted residuals (a third item)."""
    ok = np.isfinite(z)
    if ok.sum() < 3:
        return None
    A = np.column_stack([np.ones(ok.sum()), t[ok]])
    y = z[ok] + G / 2 * t[ok] ** 2
    if w is None:
        coef, *_ = np.linalg.lstsq(A, y, rcond=None)
        res = A @ coef - y
        return coef, float(np.sqrt(np.mean(res ** 2)))
    ww = np.asarray(w, float)[ok]
    coef, *_ = np.linalg.lstsq(A * ww[:, None], y * ww, rcond=None)
    res = A @ coef - y
    return coef, float(np.sqrt(np.mean(res ** 2))), float(np.sqrt(np.sum((res * ww) ** 2) / max(ok.sum() - 2, 1)))


def _sub_frame(frame, com_z, fps, a, b) -> dict:
    """Take-off and landing between frames from the parabola through the airborne centre of mass."""
    t = frame / fps
    fit = parabola(t[a:b + 1] - t[a], com_z[a:b + 1])
    if fit is None:
        return {}
    coef, rms = fit[:2]
    t0 = t[a]
    out = {"parabola_rms": round(rms, 4)}
    c0, c1 = coef

    def side(i, j, lo, hi):  # line through the supported rows i, j (j next to the flight)
        if not (0 <= i < len(frame) and 0 <= j < len(frame)) or not np.all(np.isfinite(com_z[[i, j]])):
            return None
        v = (com_z[j] - com_z[i]) / (t[j] - t[i])
        return _crossing(t[j] - t0, com_z[j], v, coef, lo, hi)

    gap = lambda i, j: 0 <= i < len(frame) and 0 <= j < len(frame) and abs(frame[j] - frame[i]) <= 2  # noqa: E731
    to = side(a - 2, a - 1, t[a - 1] - t0, 0.0) if gap(a - 1, a) else None
    ld = side(b + 2, b + 1, t[b] - t0, t[b + 1] - t0) if gap(b, b + 1) else None
    to = -0.5 / fps if to is None else to
    ld = t[b] - t0 + 0.5 / fps if ld is None else ld
    out["takeoff_frame"] = round(float(frame[a] + to * fps), 2)
    out["landing_frame"] = round(float(frame[a] + ld * fps), 2)
    out["flight_time_fit_s"] = round(float(ld - to), 4)
    t_apex = c1 / G
    if to <= t_apex <= ld:
        out["apex_z_fit"] = round(float(c0 + c1 * t_apex - G / 2 * t_apex ** 2), 4)
    return out


def held_angles(x: np.ndarray, w: int) -> np.ndarray:
    """(S, n) the centred ``w``-frame mean of each row of ``x`` (S, n), over the frames it has
    (NaN-aware; the ends average the frames within the flight)."""
    if w <= 1:
        return x
    k = w // 2
    pad = np.pad(x, [(0, 0), (k, k)], constant_values=np.nan)
    win = np.lib.stride_tricks.sliding_window_view(pad, w, axis=1)
    ok = np.isfinite(win)
    n = ok.sum(-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, np.where(ok, win, 0.0).sum(-1) / n, np.nan)


def shape_of(cols: dict, a: int, b: int, sd: dict | None = None, fps: float = 30.0) -> tuple[np.ndarray, int]:
    """(S,) shape codes (0 tuck, 1 pike, 2 layout, 3 open) per sample, and the nominal most closed row.

    sd: the knee and hip angles' per-row sd (degrees, (M,) each, :func:`.kinematics.angle_sd`).
    The contract's rule read on a noisy measurement:

    - where the angles' median sd over the flight is :data:`SHAPE_NOISY_DEG` or more, each angle
      is read as its mean over :data:`SHAPE_HELD_S` (the shape a judge sees is a held one, and a
      tuck or pike is held for 0.2-0.5 s of a salto): the most closed frame of single noisy frames
      is biased closed by about 1.5 sd, and one bad frame decides the shape. The mean's sd is taken
      as sd / sqrt(frames). A true or marker skeleton (sd about 1 deg) is read frame by frame;
    - the layout's "hips and knees >= 135 all through the middle half": the middle half's mean of
      the more bent side is at least :data:`SHAPE_OPEN`, and no frame lies under it by more than
      :data:`SHAPE_SDS` sd (a straight body measured with noise dips under 135 deg now and then; a
      body open to 125 deg stays under 135 on average). The pike's straight knees at the most closed
      frame are read with the same allowance."""
    names = ("left_hip", "right_hip", "left_knee", "right_knee")
    w = 1
    if sd is not None:
        med = np.nanmedian(np.concatenate([np.asarray(sd[n][a:b + 1], float) for n in names]))
        if np.isfinite(med) and med >= SHAPE_NOISY_DEG:
            w = max(1, 2 * int(round(SHAPE_HELD_S * fps / 2.0 - 0.5)) + 1)
    g = {n: held_angles(np.asarray(cols[n][:, a:b + 1], float), w) for n in names}

    def lo(name):  # the more bent side, each side with its own noise allowance
        left, right = g[f"left_{name}"], g[f"right_{name}"]
        if sd is not None:
            left = left + SHAPE_SDS * np.nan_to_num(sd[f"left_{name}"][a:b + 1]) / np.sqrt(w)
            right = right + SHAPE_SDS * np.nan_to_num(sd[f"right_{name}"][a:b + 1]) / np.sqrt(w)
        return np.fmin(left, right)

    hip = np.fmax(g["left_hip"], g["right_hip"])  # both hips under 90: the larger
    knee = np.fmax(g["left_knee"], g["right_knee"])
    hip_lo = np.fmin(g["left_hip"], g["right_hip"])
    knee_lo = np.fmin(g["left_knee"], g["right_knee"])
    hip_ok, knee_ok = lo("hip"), lo("knee")
    S, n = hip.shape
    closed = np.where(np.isfinite(hip), hip, np.inf)
    k = np.argmin(closed, axis=1)
    h_k, kn_k = hip[np.arange(S), k], knee[np.arange(S), k]
    kn_lo = knee_ok[np.arange(S), k]  # the pike's straight knees, with the layout's noise allowance
    q0, q1 = n // 4, max(n // 4 + 1, (3 * n + 3) // 4)
    with np.errstate(invalid="ignore"):
        layout = np.all((hip_ok[:, q0:q1] >= SHAPE_OPEN) & (knee_ok[:, q0:q1] >= SHAPE_OPEN), axis=1)
        if sd is not None:
            layout &= (np.nanmean(hip_lo[:, q0:q1], axis=1) >= SHAPE_OPEN) & (np.nanmean(knee_lo[:, q0:q1], axis=1) >= SHAPE_OPEN)
        code = np.where((h_k < SHAPE_CLOSED) & (kn_k < SHAPE_CLOSED), 0,
                        np.where((h_k < SHAPE_CLOSED) & (kn_lo >= SHAPE_OPEN), 1, np.where(layout, 2, 3)))
    code = np.where(np.isfinite(h_k) & np.isfinite(kn_k), code, -1)
    return code, int(a + k[0])


SHAPES = ("tuck", "pike", "layout", "open")


def flight_elements(frame: np.ndarray, cols: dict, support: np.ndarray, fps: float,
                    flights: list[tuple[int, int]], angle_sd: dict | None = None, held: np.ndarray | None = None
                    ) -> list[dict]:
    """The contract's flight records (plus ``<measure>_sd`` and the sub-frame fields) and, after a
    flight ending on the floor, the landing's first-contact row (``_landing_row``). held: (M,) bool,
    the rows of a held handstand (:func:`held_handstand`), a take-off position the count may start from."""
    out = []
    incl = cols["inclination"][0]
    win = int(round(WINDOW_S * fps))
    for k, (a, b) in enumerate(flights):
        prev_end = flights[k - 1][1] if k else -1
        next_start = flights[k + 1][0] if k + 1 < len(flights) else len(frame)
        rows = np.arange(len(frame))
        pre = rows[(rows > prev_end) & (rows < a) & (frame >= frame[a] - win)]
        post = rows[(rows > b) & (rows < next_start) & (frame <= frame[b] + win)]
        (i0, pos0), (i1, _) = _window_frame(frame, incl, pre, True, held), _window_frame(frame, incl, post, False)
        el: dict = {"kind": "flight", "start_frame": int(frame[a]), "end_frame": int(frame[b]),
                    "duration_s": round((frame[b] - frame[a] + 1) / fps, 4)}
        missing: dict = {}
        z = cols["com_z"]
        apex = np.nanmax(z[:, a:b + 1], axis=1) if np.isfinite(z[:, a:b + 1]).any() else np.full(len(z), np.nan)
        vals = {"apex_z": apex, "height_gain": apex - z[:, a],
                "distance": np.hypot(cols["com_x"][:, b] - cols["com_x"][:, a], cols["com_y"][:, b] - cols["com_y"][:, a])}
        som, tw = cols["somersault"], cols["twist"]
        # a side without a frame (the poses start or stop there) falls back to the flight's own end
        # alone: the other side's upright frame still counts the rotation before take-off or after landing
        if i0 is None and i1 is None:
            el["rotation_window"] = "flight"
        elif i0 is None or i1 is None:
            el["rotation_window"] = "take-off" if i0 is None else "landing"
        i0, i1 = a if i0 is None else i0, b if i1 is None else i1
        el["rotation_from_frame"], el["rotation_to_frame"] = int(frame[i0]), int(frame[i1])
        el["rotation_from_position"] = pos0 if i0 != a else "flight"
        vals["somersault_deg"] = som[:, i1] - som[:, i0]
        # a window frame the twist was not read at (before the first read row or after the last: no
        # interpolation reaches it) gives way to the read row nearest it towards the flight
        j0, j1 = _read_towards(tw[0], i0, a), _read_towards(tw[0], i1, b)
        if (j0, j1) != (i0, i1) and j0 is not None and j1 is not None:
            el["twist_from_frame"], el["twist_to_frame"] = int(frame[j0]), int(frame[j1])
            i0t, i1t = j0, j1
        else:
            i0t, i1t = i0, i1
        vals["twist_deg"] = tw[:, i1t] - tw[:, i0t]
        vals["airborne_somersault_deg"] = som[:, b] - som[:, a]
        vals["airborne_twist_deg"] = tw[:, b] - tw[:, a]
        for m in ("min_hip", "min_knee"):
            side = np.fmin(cols[f"left_{m[4:]}"][:, a:b + 1], cols[f"right_{m[4:]}"][:, a:b + 1])
            vals[m] = np.nanmin(np.where(np.isfinite(side), side, np.inf), axis=1)
        vals["max_split"] = np.nanmax(np.where(np.isfinite(cols["split"][:, a:b + 1]), cols["split"][:, a:b + 1], -np.inf), axis=1)
        for name, v in vals.items():
            v = np.where(np.isfinite(v), v, np.nan)
            digits = 4 if name in ("apex_z", "height_gain", "distance") else 2
            if np.isnan(v[0]):
                el[name] = None
                missing[name] = _why(name)
                continue
            el[name] = round(float(v[0]), digits)
            if len(v) > 1:
                el[f"{name}_sd"] = round(float(np.nanstd(v[1:])), digits)
        if el["somersault_deg"] is not None:
            el["saltos"] = float(np.round(el["somersault_deg"] / 360 * 4) / 4)
            el["saltos_sd"] = round(el.get("somersault_deg_sd", 0.0) / 360, 4)
        else:
            el["saltos"] = None
            missing["saltos"] = missing["somersault_deg"]
        if el["twist_deg"] is not None:
            el["twists"] = float(np.round(el["twist_deg"] / 360 * 2) / 2)
            el["twists_sd"] = round(el.get("twist_deg_sd", 0.0) / 360, 4)
        else:
            el["twists"] = None
            missing["twists"] = missing["twist_deg"]
        code, closed = shape_of(cols, a, b, angle_sd, fps)
        if code[0] >= 0:
            el["shape"] = SHAPES[code[0]]
            el["shape_frame"] = int(frame[closed])
            if len(code) > 1:
                el["shape_agreement"] = round(float(np.mean(code[1:] == code[0])), 3)
        else:
            el["shape"] = None
            missing["shape"] = "the hip or knee angles are missing in the flight"
        el.update(_sub_frame(frame, z[0], fps, a, b))
        if missing:
            el["missing"] = missing
        if b + 1 < len(frame) and support[b + 1] == FLOOR and frame[b + 1] - frame[b] <= 2:
            el["_landing_row"] = b + 1
        out.append(el)
    return out


def _read_towards(v: np.ndarray, i: int, j: int) -> int | None:
    """The row nearest ``i`` on the way to ``j`` (inclusive) where ``v`` is finite; None if none is."""
    rows = np.arange(i, j + 1) if j >= i else np.arange(i, j - 1, -1)
    ok = rows[np.isfinite(v[rows])]
    return int(ok[0]) if ok.size else None


def _why(name: str) -> str:
    if name in ("somersault_deg", "twist_deg", "airborne_somersault_deg", "airborne_twist_deg"):
        return "no somersault or twist at the flight's frames (no apparatus plane, or the shoulders or hips are missing)"
    if name in ("apex_z", "height_gain", "distance"):
        return "no centre of mass at the flight's frames (the hips are missing)"
    return "the joints this angle needs are missing in the flight"
