"""Belief observations: the EKF-SLAM belief encoded as fixed-size float32 arrays.

Two encodings, both slotted by landmark ID (slot i is always landmark i):

* ``"full"``: the belief exactly, a ``Dict`` with the mean and covariance padded to
  ``max_landmarks`` and a known-mask.
* ``"egocentric"``: a flat ``Box`` of features a policy learns from easily (see
  :class:`EgocentricEncoding` for the layout).

Both clip to their (finite) bounds; the wrapper reports in ``info`` when it had to.
Both are computed by kernels over B worlds (:mod:`slam_env.kernels.belief.egocentric`,
:mod:`slam_env.kernels.belief.full_belief`); ``encode`` is the case of one belief.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

from slam_env.kernels.belief.belief_state import SINGLE, BeliefBatch
from slam_env.kernels.belief.egocentric import EgocentricParams, encode_egocentric
from slam_env.kernels.belief.full_belief import FullBelief, encode_full

# Scales that turn standard deviations into features in [0, 1): tanh(σ / scale).
# The belief observations of the wrapper (ActiveSLAM-v0 adds "local").
OBSERVATION_MODES = ("egocentric", "full")
# Raw observation keys handed to the policy as they are, in this order: the proximity
# sensors, which say where obstacles are (the landmark map does not hold them).
PASSTHROUGH_KEYS = ("scan", "bumper")
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


def single_belief(mean: np.ndarray, cov: np.ndarray, state_to_id: Sequence[int]) -> BeliefBatch:
    """One belief in the filter's state order (mean (d,), cov (d, d), the landmark ID
    of each slot) as a batch of one."""
    ids = np.asarray(state_to_id, dtype=np.int64)
    return BeliefBatch(
        np.ascontiguousarray(mean, dtype=np.float64)[None],
        np.ascontiguousarray(cov, dtype=np.float64)[None],
        np.full(SINGLE, ids.shape[0], dtype=np.int64),
        np.ascontiguousarray(ids)[None],
    )


class FullEncoding:
    """``Dict(mean: (D,), cov: (D·D,), known: (M,))``, float32, with D = 3 + 2M.

    ``mean`` and the D×D covariance (flattened row-major, so that every key is a
    vector as stable-baselines3 expects; :func:`unpack_full_belief` reshapes it)
    hold the pose in entries 0..2 and landmark i in 3+2i, 4+2i; unknown slots are
    zero with ``known[i] = 0``. Positions are bounded by ±10 arena sizes and
    (co)variances by that squared; the heading lies in [−π, π]. Entries beyond the
    bounds are clipped onto them, NaN read as 0.
    """

    def __init__(self, geometry: BeliefGeometry) -> None:
        self.geometry = geometry
        m = geometry.max_landmarks
        dim = 3 + 2 * m
        extent = geometry.extent
        high_mean = np.full(dim, extent, dtype=np.float32)
        high_mean[2] = math.pi
        cov_bound = np.float32(extent**2)
        # float64 copies of the float32 bounds, for the kernel.
        self._mean_bound = high_mean.astype(np.float64)
        self._cov_bound = float(cov_bound)
        self.space = spaces.Dict(
            {
                "mean": spaces.Box(-high_mean, high_mean, dtype=np.float32),
                "cov": spaces.Box(-cov_bound, cov_bound, (dim * dim,), np.float32),
                "known": spaces.Box(0.0, 1.0, (m,), np.float32),
            }
        )

    def empty(self, worlds: int) -> FullBelief:
        """Fresh (B, …) arrays for :meth:`encode_batch` to write."""
        m = self.geometry.max_landmarks
        dim = 3 + 2 * m
        return FullBelief(
            np.empty((worlds, dim), np.float32),
            np.empty((worlds, dim * dim), np.float32),
            np.empty((worlds, m), np.float32),
            np.empty(worlds, np.bool_),
        )

    def encode_batch(
        self, belief: BeliefBatch, out: FullBelief, active: np.ndarray | None = None
    ) -> None:
        """Encode the B beliefs of ``active`` (B,) bool (default all) into ``out`` (from
        :meth:`empty`)."""
        active = np.ones(belief.x.shape[0], dtype=np.bool_) if active is None else active
        encode_full(*belief, self._mean_bound, self._cov_bound, *out, active)

    def encode(
        self, mean: np.ndarray, cov: np.ndarray, state_to_id: Sequence[int]
    ) -> tuple[dict[str, np.ndarray], bool]:
        """Encode one belief in the filter's state order (mean (d,), cov (d, d), the
        landmark ID of each slot); returns the observation and whether it clipped."""
        out = self.empty(SINGLE)
        self.encode_batch(single_belief(mean, cov, state_to_id), out)
        obs = {"mean": out.mean[0], "cov": out.cov[0], "known": out.known[0]}
        return obs, bool(out.clipped[0])


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

    Unknown slots are all zero. A negative variance (round-off) reads as 0. A belief
    outside the bounds (or with a NaN or an infinity) is clipped onto them, NaN read
    as 0.
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
        self.size = low.shape[0]
        self.space = spaces.Box(low, high, dtype=np.float32)
        # float64 copies of the float32 bounds, for the kernel.
        scales = [g.width, g.height, g.max_range, POSITION_STD_SCALE, HEADING_STD_SCALE]
        self.params = EgocentricParams(
            np.array(scales, dtype=np.float64), low.astype(np.float64), high.astype(np.float64)
        )
        self._features = np.zeros(self.size)  # the kernel's scratch: one world's features

    def encode_batch(
        self,
        belief: BeliefBatch,
        tail: np.ndarray,
        out: np.ndarray,
        clipped: np.ndarray,
        active: np.ndarray | None = None,
    ) -> None:
        """Encode the B beliefs of ``active`` (B,) bool (default all): ``out`` (B, F + T)
        float32 gets the features, then ``tail`` (B, T) float32 as it is (the raw
        proximity readings, already inside their own bounds); ``clipped`` (B,) bool."""
        active = np.ones(belief.x.shape[0], dtype=np.bool_) if active is None else active
        encode_egocentric(*belief, *self.params, tail, out, clipped, active, self._features)

    def encode(
        self,
        mean: np.ndarray,
        cov: np.ndarray,
        state_to_id: Sequence[int],
        tail: Sequence[float] = (),
    ) -> tuple[np.ndarray, bool]:
        """Encode one belief in the filter's state order (mean (d,), cov (d, d), the
        landmark ID of each slot), with ``tail`` (floats) appended as it is; returns
        the observation and whether it clipped."""
        tail = np.asarray(tail, dtype=np.float32).reshape(SINGLE, -1)
        out = np.empty((SINGLE, self.size + tail.shape[1]), dtype=np.float32)
        clipped = np.empty(SINGLE, dtype=np.bool_)
        self.encode_batch(single_belief(mean, cov, state_to_id), tail, out, clipped)
        return out[0], bool(clipped[0])
