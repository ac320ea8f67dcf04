"""Belief observations: the EKF-SLAM belief encoded as fixed-size float32 arrays.

Two encodings, both slotted by landmark ID (slot i is always landmark i):

* ``"full"``: the belief exactly, a ``Dict`` with the mean and covariance padded to
  ``max_landmarks`` and a known-mask.
* ``"egocentric"``: a flat ``Box`` of features a policy learns from easily (see
  :class:`EgocentricEncoding` for the layout).

Both clip to their (finite) bounds; the wrapper reports in ``info`` when it had to.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

# Scales that turn standard deviations into features in [0, 1): tanh(σ / scale).
POSITION_STD_SCALE = 1.0  # m
HEADING_STD_SCALE = 0.5  # rad
# A belief further than this many arena sizes outside the arena has diverged.
_EXTENT_FACTOR = 10.0


@dataclass(frozen=True)
class BeliefGeometry:
    """The sizes that fix an encoding's layout and bounds."""

    max_landmarks: int  # landmark slots: IDs 0..max_landmarks-1
    width: float  # m, arena extent along x
    height: float  # m, arena extent along y
    max_range: float  # m, sensor range: the scale of robot-frame landmark positions

    @property
    def extent(self) -> float:
        """Largest |coordinate| a sane belief can have, m."""
        return _EXTENT_FACTOR * max(self.width, self.height)


def slot_indices(state_to_id: np.ndarray) -> np.ndarray:
    """Indices into the ID-slotted state [x, y, θ, m0x, m0y, …] of each entry of the
    filter's state, which holds landmarks in the order first seen."""
    ids = np.asarray(state_to_id, dtype=np.int64)
    lm = np.empty(2 * ids.size, dtype=np.int64)
    lm[0::2] = 3 + 2 * ids
    lm[1::2] = 4 + 2 * ids
    return np.concatenate([np.arange(3), lm])


