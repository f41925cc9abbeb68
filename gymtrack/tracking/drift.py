"""The venue check: each camera's residuals watched for a knocked camera and for a camera out of sync.

Beyond the paper, which assumes a fixed, synchronised rig (Section III-B). Each window's own
frames (those before the next window's) pooled over three windows (:data:`EVERY_WINDOWS`, a
sample): the tracker's clusters of three views or more give residuals: the point
that one non-opposite *pair* of the other views triangulates (Eq. 3's two-view case, midpoint of
the rays, normalised image coordinates), projected into a third view, minus where that view saw
it -- an angle (radians) per camera, pair, point and frame (a *key*: camera x pair). A knocked
or late camera moves the keys it is involved in (its own, and the others' through the pairs it is
in) and no other: the camera whose involved keys moved, against the keys not involving it, is named.

- A knocked camera (turned about its centre) moves all its points by the same small rotation:
  each key's median residual over the samples since the move shifts from its median of the five
  seconds before, by what that rotation predicts (the move's sample is not known: the scan of
  :mod:`.drift_scan` weighs each length from one to three seconds by the evidence a step that
  long has, and keeps the strongest; a half-degree knock, about two of a sample's scatters, is
  named by its mean over two or three seconds where one second's mean misses it) -- its own keys by the turn itself, the keys of the
  pairs it is in by how their triangulated point moves -- and the keys not involving it stay.
  The rotation of each camera alone is fitted to all keys' shifts (in their scatter); the camera
  whose turn explains them clearly best is named. A turn moves every key the camera is in, as
  the fit predicts, and stays; a wrong association moves the keys of one cluster and goes: the
  named turn must still explain the keys over the next two seconds (:data:`HOLD`). Once it has,
  and a sample wholly after the move is in, :class:`DriftMonitor` reports the camera, the frame
  it started (the frame where its own points split best into unturned and turned) and the size
  in degrees, and (``recalibrate``) takes the pan and tilt fitted to its own points since the
  move (:mod:`.turn_fit`; the keys' turn where too few) as the camera's rotation (the rotation
  fitted to those points, Kabsch / Wahba's problem, is reported beside it as a cross-check) and
  maps that camera's later boxes back into the calibrated view (``correct``), and the boxes the
  tracker reports back out (``uncorrect``): a rotation about the centre is the image homography
  ``K R K^-1``. Its later points are kept: offline, its turn is refitted to all of them
  (:meth:`DriftMonitor.refined_knocks`).
- A camera out of sync by ``o`` frames shows its points where the others saw them ``o`` frames
  earlier: its residual is ``-o`` times its points' image velocity. The least-squares ``o``
  over the routine (:meth:`DriftMonitor.sync_suspects`) names the camera and the likely offset.

Shapes: a window's clusters ``members`` (M, C), segments' undistorted boxes (K, W, 4).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import GymtrackWarning
from ..geometry.camera import Rig
from ._kernels import drift as kernels
from .drift_scan import scan_steps
from .turn_fit import TurnEvidence, degrees as _degrees, fit_rotation, own_jacobian, rotation as _rotation, turn_pixels

__all__ = ["DriftMonitor", "turn_pixels", "fit_rotation"]

BASELINE_SECONDS = 5.0  # the seconds of residuals before the last one: where the camera was
#: frames: the least-squares offset that names a camera out of sync. Clean simulated routines
#: give up to 0.67 frames (the demo's high bar: 0.53-0.60; later 0.30, edge-cut boxes out) and a camera one frame late 0.2-0.75,
#: so one frame is left to ``gymtrack sync``; three frames late give 1.5 or more
SYNC_MIN_FRAMES = 1.0
RECENT_SECONDS = 1.0  # a camera's residuals must have moved for this long (the scale of the evidence's z)
SCAN_SECONDS = 3.0  # a step's evidence pooled over up to this long since it (:mod:`.drift_scan`)
EVERY_WINDOWS = 3  # windows pooled into a sample (enough points for a steady median)
MIN_DEG = 0.3  # the smallest turn reported (pan and tilt)
SIGMA_MIN = float(np.radians(0.05))  # the least scatter of a sample's median residual (radians)
GATE = 2.5  # a key's shift, in its scatter, before any camera is fitted (the usual sample: none)
ROLL_DEG = 0.5  # the fit's prior on the roll: a knock pans and tilts a camera more than it rolls it
HUBER = 2.5  # a key further than this (scatters) from the fitted turn weighs less in the fit
CAP = 16.0  # one key's most share of the evidence (scatters squared): one key cannot name a camera
#: a camera is named at one sample by evidence (the keys' squared shifts, in their scatter, that
#: its turn explains) and margin over the next camera's fit; or by EVIDENCE_HELD and MARGIN_HELD
#: with each of its own keys moved by OWN_HELD scatters. Named is not reported: see HOLD
EVIDENCE, MARGIN = 50.0, 10.0
EVIDENCE_HELD, MARGIN_HELD, OWN_HELD = 20.0, 5.0, 1.5
#: a named camera's turn, over the next HOLD_SECONDS, still explains every key it is in: at each
#: sample the keys' moves from their baseline matched against the shifts the turn predicts (scatters,
#: pooled over the keys, each capped), this on average. A turned camera moves every point it sees,
#: in every pair, and stays turned (bench_faults' knocks: 3.6 or more, a few 0.5 degree ones
#: less); a wrong association or a change of the people in the samples moves a few keys and comes
#: and goes (clean routines: up to 3.1; over one second instead of two, a clean 20 s parallel bars
#: held 5.7, 2.7). Set on simulated routines (bench_faults' knocks, 7 apparatus, seeds 0-9, n_cam 3
#: and 4, and the default suite's 56 clean routines of n_cam 3 and 4): no clean one of the 196
#: alarms, a 0.5 degree knock is named within 5 s in 118 of 140, a 1 degree one in 136 of 140
#: (simulator with centre-of-mass flights, edge-cut boxes out: 0 of 252 clean; 31/42, 42/42)
HOLD, HOLD_SECONDS = 3.5, 2.0
FULL_SAMPLES = 1  # samples wholly after a move that its turn is fitted to
MAX_RESIDUAL = 0.05  # radians (3 deg): a larger residual is a wrong association, not drift
MIN_POINTS = 8  # points of a camera x pair in a sample for its median to count


def _small_turn(axis: int, eps: float) -> np.ndarray:
    """(3, 3) I + eps [e_axis]x: a turn by ``eps`` radians about one camera axis, to first order."""
    e = np.zeros(3)
    e[axis] = eps
    return np.eye(3) + np.array([[0, -e[2], e[1]], [e[2], 0, -e[0]], [-e[1], e[0], 0]])


_SMALL_TURNS = np.stack([_small_turn(i, 1e-4) for i in range(3)])  # (3, 3, 3) the Jacobians' steps
_PRIOR = np.diag([1e-6, 1e-6, 1 / np.radians(ROLL_DEG) ** 2])  # the turn fit's prior (tilt, pan, roll)


class DriftMonitor:
    """Residuals per camera x view pair, sampled every few windows; knock events; the sync regression.

    rig: the cameras; fps: frames per second; step: frames between windows; opposite: (C, C) bool,
    the view pairs judged opposite (:func:`~gymtrack.geometry.views.opposite_pairs`); recalibrate:
    re-estimate a knocked camera's rotation and correct its later boxes; active: watch at all (the
    tracker's default; nothing changes the outputs until a camera is found moved).
    """

    def __init__(self, rig: Rig, fps: float, step: int, opposite: np.ndarray, recalibrate: bool = True,
                 active: bool = True):
        self.rig, self.fps, self.recalibrate, self.active = rig, fps, recalibrate, active
        C = self.C = len(rig)
        self.Kinv = np.stack([np.linalg.inv(c.K) for c in rig])
        self.Rt = np.ascontiguousarray(np.stack([c.R.T for c in rig]))  # (C, 3, 3) camera -> world; C order as warm_up compiles
        self.centres = rig.centres
        self.Pn = np.stack([np.c_[c.R, c.t] for c in rig])  # (C, 3, 4) normalised projections
        every = step * EVERY_WINDOWS  # frames between samples
        self.n_base = max(3, int(round(BASELINE_SECONDS * fps / every)))
        self.n_recent = max(2, int(round(RECENT_SECONDS * fps / every)))
        self.n_scan = max(self.n_recent, int(round(SCAN_SECONDS * fps / every)))
        self.step, self.window_step, self._windows = every, step, 0
        self._rows: list = []  # the residual rows of the windows since the last sample
        # the view pairs that triangulate (not opposite: ill-conditioned there); a camera is judged
        # by the points of each pair without it (a knocked camera drags the pairs it is in)
        pa, pb = np.triu_indices(C, 1)
        keep = ~np.asarray(opposite, bool)[pa, pb]
        self.pairs = (pa[keep], pb[keep])
        Np = len(self.pairs[0])
        # key c * Np + p: camera c judged by pair p; the keys each camera is involved in (judged, or in the pair)
        self.key_camera = np.repeat(np.arange(C), Np)
        key_pair = np.tile(np.arange(Np), C)
        self.involves = np.stack([(self.key_camera == c) | (self.pairs[0][key_pair] == c) | (self.pairs[1][key_pair] == c)
                                  for c in range(C)])  # (C, C * Np)
        L = self.n_base + self.n_scan
        self.meds = np.full((C * Np, L, 2), np.nan)  # per camera x pair: the last L samples' median residual
        self.frames = np.zeros(L, np.int64)  # each sample's last frame
        self.samples: list = [None] * L  # each sample's (start (C * Np + 1,), world points, where seen) by camera x pair
        self.last_frame = 0
        self.sums = np.zeros((C * Np, 3))  # sync regression per camera x pair: n, sum v.v, sum v.r
        self.events: list[dict] = []
        self.turns: dict[int, tuple[int, np.ndarray]] = {}  # camera -> (from frame, rotation now vs calibrated)
        self.knocks: list[tuple[int, int, np.ndarray]] = []  # each re-estimated turn: (camera, start frame, rotation)
        self.evidence: dict[int, TurnEvidence] = {}  # each knocked camera's own points from its first move on
        self.history: list[tuple[int, np.ndarray]] = []  # every sample's last frame and median residuals (Nk, 2)
        self.first: int | None = None
        self.n_hold = max(2, int(round(HOLD_SECONDS * fps / every)))
        # (camera, its first moved sample's frame, start, the frame named at, the keys' shifts its turn
        # predicts (radians), their baseline and scatter (None once they held), how far they held at each
        # later sample (scatters)): to be reported
        self._named: tuple | None = None
        self._own = [np.flatnonzero(self.key_camera == c) for c in range(C)]  # each camera's own keys
        self._turns = np.stack([c.R.T @ _SMALL_TURNS @ c.R for c in rig])  # (C, 3, 3, 3): each camera's small turns, world

    # ------------------------------------------------------------ per window
    def observe(self, start: int, box: np.ndarray, observed: np.ndarray, members: np.ndarray) -> None:
        """One window: segments' undistorted boxes (K, W, 4), observed (K, W) (the tracker: not where the image's
        edge cuts the box), clusters (M, C). Its residuals are kept; every :data:`EVERY_WINDOWS`-th window they are
        pooled into a sample."""
        if not self.active:
            return
        if self.first is None:
            self.first = start
        self._windows += 1
        w_hi = min(observed.shape[1] - 1, 1 + self.window_step)  # each window's own frames (up to the next one's)
        if len(members):
            rows = kernels.residuals(box, observed, members, self.Kinv, self.Rt, self.centres, self.Pn, *self.pairs,
                                     MAX_RESIDUAL, 1, w_hi)
            self.sums += rows[4]
            self._rows.append((*rows[:4], start + rows[5]))  # (with each row's frame)
        if self._windows % EVERY_WINDOWS:
            return
        self.last_frame = start + observed.shape[1] - 1
        self.meds[:, :-1] = self.meds[:, 1:]  # a new sample (NaN where a camera x pair has too few points)
        self.meds[:, -1] = np.nan
        self.frames[:-1] = self.frames[1:]
        self.frames[-1] = start + w_hi - 1  # the sample's last frame
        self.samples.pop(0)
        self.samples.append(None)
        if self._rows:  # the sample: the rows of its windows pooled
            key, R, X, S, F = (np.concatenate(a) for a in zip(*self._rows))
            med, starts, X, S, F = kernels.medians(key, R, X, S, F, len(self.meds), MIN_POINTS)
            self.meds[:, -1] = med
            self.samples[-1] = (starts, X, S, F)
            self.history.append((int(self.frames[-1]), med))
            self._rows = []
            for c, ev in self.evidence.items():
                ev.add(self.samples[-1], int(self.frames[-2]) + 1, self.turns[c])
        self._check()

    def _jacobians(self, c: int | np.ndarray, k: np.ndarray, X: np.ndarray, seen: np.ndarray) -> np.ndarray:
        """(n, 2, 3) how keys ``k``'s (n,) residuals move as camera ``c`` (one, or (n,): one per key;
        involved in each) turns by a small rotation vector (its camera coordinates), at the world
        points ``X`` (n, 3) they judge and where the judged cameras saw them (normalised ``seen``
        (n, 2)). Its own key: the seen point moves; a key whose pair holds it: the pair's point
        moves (its rays through ``X`` re-triangulated) and so does its projection into the judged camera."""
        c = np.broadcast_to(c, k.shape)
        j, p = self.key_camera[k], k % len(self.pairs[0])
        a, b = self.pairs[0][p], self.pairs[1][p]
        ca, cb = self.centres[a], self.centres[b]
        # the camera's ray through X as it is and turned by eps about each of its axes (world), the
        # other's ray as it is; their midpoints (Eq. 3's two-view case) seen from the judged camera
        eps, first = 1e-4, (a == c)[:, None, None]
        d = np.repeat((X - np.where(first[:, 0], ca, cb))[:, None], 4, axis=1)  # (n, 4, 3)
        d[:, 1:] = np.einsum("nmij,nj->nmi", self._turns[c], d[:, 0])
        other = np.broadcast_to((X - np.where(first[:, 0], cb, ca))[:, None], d.shape)
        da, db = np.where(first, d, other), np.where(first, other, d)
        w = (ca - cb)[:, None]
        aa, bb, cc = (da * da).sum(2), (da * db).sum(2), (db * db).sum(2)
        dw, ew = (da * w).sum(2), (db * w).sum(2)
        den = aa * cc - bb * bb  # (0 for the own keys, whose pair lacks c: they take the closed form below)
        with np.errstate(divide="ignore", invalid="ignore"):
            P = (ca[:, None] + ((bb * ew - cc * dw) / den)[..., None] * da + cb[:, None] + ((aa * ew - bb * dw) / den)[..., None] * db) / 2
            q = np.einsum("nmk,nik->nmi", P, self.Pn[j, :, :3]) + self.Pn[j, None, :, 3]
            seen_j = q[..., :2] / q[..., 2:]
        J = -(seen_j[:, 1:] - seen_j[:, :1]).transpose(0, 2, 1) / eps
        return np.where((j == c)[:, None, None], own_jacobian(seen), J)

    def _fit(self, shift: np.ndarray, sigma: np.ndarray, keys: np.ndarray, recent: int) -> list:
        """Per camera: (misfit, turn (3,), own, pred) -- the rotation of that camera alone that best
        explains the keys' shifts (in their scatter; a robust fit, a prior on the roll), what it
        leaves unexplained (each key's share capped), its own keys' smallest shift (scatters), and
        the shift (Nk, 2) it predicts for every key (0 for the keys it is not in); ``recent``: the
        samples the shifts are of."""
        got = [q for q in self.samples[-recent:] if q is not None]  # (each: offsets per key, points, where seen)
        Nk = len(sigma)
        rep = np.full((Nk, 5), np.nan)  # each key's median point and where it was seen (NaN: no rows)
        if got:
            rep = kernels.key_medians(np.concatenate([np.repeat(np.arange(Nk), np.diff(q[0])) for q in got]),
                                      np.concatenate([np.concatenate(q[1:3], axis=1) for q in got]), Nk)
        keys = keys[np.isfinite(rep[keys, 0])]
        z = shift[keys] / sigma[keys, None]  # (n, 2)
        inv = self.involves[:, keys]  # (C, n): every camera with every key it is in, all fitted in one call
        cam, row = np.nonzero(inv)
        A = np.zeros((self.C, len(keys), 2, 3))
        A[cam, row] = self._jacobians(cam, keys[row], rep[keys[row], :3], rep[keys[row], 3:]) / sigma[keys[row], None, None]
        w, miss = kernels.turn_fits(A, z, inv, _PRIOR, HUBER, 4)
        misfit = np.minimum(CAP, miss ** 2).sum(axis=1)
        pred = np.zeros((self.C, len(sigma), 2))  # (radians) each key's shift that each camera's turn predicts
        pred[:, keys] = (A @ w[:, None, :, None])[..., 0] * sigma[keys, None]
        own = inv & (self.key_camera[keys] == np.arange(self.C)[:, None])
        size = np.where(own, np.linalg.norm(z, axis=1), np.inf).min(axis=1)  # (its own keys' smallest shift)
        out = [(float(misfit[c]), w[c], float(size[c]), pred[c]) if own[c].any() else (np.inf, None, 0.0, None)
               for c in range(self.C)]
        return out, float(np.minimum(CAP, (z ** 2).sum(axis=1)).sum())

    def _check(self) -> None:
        """A knock: the camera whose turn alone explains how the keys moved -- its own residuals,
        and the others' through the pairs it is in, none else -- clearly better than any other
        camera's; named, then reported once its turn held (:meth:`_confirm`)."""
        if self._named is not None:
            return self._confirm()
        shift, sigma, scatter, base, m = scan_steps(self.meds, self.n_base, self.n_recent, SIGMA_MIN, CAP)  # (per key)
        ready = np.isfinite(sigma)
        z2 = np.where(ready, (shift ** 2).sum(axis=1) / sigma ** 2, 0.0)
        chi0 = np.minimum(CAP, z2).sum()
        if not (z2 > GATE ** 2).any() or chi0 < EVIDENCE_HELD:
            return  # (the usual sample: nothing moved, or too little for any camera's turn to explain)
        # a camera's turn explains at most the keys it is in (the others' misfit is their own z2): where
        # that bound passes neither rule for any camera, the fit would be wasted (with a margin for rounding)
        most = (self.involves @ np.minimum(CAP, z2)) * (1 + 1e-9)  # (C,)
        own_moved = np.array([ready[own].any() and bool((z2[own[ready[own]]] >= OWN_HELD ** 2).all()) for own in self._own])
        if not ((most >= EVIDENCE) | (most >= EVIDENCE_HELD) & own_moved).any():
            return
        fits, chi0 = self._fit(shift, sigma, np.flatnonzero(ready), m)
        misfit = np.array([f[0] for f in fits])
        c = int(np.argmin(misfit))
        _, w, own, pred = fits[c]
        if w is None or np.degrees(np.hypot(w[0], w[1])) < MIN_DEG:
            return
        evidence, margin = chi0 - misfit[c], float(np.sort(misfit)[1] - misfit[c]) if self.C > 1 else np.inf
        if not (evidence >= EVIDENCE and margin >= MARGIN or evidence >= EVIDENCE_HELD and margin >= MARGIN_HELD
                and own >= OWN_HELD):
            return
        k = max(np.flatnonzero(ready & (self.key_camera == c)), key=lambda k: np.linalg.norm(shift[k]) / sigma[k])
        step = float(np.linalg.norm(shift[k]))
        dev = np.linalg.norm(self.meds[k] - base[k], axis=1)
        moved = dev > step / 2  # (NaN: not moved)
        first = len(self.frames) - self.n_recent  # the first sample of the run of moved samples reaching into the last second
        while first > 0 and moved[first - 1]:
            first -= 1
        # named: reported once its turn held (HOLD) and FULL_SAMPLES samples after the first moved one (which may
        # hold frames from before the move) have come, the turn fitted to those
        self._named = (c, int(self.frames[first]), int(self.frames[first]) - self.step + 1, int(self.frames[-1]), pred,
                       base.copy(), scatter, [])

    def _confirm(self) -> None:
        """The named camera's event, once its turn held over HOLD_SECONDS and FULL_SAMPLES samples
        wholly after its first moved one are in, and the turn fitted to the keys' shifts over those
        samples against the samples before the move (:meth:`_fit`) still explains them best: its
        own points' pan and tilt is the camera's re-estimated rotation (:mod:`.turn_fit`; the keys'
        turn where too few); the rotation fitted to its own points (Kabsch) is reported beside it."""
        c, first_frame, started, named_frame, pred, base, sigma, held = self._named
        lo = len(self.frames) - self.n_base - self.n_recent  # (judged over the last n_base + n_recent samples)
        meds, samples, frames = self.meds[:, lo:], self.samples[lo:], self.frames[lo:]
        at = np.flatnonzero(frames == first_frame)
        if not len(at) or at[0] < 1:  # (the move's sample left the history: named again if it holds)
            self._named = None
            return
        if pred is not None:  # a knock stays: every key the turn moved, over the next HOLD_SECONDS
            if self.frames[-1] > named_frame:
                p = pred / sigma[:, None]
                p_n = np.linalg.norm(p, axis=1)
                z = (self.meds[:, -1] - base) / sigma[:, None]
                ok = np.isfinite(z).all(axis=1) & (p_n > 0)
                if ok.any():  # the keys' moves along the predicted ones, each capped, pooled as a matched filter
                    along = np.clip((z[ok] * p[ok]).sum(axis=1) / p_n[ok], -np.sqrt(CAP), np.sqrt(CAP))
                    held.append(float((p_n[ok] * along).sum() / np.linalg.norm(p_n[ok])))
            if len(held) < self.n_hold:
                return
            if np.mean(held) < HOLD:  # a change of the people in the samples, or a wrong association
                self._named = None
                return self._check()  # (another camera may have moved meanwhile: judged at once)
            self._named = (c, first_frame, started, named_frame, None, None, None, held)
        first = int(at[0])
        if len(frames) - 1 - first < FULL_SAMPLES:
            return
        self._named = None
        own = np.flatnonzero(self.key_camera == c)
        pts = [None if q is None else (np.concatenate([q[1][q[0][k]:q[0][k + 1]] for k in own]),
                                       np.concatenate([q[2][q[0][k]:q[0][k + 1]] for k in own])) for q in samples]
        before = [q for q in pts[:first] if q is not None and len(q[0])]
        after = [q for q in pts[first + 1:] if q is not None and len(q[0])]
        if not before or not after:
            return
        shift, sigma = scan_steps(np.concatenate([meds[:, :first], meds[:, first + 1:]], axis=1), first, self.n_recent,
                                  SIGMA_MIN, CAP, len(frames) - 1 - first)[:2]  # (all the samples after the move)
        fits = self._fit(shift, sigma, np.flatnonzero(np.isfinite(sigma)), len(frames) - 1 - first)[0]
        w = fits[c][1]
        misfit = np.array([f[0] for f in fits])
        if w is None or np.delete(misfit, c).min() - misfit[c] < MARGIN_HELD:
            return  # (over the samples after the move, another camera's turn explains them as well)
        ev = TurnEvidence(self.Pn[c], own, np.stack([m for f, m in self.history if f < frames[first]]
                                                    or [np.full((len(meds), 2), np.nan)]), samples[first + 1:])
        keys, R = _rotation(w), ev.fit()  # its own points' pan and tilt (:mod:`.turn_fit`); too few: the keys' turn
        R, kabsch = keys if R is None else R, self._refit(c, after) @ self._refit(c, before).T
        started = ev.start(samples[max(0, first - 2):], R) or started  # (up to now: the first moved sample may be early)
        frame = self.last_frame
        event = {"camera": self.rig.names[c], "start_frame": started, "detected_frame": int(frame),
                 "start_seconds": round((started - self.first) / self.fps, 2),
                 "degrees": round(_degrees(keys), 2), "turn_degrees": round(_degrees(kabsch), 2)}
        if self.recalibrate:
            prev = self.turns.get(c, (0, np.eye(3)))[1]
            self.turns[c] = (int(frame) + 1, R @ prev)
            self.knocks.append((c, started, R))
            if c not in self.evidence:  # its first turn: refitted offline to every point from the move on
                ev.applied, ev.knock, self.evidence[c] = self.turns[c], len(self.knocks) - 1, ev
            event |= {"recalibrated_from_frame": int(frame) + 1, "rotation_degrees": round(_degrees(R @ prev), 2)}
        self.events.append(event)
        warnings.warn(f"camera {event['camera']} moved by about {event['degrees']} deg from frame {started} "
                      f"({event['start_seconds']} s): knocked? " + (f"its rotation was re-estimated "
                      f"({event['rotation_degrees']} deg) and applied from frame {frame + 1}" if self.recalibrate
                      else "recalibrate it"), GymtrackWarning, stacklevel=3)
        self.meds[:] = np.nan  # every camera's residuals moved with it: a new baseline after the move
        self.samples = [None] * len(self.samples)

    def refined_knocks(self) -> list[tuple[int, int, np.ndarray]]:
        """:attr:`knocks`, each camera's first turn refitted to all its points from the move on."""
        out = list(self.knocks)
        for c, ev in self.evidence.items():
            if (R := ev.fit()) is not None:
                out[ev.knock] = (c, out[ev.knock][1], R)
        return out

    def _refit(self, c: int, samples: list[tuple]) -> np.ndarray:
        """The rotation of camera ``c`` against its calibration, from the (n, 3) world points the
        other views triangulated and the (n, 3) rays it saw them on (camera coordinates) of ``samples``."""
        X = np.concatenate([q[0] for q in samples])
        seen = np.concatenate([q[1] for q in samples])
        seen = np.concatenate([seen, np.ones((len(seen), 1))], axis=1)
        cam = self.rig[c]
        return fit_rotation((X - cam.centre) @ cam.R.T, seen)

    # ------------------------------------------------------------ boxes in and out
    def correct(self, frame: int, camera: np.ndarray, box: np.ndarray) -> np.ndarray:
        """(n,) cameras, (n, 4) raw boxes of one frame -> the boxes as the calibrated cameras see them."""
        for c, (first, R) in self.turns.items():
            m = np.flatnonzero(camera == c)
            if frame >= first and len(m):
                box = box.copy()
                box[m, :2] = turn_pixels(self.rig[c], box[m, :2], R.T)
        return box

    def uncorrect(self, frame: np.ndarray, camera: np.ndarray, box: np.ndarray) -> np.ndarray:
        """The tracker's reported boxes (n,) moved back into the turned cameras' images."""
        for c, (first, R) in self.turns.items():
            m = np.flatnonzero((camera == c) & (frame >= first))
            if len(m):
                box = box.copy()
                box[m, :2] = turn_pixels(self.rig[c], box[m, :2], R)
        return box

    def uncorrect_output(self, out):
        """A :class:`~.types.TrackerOutput` with its boxes moved back into the turned cameras' images."""
        import dataclasses

        def back(d):
            if not len(d):
                return d
            return type(d).of_columns(d.frame, d.camera, self.uncorrect(d.frame, d.camera, d.box), d.score, d.track_id,
                                      d.camera_names)

        return dataclasses.replace(out, boxes=back(out.boxes), target_boxes=back(out.target_boxes))

    # ------------------------------------------------------------ at the end
    def warn_sync(self) -> None:
        """A warning for a camera whose residuals say it is out of sync."""
        if not self.active:
            return
        for s in self.sync_suspects():
            warnings.warn(f"camera {s['camera']} is probably out of sync by {s['offset']:+d} frames (its residuals "
                          f"follow its points' motion, {s['estimate']:+.2f} frames): run gymtrack sync", GymtrackWarning,
                          stacklevel=3)

    def sync_suspects(self, min_frames: float = SYNC_MIN_FRAMES) -> list[dict]:
        """Cameras whose residuals follow their points' motion: ``[{camera, offset, frames}]`` for a
        least-squares offset of ``min_frames`` or more (``offset`` as scene.yaml's frame_offsets)."""
        out = []
        own = np.stack([self.sums[self.key_camera == c].sum(axis=0) for c in range(self.C)])  # (C, 3)
        clean = np.stack([self.sums[~self.involves[c]].sum(axis=0) for c in range(self.C)])
        with np.errstate(invalid="ignore", divide="ignore"):
            o, o_clean = -own[:, 2] / own[:, 1], -clean[:, 2] / clean[:, 1]
        # the camera out of sync drags the keys it is in, not the others: the largest own offset
        # beyond what the keys not involving it show
        score = np.where(np.isfinite(o), np.abs(o) - np.abs(np.nan_to_num(o_clean)), -np.inf)
        worst = int(np.argmax(score)) if np.isfinite(score).any() else -1
        n = own[:, 0]
        if worst >= 0 and abs(o[worst]) >= min_frames and n[worst] >= 50:
            out.append({"camera": self.rig.names[worst], "offset": int(np.round(o[worst])),
                        "estimate": round(float(o[worst]), 2), "points": int(n[worst])})
        return out

    def summary(self) -> dict:
        """What the summary reports (empty on a clean routine)."""
        s = {}
        if self.events:
            s["camera_moved"] = self.events
        if sus := self.sync_suspects():
            s["camera_out_of_sync"] = sus
        return s
