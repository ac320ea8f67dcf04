"""Motion and measurement models of the seeds, their Jacobians and inverse models.

Pure functions of numpy arrays; the filter and the env's odometry sensor both use
the noise covariances defined here, so a noise-matched filter is matched exactly.

Conventions
-----------
* A pose is ``(x, y, θ)`` (m, m, rad); a landmark ``m = (mx, my)`` (m).
* Motion models (seed 000 "odometry", seed 004 "velocity") map a pose and a control
  ``u`` to the next pose; the heading is wrapped to [−π, π).
* Measurement models map a pose and landmarks ``m: (k, 2)`` (or one ``(2,)``) to
  measurements ``z: (k, 2)`` (or ``(2,)``); every function here is vectorised over
  the leading axes of ``m``/``z`` and returns arrays with those leading axes.

  - ``"range_bearing"`` (seed 000): ``z = [r, φ]``, ``r = √q``,
    ``φ = wrap(atan2(dy, dx) − θ)``, ``(dx, dy) = m − t``, ``q = dx² + dy²``.
  - ``"cartesian"`` (seed 004): ``z = R(θ)ᵀ (m − t)``, the landmark in the robot frame.

* The Jacobians of a measurement are the two non-zero blocks of the full-width H:
  ``H_x = ∂h/∂pose`` (2×3) and ``H_m = ∂h/∂m`` (2×2). The inverse model
  ``m = h⁻¹(z, pose)`` has ``L = ∂h⁻¹/∂pose`` (2×3) and ``W = ∂h⁻¹/∂z`` (2×2)
  (seed 000 §2.2).
* ``*_linearise`` are scalar fast paths (plain floats in, plain floats out) of
  ``h`` and ``[H_x, H_m]`` for one landmark: the filter's sequential correction calls
  them once per observation, where building small numpy arrays would cost more than
  the arithmetic.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from slam_env.geometry import wrap_angle

_TWO_PI = 2.0 * math.pi


def _wrap(a: float) -> float:
    return wrap_angle(a)  # half-open [−π, π) even at round-off


# --------------------------------------------------------------------------- noise


def odometry_action_variances(u, alphas) -> tuple[float, float, float]:
    """The diagonal of M (see :func:`odometry_action_cov`) as Python floats, for
    callers that work on a 3-vector without numpy (the odometry sensor's hot path)."""
    rot1, trans, rot2 = float(u[0]), float(u[1]), float(u[2])
    a1, a2, a3, a4 = map(float, alphas)
    r1, t, r2 = rot1 * rot1, trans * trans, rot2 * rot2
    return (a1 * r1 + a2 * t, a3 * t + a4 * (r1 + r2), a1 * r2 + a2 * t)


def odometry_action_cov(u, alphas) -> np.ndarray:
    """M, the 3×3 action-space noise of the odometry model (seed 000).

    u = (δrot1, δtr, δrot2); alphas = (α1, α2, α3, α4).
    M = diag(α1·δrot1² + α2·δtr², α3·δtr² + α4·(δrot1² + δrot2²), α1·δrot2² + α2·δtr²).
    """
    return np.diag(odometry_action_variances(u, alphas))


def velocity_control_variances(u, noise) -> tuple[float, float]:
    """The diagonal of Σu (see :func:`velocity_control_cov`) as Python floats."""
    dp, dth = float(u[0]), float(u[1])
    sp, sth, bp, bth = map(float, noise)
    return (sp * sp + bp * dp * dp, sth * sth + bth * dth * dth)


def velocity_control_cov(u, noise) -> np.ndarray:
    """Σu, the 2×2 control noise of the (Δp, Δθ) model (seed 004).

    u = (Δp, Δθ); noise = (σp, σθ, βp, βθ); Σu = diag(σp² + βp·Δp², σθ² + βθ·Δθ²).
    """
    return np.diag(velocity_control_variances(u, noise))


# --------------------------------------------------------------------------- motion


def odometry_motion(pose, u) -> np.ndarray:
    """g(pose, u) for u = (δrot1, δtr, δrot2) (seed 000): the next pose (3,).

    x += δtr·cos(θ + δrot1), y += δtr·sin(θ + δrot1), θ = wrap(θ + δrot1 + δrot2).
    """
    x, y, th = float(pose[0]), float(pose[1]), float(pose[2])
    rot1, trans, rot2 = float(u[0]), float(u[1]), float(u[2])
    a = th + rot1
    return np.array([x + trans * math.cos(a), y + trans * math.sin(a), _wrap(a + rot2)])


def odometry_jacobians(pose, u) -> tuple[np.ndarray, np.ndarray]:
    """(G, V) of the odometry model: G = ∂g/∂pose (3×3), V = ∂g/∂u (3×3).

    G = [[1, 0, −δtr·sin(θ+δrot1)], [0, 1, δtr·cos(θ+δrot1)], [0, 0, 1]]
    V = [[−δtr·sin(θ+δrot1), cos(θ+δrot1), 0], [δtr·cos(θ+δrot1), sin(θ+δrot1), 0], [1, 0, 1]]
    """
    th = float(pose[2])
    rot1, trans = float(u[0]), float(u[1])
    c, s = math.cos(th + rot1), math.sin(th + rot1)
    G = np.array([[1.0, 0.0, -trans * s], [0.0, 1.0, trans * c], [0.0, 0.0, 1.0]])
    V = np.array([[-trans * s, c, 0.0], [trans * c, s, 0.0], [1.0, 0.0, 1.0]])
    return G, V


def velocity_motion(pose, u) -> np.ndarray:
    """f(pose, u) for u = (Δp, Δθ) (seed 004, translation then rotation): (3,).

    x += Δp·cos θ, y += Δp·sin θ, θ = wrap(θ + Δθ).
    """
    x, y, th = float(pose[0]), float(pose[1]), float(pose[2])
    dp, dth = float(u[0]), float(u[1])
    return np.array([x + dp * math.cos(th), y + dp * math.sin(th), _wrap(th + dth)])


def velocity_jacobians(pose, u) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of the velocity model: A = ∂f/∂pose (3×3), B = ∂f/∂u (3×2).

    A = [[1, 0, −Δp·sin θ], [0, 1, Δp·cos θ], [0, 0, 1]]
    B = [[cos θ, 0], [sin θ, 0], [0, 1]]
    """
    th = float(pose[2])
    dp = float(u[0])
    c, s = math.cos(th), math.sin(th)
    A = np.array([[1.0, 0.0, -dp * s], [0.0, 1.0, dp * c], [0.0, 0.0, 1.0]])
    B = np.array([[c, 0.0], [s, 0.0], [0.0, 1.0]])
    return A, B


def odometry_linearise(
    x: float, y: float, th: float, u, alphas
) -> tuple[float, float, float, float, float, tuple[float, ...]]:
    """Scalar fast path of the odometry prediction: ``(x', y', θ', a, b, R)``.

    The next pose g(pose, u); G = ∂g/∂pose = [[1, 0, a], [0, 1, b], [0, 0, 1]]; and
    R_x = V M Vᵀ as its upper triangle (r00, r01, r02, r11, r12, r22).
    """
    rot1, trans, rot2 = u
    a1, a2, a3, a4 = alphas
    r1, t2, r2 = rot1 * rot1, trans * trans, rot2 * rot2
    m0 = a1 * r1 + a2 * t2
    m1 = a3 * t2 + a4 * (r1 + r2)
    m2 = a1 * r2 + a2 * t2
    h = th + rot1
    c, s = math.cos(h), math.sin(h)
    ts, tc = trans * s, trans * c
    # V = [[−ts, c, 0], [tc, s, 0], [1, 0, 1]], R_x = V diag(m0, m1, m2) Vᵀ.
    R = (
        ts * ts * m0 + c * c * m1,
        -ts * tc * m0 + c * s * m1,
        -ts * m0,
        tc * tc * m0 + s * s * m1,
        tc * m0,
        m0 + m2,
    )
    return x + tc, y + ts, _wrap(h + rot2), -ts, tc, R


def velocity_linearise(
    x: float, y: float, th: float, u, noise
) -> tuple[float, float, float, float, float, tuple[float, ...]]:
    """Scalar fast path of the velocity prediction: ``(x', y', θ', a, b, R)``.

    A = ∂f/∂pose = [[1, 0, a], [0, 1, b], [0, 0, 1]]; R_x = B Σu Bᵀ as its upper
    triangle (r00, r01, r02, r11, r12, r22).
    """
    dp, dth = u
    sp, sth, bp, bth = noise
    v0 = sp * sp + bp * dp * dp
    v1 = sth * sth + bth * dth * dth
    c, s = math.cos(th), math.sin(th)
    R = (c * c * v0, c * s * v0, 0.0, s * s * v0, 0.0, v1)
    return x + dp * c, y + dp * s, _wrap(th + dth), -dp * s, dp * c, R


@dataclass(frozen=True)
class MotionModel:
    """A motion model as the filter uses it.

    ``motion(pose, u) -> pose'``; ``jacobians(pose, u) -> (∂g/∂pose, ∂g/∂u)``;
    ``noise_cov(u, params) -> control covariance`` (M or Σu) so that
    ``R_x = J_u · noise_cov · J_uᵀ``; ``control_dim`` is the length of u.
    ``linearise(x, y, θ, u, params)`` is the scalar fast path the filter calls; it
    relies on ∂g/∂pose having the form [[1, 0, a], [0, 1, b], [0, 0, 1]] (true of
    both models: the heading enters the position only, nothing enters the heading).
    """

    name: str
    control_dim: int
    motion: Callable[..., np.ndarray]
    jacobians: Callable[..., tuple[np.ndarray, np.ndarray]]
    noise_cov: Callable[..., np.ndarray]
    linearise: Callable[..., tuple[float, float, float, float, float, tuple[float, ...]]]


MOTION_MODELS: dict[str, MotionModel] = {
    "odometry": MotionModel(
        "odometry",
        3,
        odometry_motion,
        odometry_jacobians,
        odometry_action_cov,
        odometry_linearise,
    ),
    "velocity": MotionModel(
        "velocity",
        2,
        velocity_motion,
        velocity_jacobians,
        velocity_control_cov,
        velocity_linearise,
    ),
}


# --------------------------------------------------------------------------- measurement


def _pose_floats(pose) -> tuple[float, float, float]:
    return float(pose[0]), float(pose[1]), float(pose[2])


def range_bearing_h(pose, m) -> np.ndarray:
    """z = h(pose, m) = [r, φ] for landmarks m: (..., 2) → (..., 2); φ wrapped."""
    x, y, th = _pose_floats(pose)
    m = np.asarray(m, dtype=float)
    dx = m[..., 0] - x
    dy = m[..., 1] - y
    return np.stack([np.hypot(dx, dy), wrap_angle(np.arctan2(dy, dx) - th)], axis=-1)


def range_bearing_jacobians(pose, m) -> tuple[np.ndarray, np.ndarray]:
    """(H_x (..., 2, 3), H_m (..., 2, 2)) of the range-bearing model (seed 000 §2.3).

    H_x = [[−dx/√q, −dy/√q, 0], [dy/q, −dx/q, −1]], H_m = [[dx/√q, dy/√q], [−dy/q, dx/q]].
    Undefined at q = 0 (a landmark on the robot).
    """
    x, y, _ = _pose_floats(pose)
    m = np.asarray(m, dtype=float)
    dx = m[..., 0] - x
    dy = m[..., 1] - y
    q = dx * dx + dy * dy
    r = np.sqrt(q)
    Hm = np.stack([np.stack([dx / r, dy / r], -1), np.stack([-dy / q, dx / q], -1)], -2)
    Hx = np.zeros((*dx.shape, 2, 3))
    Hx[..., :, :2] = -Hm
    Hx[..., 1, 2] = -1.0
    return Hx, Hm


def range_bearing_inverse(pose, z) -> np.ndarray:
    """m = h⁻¹(z, pose) = t + r·[cos(φ + θ), sin(φ + θ)] for z: (..., 2) → (..., 2)."""
    x, y, th = _pose_floats(pose)
    z = np.asarray(z, dtype=float)
    r = z[..., 0]
    a = z[..., 1] + th
    return np.stack([x + r * np.cos(a), y + r * np.sin(a)], axis=-1)


def range_bearing_inverse_jacobians(pose, z) -> tuple[np.ndarray, np.ndarray]:
    """(L (..., 2, 3), W (..., 2, 2)) of the range-bearing inverse model (seed 000 §2.2).

    L = [[1, 0, −r·sin(φ+θ)], [0, 1, r·cos(φ+θ)]], W = [[cos(φ+θ), −r·sin(φ+θ)],
    [sin(φ+θ), r·cos(φ+θ)]].
    """
    th = float(pose[2])
    z = np.asarray(z, dtype=float)
    r = z[..., 0]
    a = z[..., 1] + th
    c, s = np.cos(a), np.sin(a)
    L = np.zeros((*r.shape, 2, 3))
    L[..., 0, 0] = 1.0
    L[..., 1, 1] = 1.0
    L[..., 0, 2] = -r * s
    L[..., 1, 2] = r * c
    W = np.stack([np.stack([c, -r * s], -1), np.stack([s, r * c], -1)], -2)
    return L, W


def range_bearing_linearise(
    x: float, y: float, th: float, mx: float, my: float
) -> tuple[float, float, tuple[float, ...], tuple[float, ...]]:
    """Scalar fast path: (r̂, φ̂, row 0, row 1) with the rows of [H_x | H_m] (2×5).

    Raises ``ZeroDivisionError`` when the landmark is on the robot (q = 0).
    """
    dx = mx - x
    dy = my - y
    q = dx * dx + dy * dy
    r = math.sqrt(q)
    a, b = dx / r, dy / r
    c, d = dy / q, dx / q
    phi = _wrap(math.atan2(dy, dx) - th)
    return r, phi, (-a, -b, 0.0, a, b), (c, -d, -1.0, -c, d)


def range_bearing_singular(pose, m) -> np.ndarray:
    """(...,) bool: where the range-bearing Jacobians are undefined (q = 0)."""
    x, y, _ = _pose_floats(pose)
    m = np.asarray(m, dtype=float)
    return (m[..., 0] == x) & (m[..., 1] == y)


def cartesian_h(pose, m) -> np.ndarray:
    """z = R(θ)ᵀ(m − t) for landmarks m: (..., 2) → (..., 2) (seed 004)."""
    x, y, th = _pose_floats(pose)
    m = np.asarray(m, dtype=float)
    c, s = math.cos(th), math.sin(th)
    dx = m[..., 0] - x
    dy = m[..., 1] - y
    return np.stack([c * dx + s * dy, -s * dx + c * dy], axis=-1)


def cartesian_jacobians(pose, m) -> tuple[np.ndarray, np.ndarray]:
    """(H_x (..., 2, 3), H_m (..., 2, 2)) of the cartesian model.

    With z = (z1, z2) = h: H_x = [[−cos θ, −sin θ, z2], [sin θ, −cos θ, −z1]],
    H_m = R(θ)ᵀ = [[cos θ, sin θ], [−sin θ, cos θ]].
    """
    z = cartesian_h(pose, m)
    c, s = math.cos(float(pose[2])), math.sin(float(pose[2]))
    lead = z.shape[:-1]
    Hx = np.empty((*lead, 2, 3))
    Hx[..., 0, 0] = -c
    Hx[..., 0, 1] = -s
    Hx[..., 0, 2] = z[..., 1]
    Hx[..., 1, 0] = s
    Hx[..., 1, 1] = -c
    Hx[..., 1, 2] = -z[..., 0]
    Hm = np.broadcast_to(np.array([[c, s], [-s, c]]), (*lead, 2, 2)).copy()
    return Hx, Hm


def cartesian_inverse(pose, z) -> np.ndarray:
    """m = h⁻¹(z, pose) = t + R(θ)·z for z: (..., 2) → (..., 2)."""
    x, y, th = _pose_floats(pose)
    z = np.asarray(z, dtype=float)
    c, s = math.cos(th), math.sin(th)
    return np.stack([x + c * z[..., 0] - s * z[..., 1], y + s * z[..., 0] + c * z[..., 1]], -1)


def cartesian_inverse_jacobians(pose, z) -> tuple[np.ndarray, np.ndarray]:
    """(L (..., 2, 3), W (..., 2, 2)) of the cartesian inverse model.

    L = [[1, 0, −sin θ·z1 − cos θ·z2], [0, 1, cos θ·z1 − sin θ·z2]], W = R(θ).
    """
    th = float(pose[2])
    z = np.asarray(z, dtype=float)
    c, s = math.cos(th), math.sin(th)
    lead = z.shape[:-1]
    L = np.zeros((*lead, 2, 3))
    L[..., 0, 0] = 1.0
    L[..., 1, 1] = 1.0
    L[..., 0, 2] = -s * z[..., 0] - c * z[..., 1]
    L[..., 1, 2] = c * z[..., 0] - s * z[..., 1]
    W = np.broadcast_to(np.array([[c, -s], [s, c]]), (*lead, 2, 2)).copy()
    return L, W


def cartesian_linearise(
    x: float, y: float, th: float, mx: float, my: float
) -> tuple[float, float, tuple[float, ...], tuple[float, ...]]:
    """Scalar fast path: (ẑ1, ẑ2, row 0, row 1) with the rows of [H_x | H_m] (2×5)."""
    c, s = math.cos(th), math.sin(th)
    dx = mx - x
    dy = my - y
    z1 = c * dx + s * dy
    z2 = -s * dx + c * dy
    return z1, z2, (-c, -s, z2, c, s), (s, -c, -z1, -s, c)


def cartesian_singular(pose, m) -> np.ndarray:
    """(...,) bool: the cartesian model is linear in m and smooth everywhere."""
    return np.zeros(np.shape(m)[:-1], dtype=bool)


@dataclass(frozen=True)
class MeasurementModel:
    """A measurement model as the filter uses it (all functions above, by model).

    ``angular[i]`` says whether component i of z is an angle, whose innovation is
    wrapped to [−π, π). ``singular(pose, m) -> (k,) bool`` marks landmarks at which
    ``h`` cannot be linearised (range-bearing: a landmark on the robot, q = 0).
    """

    name: str
    h: Callable[..., np.ndarray]
    jacobians: Callable[..., tuple[np.ndarray, np.ndarray]]
    inverse: Callable[..., np.ndarray]
    inverse_jacobians: Callable[..., tuple[np.ndarray, np.ndarray]]
    linearise: Callable[..., tuple[float, float, tuple[float, ...], tuple[float, ...]]]
    angular: tuple[bool, bool]
    singular: Callable[..., np.ndarray]


MEASUREMENT_MODELS: dict[str, MeasurementModel] = {
    "range_bearing": MeasurementModel(
        "range_bearing",
        range_bearing_h,
        range_bearing_jacobians,
        range_bearing_inverse,
        range_bearing_inverse_jacobians,
        range_bearing_linearise,
        (False, True),
        range_bearing_singular,
    ),
    "cartesian": MeasurementModel(
        "cartesian",
        cartesian_h,
        cartesian_jacobians,
        cartesian_inverse,
        cartesian_inverse_jacobians,
        cartesian_linearise,
        (False, False),
        cartesian_singular,
    ),
}
