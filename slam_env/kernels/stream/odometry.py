"""Odometry of B worlds: the control that explains each motion, and a noisy reading of it.

Model ``"odometry"`` (seed 000): u = (δrot1, δtr, δrot2) with the action-space noise M(u);
model ``"velocity"`` (seed 004): u = (Δp, Δθ) with Σu (both in
:mod:`slam_env.kernels.base.models`, which the filter uses too: a noise-matched filter is
matched exactly). The reading is
``u + sqrt(diag(C(u))) · ε`` at the true control, rotations wrapped, ε from Box–Muller
pairs of the step's uniforms (:func:`odometry_uniforms` of them).
"""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base.angles import wrap
from slam_env.kernels.base.compiling import kernel
from slam_env.kernels.base.models import (
    MIN_ODOMETRY_TRANSLATION,
    odometry_variances,
    velocity_variances,
)
from slam_env.kernels.base.random import normal_pair

HALF_PI = 0.5 * math.pi


def odometry_uniforms(control_dim: int) -> int:
    """Uniforms one reading consumes: a Box–Muller pair per two control entries."""
    return 2 * ((control_dim + 1) // 2)


@kernel
def odometry_from_poses(
    x0: float, y0: float, th0: float, x1: float, y1: float, th1: float, min_translation: float
) -> tuple[float, float, float]:
    """(δrot1, δtr, δrot2) of the motion pose0 → pose1 (seed 000).

    A motion backwards relative to the heading gets a negative δtr, so that δrot1
    stays small instead of jumping to ±π: the model's noise grows with δrot1², and
    reversing is not a half-turn. Below ``min_translation`` δrot1 is 0, δtr is the
    displacement along the heading and the whole rotation goes into δrot2 (the
    sideways part, under a millimetre, is dropped).
    """
    dx, dy = x1 - x0, y1 - y0
    trans = math.hypot(dx, dy)
    if trans < min_translation:
        return 0.0, dx * math.cos(th0) + dy * math.sin(th0), wrap(th1 - th0)
    rot1 = wrap(math.atan2(dy, dx) - th0)
    if abs(rot1) > HALF_PI:
        rot1 = wrap(rot1 - math.pi)
        trans = -trans
    return rot1, trans, wrap(th1 - th0 - rot1)


@kernel
def velocity_from_poses(
    x0: float, y0: float, th0: float, x1: float, y1: float, th1: float
) -> tuple[float, float]:
    """(Δp, Δθ) of the motion pose0 → pose1 (seed 004): the displacement projected on
    the initial heading (signed), and the wrapped turn."""
    return (x1 - x0) * math.cos(th0) + (y1 - y0) * math.sin(th0), wrap(th1 - th0)


@kernel
def true_control(
    velocity_model: bool, x0: float, y0: float, th0: float, x1: float, y1: float, th1: float
) -> tuple[float, float, float]:
    """The control of the motion pose0 → pose1: (δrot1, δtr, δrot2), or (Δp, Δθ, 0)."""
    if velocity_model:
        dp, dth = velocity_from_poses(x0, y0, th0, x1, y1, th1)
        return dp, dth, 0.0
    return odometry_from_poses(x0, y0, th0, x1, y1, th1, MIN_ODOMETRY_TRANSLATION)


@kernel
def noisy_control(
    velocity_model: bool,
    c0: float,
    c1: float,
    c2: float,
    noise: np.ndarray,
    uniforms: np.ndarray,
    offset: int,
) -> tuple[float, float, float]:
    """A noisy reading of the true control (c0, c1, c2) (c2 unused by the velocity
    model): each entry plus its standard deviation times a normal from the uniforms at
    ``offset`` (see :func:`odometry_uniforms`), rotations wrapped."""
    e0, e1 = normal_pair(uniforms[offset], uniforms[offset + 1])
    if velocity_model:
        v0, v1 = velocity_variances(c0, c1, noise[0], noise[1], noise[2], noise[3])
        return c0 + math.sqrt(v0) * e0, wrap(c1 + math.sqrt(v1) * e1), 0.0
    v0, v1, v2 = odometry_variances(c0, c1, c2, noise[0], noise[1], noise[2], noise[3])
    e2 = normal_pair(uniforms[offset + 2], uniforms[offset + 3])[0]
    return wrap(c0 + math.sqrt(v0) * e0), c1 + math.sqrt(v1) * e1, wrap(c2 + math.sqrt(v2) * e2)


@kernel
def read_odometry(
    pose0: np.ndarray,
    pose1: np.ndarray,
    velocity_model: bool,
    noise: np.ndarray,
    uniforms: np.ndarray,
    offset: int,
    active: np.ndarray,
    out_true: np.ndarray,
    out_reading: np.ndarray,
) -> None:
    """The true control of each active world's motion ``pose0[b] → pose1[b]`` into
    ``out_true[b]`` and its noisy reading into ``out_reading[b]`` ((B, 3) for the
    odometry model, (B, 2) for the velocity model). ``noise`` is α1..α4 or
    (σp, σθ, βp, βθ); the reading reads uniforms ``offset :`` of ``uniforms[b]``."""
    dim = out_true.shape[1]
    for b in range(pose0.shape[0]):
        if not active[b]:
            continue
        c = true_control(
            velocity_model,
            pose0[b, 0],
            pose0[b, 1],
            pose0[b, 2],
            pose1[b, 0],
            pose1[b, 1],
            pose1[b, 2],
        )
        r = noisy_control(velocity_model, c[0], c[1], c[2], noise, uniforms[b], offset)
        for i in range(dim):
            out_true[b, i] = c[i]
            out_reading[b, i] = r[i]
