"""A knocked camera's turn and the frame it moved, re-estimated from its own points (beyond the
paper; :mod:`.drift`).

The points that view pairs without the camera triangulate (Eq. 3's two-view case), projected
into it, against where it saw them: once the camera turned by ``R`` about its centre, each seen
ray is ``R`` times the calibrated one. Each point's residual, less its camera x pair's median
residual before the move (two views' box centres are not one body point: every pair's
residuals carry a bias of their own; taken over the whole routine before the move, as a
gymnast's poses come and go), is fitted by the turn's pan and tilt, point by point:

- Cauchy's weights (a loss that lets go of far points): a gymnast in a pose that the views frame
  differently moves a pair's residuals by up to a degree, mostly one way, for seconds; a median
  or Huber's weights follow such points, the bulk of the points (the upright people) does not.
- The roll is left at zero: a routine's points lie in a small part of the image, where a roll
  moves them as a pan or a tilt does, so a free roll took up those biases (off by up to 2 deg on
  bench_faults' knocks of seed 0, pulling pan and tilt by 0.3 deg); a pan and tilt alone move
  the points where they are seen as the turn did (a knock's share about the optical axis is small).

The frame the move started (:meth:`TurnEvidence.start`): the frames around it split where the
points before fit the unturned camera and those after the turned one best. Offline the routine
after the move is at hand: :class:`TurnEvidence` keeps the camera's points from the move on
(those seen after the stream's correction turned back by it) and fits them all.
"""

from __future__ import annotations

import numpy as np

from ..geometry.camera import Camera

__all__ = ["fit_rotation", "own_jacobian", "fit_turn", "rotation", "degrees", "TurnEvidence", "turn_pixels"]

SCALE = float(np.radians(0.2))  # Cauchy's scale (radians): a point's residual scatter about its pair's bias
ITERATIONS = 12  # reweighted least squares; the first three with Huber's weights (a start near the bulk)
MIN_POINTS = 30  # points after the move for a fit at all
MIN_SAMPLES = 3  # samples before the move with a pair's median residual for its bias


def fit_rotation(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """(n, 3) directions in the calibrated camera, (n, 3) where the camera sees them now -> the
    rotation ``R`` (3, 3) with ``after ~ R before`` (least squares on unit vectors; Kabsch)."""
    a = before / np.linalg.norm(before, axis=1, keepdims=True)
    b = after / np.linalg.norm(after, axis=1, keepdims=True)
    U, _, Vt = np.linalg.svd(b.T @ a)
    d = np.sign(np.linalg.det(U @ Vt))
    return U @ np.diag([1.0, 1.0, d]) @ Vt


def own_jacobian(seen: np.ndarray) -> np.ndarray:
    """(n, 2) normalised points a camera saw -> (n, 2, 3) how each moves as the camera turns by a
    small rotation vector (its coordinates: tilt, pan, roll)."""
    x, y = seen[:, 0], seen[:, 1]
    return np.stack([np.stack([-x * y, 1 + x * x, -y], 1), np.stack([-(1 + y * y), x * y, x], 1)], 1)


def rotation(w: np.ndarray) -> np.ndarray:
    """(3,) rotation vector -> (3, 3) rotation (Rodrigues)."""
    t = float(np.linalg.norm(w))
    if t < 1e-12:
        return np.eye(3)
    k = w / t
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(t) * K + (1 - np.cos(t)) * K @ K


def degrees(R: np.ndarray) -> float:
    """The angle (degrees) of a rotation (3, 3)."""
    return float(np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))))


def _turned(seen: np.ndarray, R: np.ndarray) -> np.ndarray:
    """(n, 2) normalised points -> where they lie after the camera turned by ``R``."""
    ray = np.c_[seen, np.ones(len(seen))] @ R.T
    return ray[:, :2] / ray[:, 2:]


def fit_turn(P: np.ndarray, X: np.ndarray, seen: np.ndarray, bias: np.ndarray) -> np.ndarray | None:
    """The camera's turn (3, 3) since its calibration ``P`` (3, 4, normalised), from the (n, 3)
    world points the other views triangulated, the (n, 2) normalised points it saw them at, and
    each point's pair's residual (n, 2) before the move: pan and tilt, roll 0 (module
    docstring); None with fewer than :data:`MIN_POINTS` points."""
    if len(X) < MIN_POINTS:
        return None
    q = X @ P[:, :3].T + P[:, 3]
    want = q[:, :2] / q[:, 2:] + bias  # where each point would be seen unturned
    R = np.eye(3)
    for i in range(ITERATIONS):  # Gauss-Newton about the turn so far, reweighted
        back = _turned(seen, R.T)  # the seen points turned back by the turn so far
        r, J = back - want, own_jacobian(back)[:, :, :2]
        miss = np.linalg.norm(r, axis=1) / SCALE
        wt = np.minimum(1.0, 1.5 / np.maximum(miss, 1e-12)) if i < 3 else 1 / (1 + miss ** 2)
        step = np.linalg.solve(np.einsum("n,nji,njk->ik", wt, J, J), np.einsum("n,nji,nj->i", wt, J, r))
        R = R @ rotation(np.r_[step, 0.0])  # (the seen points are R_true times the unturned: R_true = R E)
    return R