def unpack_full_belief(obs: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A ``"full"`` belief observation as (mean (D,), cov (D, D), known (M,) bool)."""
    mean = obs["mean"].astype(np.float64)
    dim = mean.shape[-1]
    return mean, obs["cov"].astype(np.float64).reshape(dim, dim), obs["known"] > 0.5


class FullEncoding:
    """``Dict(mean: (D,), cov: (D·D,), known: (M,))``, float32, with D = 3 + 2M.

    ``mean`` and the D×D covariance (flattened row-major, so that every key is a
    vector as stable-baselines3 expects; :func:`unpack_full_belief` reshapes it)
    hold the pose in entries 0..2 and landmark i in 3+2i, 4+2i; unknown slots are
    zero with ``known[i] = 0``. Positions are bounded by ±10 arena sizes and
    (co)variances by that squared; the heading lies in [−π, π].
    """

    def __init__(self, geometry: BeliefGeometry) -> None:
        self.geometry = geometry
        m = geometry.max_landmarks
        dim = 3 + 2 * m
        extent = geometry.extent
        high_mean = np.full(dim, extent, dtype=np.float32)
        high_mean[2] = math.pi
        cov_bound = np.float32(extent**2)
        self._mean_high = high_mean
        self._cov_bound = cov_bound
        self.space = spaces.Dict(
            {
                "mean": spaces.Box(-high_mean, high_mean, dtype=np.float32),
                "cov": spaces.Box(-cov_bound, cov_bound, (dim * dim,), np.float32),
                "known": spaces.Box(0.0, 1.0, (m,), np.float32),
            }
        )

    def encode(
        self, mean: np.ndarray, cov: np.ndarray, state_to_id: np.ndarray
    ) -> tuple[dict[str, np.ndarray], bool]:
        """Encode the filter's state; returns the observation and whether it clipped."""
        m = self.geometry.max_landmarks
        dim = 3 + 2 * m
        idx = slot_indices(state_to_id)
        full_mean = np.zeros(dim, dtype=np.float64)
        full_cov = np.zeros((dim, dim), dtype=np.float64)
        full_mean[idx] = mean
        full_cov[np.ix_(idx, idx)] = cov
        known = np.zeros(m, dtype=np.float32)
        known[np.asarray(state_to_id, dtype=np.int64)] = 1.0
        clipped_mean = np.clip(np.nan_to_num(full_mean), -self._mean_high, self._mean_high)
        clipped_cov = np.clip(np.nan_to_num(full_cov), -self._cov_bound, self._cov_bound)
        clipped = not (  # also true for any NaN
            np.array_equal(clipped_mean, full_mean) and np.array_equal(clipped_cov, full_cov)
        )
        obs = {
            "mean": clipped_mean.astype(np.float32),
            "cov": clipped_cov.astype(np.float32).ravel(),
            "known": known,
        }
        return obs, clipped


class EgocentricEncoding:
    """A flat ``Box`` of 7 + 4M float32 features:

    | index        | feature                                                            |
    |--------------|--------------------------------------------------------------------|
    | 0, 1         | estimated x / width, y / height (in [−10, 11])                       |
    | 2, 3         | cos θ̂, sin θ̂                                                        |
    | 4, 5, 6      | tanh(σx / 1 m), tanh(σy / 1 m), tanh(σθ / 0.5 rad): pose uncertainty |
    | 7 + 4i       | landmark i known (1) or not (0)                                     |
    | 8 + 4i, 9 + 4i | its estimated position in the estimated robot frame / max_range    |
    | 10 + 4i      | tanh(√trace Σ_ii / 1 m): its marginal uncertainty                   |

    Unknown slots are all zero.
    """

    def __init__(self, geometry: BeliefGeometry) -> None:
        self.geometry = geometry
        m = geometry.max_landmarks
        g = geometry
        rel = g.extent * 2.0 / g.max_range  # no belief inside the bounds gets further
        low = np.concatenate(
            [
                [-_EXTENT_FACTOR, -_EXTENT_FACTOR, -1.0, -1.0, 0.0, 0.0, 0.0],
                np.tile([0.0, -rel, -rel, 0.0], m),
            ]
        ).astype(np.float32)
        high = np.concatenate(
            [
                [_EXTENT_FACTOR + 1.0, _EXTENT_FACTOR + 1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
                np.tile([1.0, rel, rel, 1.0], m),
            ]
        ).astype(np.float32)
        self._low, self._high = low, high
        self._size = low.shape[0]
        self._rel_bound = float(high[8]) if m else 0.0  # |robot-frame position| bound
        self._position_bounds = (float(low[0]), float(high[0]), float(low[1]), float(high[1]))
        self.space = spaces.Box(low, high, dtype=np.float32)

    def encode(
        self,
        mean: np.ndarray,
        cov: np.ndarray,
        state_to_id: np.ndarray,
        tail: Sequence[float] = (),
    ) -> tuple[np.ndarray, bool]:
        """Encode the filter's state; returns the observation and whether it clipped.

        ``tail`` (floats) is appended after the features as it is, unclipped (the
        wrapper's raw proximity readings, already inside their own bounds).

        The features are computed on Python floats, one pass over the known
        landmarks: for the tens of landmarks of a world, a numpy call (about a
        microsecond whatever its size) costs more than a landmark's arithmetic.
        """
        g = self.geometry
        ml = mean.tolist()
        dl = cov.diagonal().tolist()
        x, y, theta = ml[0], ml[1], ml[2]
        c, s = math.cos(theta), math.sin(theta)
        sqrt, tanh = math.sqrt, math.tanh
        vx, vy, vth = dl[0], dl[1], dl[2]
        feat = [0.0] * self._size
        # Variances clamped at 0 by comparisons that let a NaN through (to be caught).
        feat[:7] = (
            x / g.width,
            y / g.height,
            c,
            s,
            tanh(sqrt(0.0 if vx < 0.0 else vx) / POSITION_STD_SCALE),
            tanh(sqrt(0.0 if vy < 0.0 else vy) / POSITION_STD_SCALE),
            tanh(sqrt(0.0 if vth < 0.0 else vth) / HEADING_STD_SCALE),
        )
        # The robot frame, R(θ)ᵀ (m − t), scaled by the sensor range.
        ck, sk = c / g.max_range, s / g.max_range
        bound = self._rel_bound
        inside = True
        ids = state_to_id.tolist() if isinstance(state_to_id, np.ndarray) else state_to_id
        for i, lid in enumerate(ids):
            row = 3 + 2 * i
            rx, ry = ml[row] - x, ml[row + 1] - y
            ex = rx * ck + ry * sk
            ey = ry * ck - rx * sk
            trace = dl[row] + dl[row + 1]
            slot = 7 + 4 * lid
            feat[slot : slot + 4] = (
                1.0,
                ex,
                ey,
                tanh(sqrt(0.0 if trace < 0.0 else trace) / POSITION_STD_SCALE),
            )
            if not (-bound <= ex <= bound and -bound <= ey <= bound):  # or NaN
                inside = False
        # Only a diverged belief leaves the bounds (a NaN or inf poisons the sum).
        x_low, x_high, y_low, y_high = self._position_bounds
        if (
            inside
            and math.isfinite(sum(feat))
            and x_low <= feat[0] <= x_high
            and y_low <= feat[1] <= y_high
        ):
            feat += tail
            return np.array(feat, dtype=np.float32), False
        out = np.minimum(np.maximum(np.nan_to_num(np.array(feat)), self._low), self._high)
        return np.concatenate([out, tail]).astype(np.float32), True
