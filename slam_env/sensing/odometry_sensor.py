"""Noisy odometry for users' own worlds, over the same compiled functions as the envs'
batched core.

A plain class built from its frozen :class:`~slam_env.config.OdometryConfig`; it imports
neither pymunk nor gymnasium. All randomness comes from the ``numpy.random.Generator``
passed to each call (one block of uniforms, as Box–Muller normals), so the same seed
and the same inputs give bit-identical readings, and the noise covariance is the one
the filter's motion model uses (:attr:`OdometrySensor.alphas` / ``velocity_noise``).
"""

from __future__ import annotations

import numpy as np

from slam_env.config import OdometryConfig
from slam_env.kernels.base.models import odometry_variances, velocity_variances
from slam_env.kernels.stream.odometry import noisy_control, odometry_uniforms, true_control

__all__ = ["OdometrySensor"]


class OdometrySensor:
    """Noisy odometry: the robot's true motion pose0 → pose1, decomposed into a
    control u, plus Gaussian noise sampled in action space with exactly the
    covariance the filter's motion model uses (:mod:`slam_env.kernels.stream.odometry`).

    Model ``"odometry"`` (seed 000), ``dim = 3``: ``u = (δrot1 [rad], δtr [m],
    δrot2 [rad])`` (a backwards motion has δtr < 0 and a small δrot1); noise
    covariance ``M(u) = diag(α1·δrot1² + α2·δtr², α3·δtr² + α4·(δrot1² + δrot2²),
    α1·δrot2² + α2·δtr²)``, α1..α4 = :attr:`alphas` (unitless).

    Model ``"velocity"`` (seed 004), ``dim = 2``: ``u = (Δp [m], Δθ [rad])``; noise
    covariance ``Σu(u) = diag(σp² + βp·Δp², σθ² + βθ·Δθ²)`` with
    :attr:`velocity_noise` = (σp [m], σθ [rad], βp, βθ).

    Reading: ``u_noisy = u_true + sqrt(diag(C(u_true))) · ε``, the rotation entries
    wrapped to [−π, π), ε ~ N(0, I) from one ``rng.random(4)`` (odometry) or
    ``rng.random(2)`` (velocity) call, as Box–Muller pairs (always drawn, even when
    C = 0). :meth:`perturb` applies the noise to a control already computed with
    :meth:`true_control` (``measure = perturb ∘ true_control``).

    Caveat of the α-model: δrot1 is the direction of travel, so a translation just
    above the 1 mm threshold below which δrot1 is 0 (e.g. a push during an in-place
    turn) can give |δrot1| up to π/2 and a large α1·δrot1² noise.
    """

    def __init__(self, config: OdometryConfig) -> None:
        if not isinstance(config, OdometryConfig):
            raise TypeError(f"config must be an OdometryConfig, got {type(config).__name__}")
        self.config = config
        self.model = config.motion_model
        self.alphas = tuple(float(a) for a in config.alphas)  # α1..α4, unitless
        self.velocity_noise = tuple(float(v) for v in config.velocity_noise)  # σp, σθ, βp, βθ
        self._velocity = self.model == "velocity"
        self.dim: int = 2 if self._velocity else 3
        self.angle_indices: tuple[int, ...] = (1,) if self._velocity else (0, 2)
        """Entries of u that are angles (wrapped to [−π, π))."""
        self._noise = np.array(self.velocity_noise if self._velocity else self.alphas)

    def true_control(self, pose0, pose1) -> np.ndarray:
        """The noiseless control (dim,) that takes pose0 to pose1."""
        p0 = [float(v) for v in pose0[:3]]
        p1 = [float(v) for v in pose1[:3]]
        return np.array(true_control(self._velocity, *p0, *p1)[: self.dim])

    def noise_cov(self, u) -> np.ndarray:
        """The action-space noise covariance at u: M (3×3) or Σu (2×2), diagonal."""
        u = self._control(u)
        if self._velocity:
            return np.diag(velocity_variances(u[0], u[1], *self.velocity_noise))
        return np.diag(odometry_variances(u[0], u[1], u[2], *self.alphas))

    def perturb(self, u, rng: np.random.Generator) -> np.ndarray:
        """A noisy reading of the (true) control u: ``u + sqrt(diag(C(u)))·ε``,
        rotations wrapped. Returns a new (dim,) float64 array."""
        u = self._control(u)
        c2 = 0.0 if self._velocity else u[2]
        uniforms = rng.random(odometry_uniforms(self.dim))
        reading = noisy_control(self._velocity, u[0], u[1], c2, self._noise, uniforms, 0)
        return np.array(reading[: self.dim])

    def measure(self, pose0, pose1, rng: np.random.Generator) -> np.ndarray:
        """The noisy odometry reading (dim,) for the true motion pose0 → pose1."""
        return self.perturb(self.true_control(pose0, pose1), rng)

    def _control(self, u) -> list[float]:
        u = np.asarray(u, dtype=np.float64)
        if u.shape != (self.dim,):
            raise ValueError(f"u must have shape ({self.dim},), got {u.shape}")
        return u.tolist()