class TurnEvidence:
    """One knocked camera's own points from its move on, to fit its turn with (:func:`fit_turn`).

    P: its calibrated normalised projection (3, 4); own: its keys (camera x pair, :mod:`.drift`);
    before: every sample's median residual per key (n, Nk, 2) before the move (the pairs' biases:
    their median, the whole routine before the move: a gymnast's poses come and go); after: the
    monitor's samples ``(starts, world points, seen, frames)`` after the move (None: no sample). ``applied``, once set: ``(from
    frame, rotation)`` the stream corrects the camera's later boxes by (turned back by it: as seen),
    and ``knock`` the index of the turn in the monitor's knocks.
    """

    def __init__(self, P: np.ndarray, own: np.ndarray, before: np.ndarray, after: list):
        self.P, self.own, self.applied, self.knock = P, own, None, -1
        ok = np.isfinite(before[:, own, 0]).sum(axis=0) >= MIN_SAMPLES
        with np.errstate(all="ignore"):
            self.bias = {int(k): np.nanmedian(before[:, k], axis=0) for k in own[ok]}
        self.X: list[np.ndarray] = []
        self.seen: list[np.ndarray] = []
        self.b: list[np.ndarray] = []
        self._add(*self._points(after))

    def _points(self, samples: list, frames: bool = False) -> tuple:
        """The own keys' rows of ``samples``: key (n,), world points (n, 3), seen (n, 2)[, frame (n,)]."""
        got = [(np.full(q[0][k + 1] - q[0][k], k), *(a[q[0][k]:q[0][k + 1]] for a in q[1:4 if frames else 3]))
               for q in samples if q is not None for k in self.own]
        if not got:
            return (np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 2)), np.zeros(0, np.int64))[:4 if frames else 3]
        return tuple(np.concatenate(a) for a in zip(*got))

    def _add(self, key: np.ndarray, X: np.ndarray, seen: np.ndarray) -> None:
        keep = np.isin(key, list(self.bias))
        if keep.any():
            self.X.append(X[keep])
            self.seen.append(seen[keep])
            self.b.append(np.stack([self.bias[k] for k in key[keep].tolist()]))

    def add(self, sample, first_frame: int, turn: tuple) -> None:
        """A later sample (its first frame; the camera's turn now): its points, if all its frames
        were corrected by the turn this evidence began with (a later knock of the camera ends it)."""
        if sample is not None and self.applied is not None and turn[1] is self.applied[1] and first_frame >= self.applied[0]:
            key, X, seen = self._points([sample])
            self._add(key, X, _turned(seen, self.applied[1]))

    def start(self, samples: list, R: np.ndarray) -> int | None:
        """The frame the turn ``R`` began: the samples' frames split where the points before fit
        the unturned camera and those from it on the turned one best (Cauchy's loss on each point's
        residual less its pair's bias, as is and less the shift the turn predicts); None if no
        split inside them does."""
        key, X, seen, frame = self._points(samples, frames=True)
        keep = np.isin(key, list(self.bias))
        if not keep.any():
            return None
        key, X, seen, frame = key[keep], X[keep], seen[keep], frame[keep]
        p = X @ self.P[:, :3].T + self.P[:, 3]
        want = p[:, :2] / p[:, 2:] + np.stack([self.bias[k] for k in key.tolist()])
        frames, at = np.unique(frame, return_inverse=True)
        unturned, turned = (np.bincount(at, np.log1p((np.linalg.norm(seen - w, axis=1) / SCALE) ** 2), len(frames))
                            for w in (want, _turned(want, R)))
        split = np.r_[0.0, np.cumsum(unturned)] + np.r_[np.cumsum(turned[::-1])[::-1], 0.0]  # turned from frame j on
        j = int(np.argmin(split))
        return None if j in (0, len(frames)) else int(frames[j])

    def fit(self) -> np.ndarray | None:
        """The turn fitted to every point so far (None: too few)."""
        if not self.X:
            return None
        return fit_turn(self.P, np.concatenate(self.X), np.concatenate(self.seen), np.concatenate(self.b))


def turn_pixels(cam: Camera, uv: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """(n, 2) raw pixels of ``cam`` -> where they lie after the camera turned by ``rotation`` (3, 3,
    camera coordinates) about its centre: every ray turns by ``rotation`` (distortion undone, then
    applied again)."""
    if not len(uv):
        return np.asarray(uv, dtype=np.float64)
    x = cam.undistort(uv)
    ray = np.c_[x, np.ones(len(x))] @ np.linalg.inv(cam.K).T
    return cam.project(cam.centre + (ray @ rotation.T) @ cam.R)
