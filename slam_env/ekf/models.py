"""Motion and measurement models of the seeds, their Jacobians and inverse models,
as functions of numpy arrays.

The equations themselves are written once, as the scalar compiled functions of
:mod:`slam_env.kernels.base.models` that the filter's kernels and the odometry sensor call;
these are their array forms, for tests, planners and users. The filter and the env's
odometry sensor use the same noise covariances, so a noise-matched filter is matched
exactly.

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
* ``*_linearise`` are scalar forms (plain floats in, plain floats out) of the
  prediction and of ``h`` with ``[H_x, H_m]`` for one landmark.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from slam_env.kernels.base import models as km

# --------------------------------------------------------------------------- noise


def odometry_action_variances(u, alphas) -> tuple[float, float, float]:
    """The diagonal of M (see :func:`odometry_action_cov`) as Python floats."""
    a1, a2, a3, a4 = map(float, alphas)
    return km.odometry_variances(float(u[0]), float(u[1]), float(u[2]), a1, a2, a3, a4)


def odometry_action_cov(u, alphas) -> np.ndarray:
    """M, the 3×3 action-space noise of the odometry model (seed 000).

    u = (δrot1, δtr, δrot2); alphas = (α1, α2, α3, α4).
    M = diag(α1·δrot1² + α2·δtr², α3·δtr² + α4·(δrot1² + δrot2²), α1·δrot2² + α2·δtr²).
    """
    return np.diag(odometry_action_variances(u, alphas))


def velocity_control_variances(u, noise) -> tuple[float, float]:
    """The diagonal of Σu (see :func:`velocity_control_cov`) as Python floats."""
    sp, sth, bp, bth = map(float, noise)
    return km.velocity_variances(float(u[0]), float(u[1]), sp, sth, bp, bth)


def velocity_control_cov(u, noise) -> np.ndarray:
    """Σu, the 2×2 control noise of the (Δp, Δθ) model (seed 004).

    u = (Δp, Δθ); noise = (σp, σθ, βp, βθ); Σu = diag(σp² + βp·Δp², σθ² + βθ·Δθ²).
    """
    return np.diag(velocity_control_variances(u, noise))


# --------------------------------------------------------------------------- motion


def _pose_floats(pose) -> tuple[float, float, float]:
    return float(pose[0]), float(pose[1]), float(pose[2])


def _pose_jacobian(a: float, b: float) -> np.ndarray:
    """G = [[1, 0, a], [0, 1, b], [0, 0, 1]], the pose Jacobian of both motion models."""
    return np.array([[1.0, 0.0, a], [0.0, 1.0, b], [0.0, 0.0, 1.0]])


def odometry_motion(pose, u) -> np.ndarray:
    """g(pose, u) for u = (δrot1, δtr, δrot2) (seed 000): the next pose (3,).

    x += δtr·cos(θ + δrot1), y += δtr·sin(θ + δrot1), θ = wrap(θ + δrot1 + δrot2).
    """
    return np.array(km.odometry_motion(*_pose_floats(pose), float(u[0]), float(u[1]), float(u[2])))


def odometry_jacobians(pose, u) -> tuple[np.ndarray, np.ndarray]:
    """(G, V) of the odometry model: G = ∂g/∂pose (3×3), V = ∂g/∂u (3×3).

    G = [[1, 0, −δtr·sin(θ+δrot1)], [0, 1, δtr·cos(θ+δrot1)], [0, 0, 1]]
    V = [[−δtr·sin(θ+δrot1), cos(θ+δrot1), 0], [δtr·cos(θ+δrot1), sin(θ+δrot1), 0], [1, 0, 1]]
    """
    a, b, c, s = km.odometry_jacobian(float(pose[2]), float(u[0]), float(u[1]))
    return _pose_jacobian(a, b), np.array([[a, c, 0.0], [b, s, 0.0], [1.0, 0.0, 1.0]])


def velocity_motion(pose, u) -> np.ndarray:
    """f(pose, u) for u = (Δp, Δθ) (seed 004, translation then rotation): (3,).

    x += Δp·cos θ, y += Δp·sin θ, θ = wrap(θ + Δθ).
    """
    return np.array(km.velocity_motion(*_pose_floats(pose), float(u[0]), float(u[1])))


def velocity_jacobians(pose, u) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of the velocity model: A = ∂f/∂pose (3×3), B = ∂f/∂u (3×2).

    A = [[1, 0, −Δp·sin θ], [0, 1, Δp·cos θ], [0, 0, 1]]
    B = [[cos θ, 0], [sin θ, 0], [0, 1]]
    """
    a, b, c, s = km.velocity_jacobian(float(pose[2]), float(u[0]))
    return _pose_jacobian(a, b), np.array([[c, 0.0], [s, 0.0], [0.0, 1.0]])


def odometry_linearise(
    x: float, y: float, th: float, u, alphas
) -> tuple[float, float, float, float, float, tuple[float, ...]]:
    """Scalar form of the odometry prediction: ``(x', y', θ', a, b, R)``.

    The next pose g(pose, u); G = ∂g/∂pose = [[1, 0, a], [0, 1, b], [0, 0, 1]]; and
    R_x = V M Vᵀ as its upper triangle (r00, r01, r02, r11, r12, r22).
    """
    out = km.odometry_predict(x, y, th, *map(float, u), *map(float, alphas))
    return (*out[:5], out[5:])


def velocity_linearise(
    x: float, y: float, th: float, u, noise
) -> tuple[float, float, float, float, float, tuple[float, ...]]:
    """Scalar form of the velocity prediction: ``(x', y', θ', a, b, R)``.

    A = ∂f/∂pose = [[1, 0, a], [0, 1, b], [0, 0, 1]]; R_x = B Σu Bᵀ as its upper
    triangle (r00, r01, r02, r11, r12, r22).
    """
    out = km.velocity_predict(x, y, th, *map(float, u), *map(float, noise))
    return (*out[:5], out[5:])


@dataclass(frozen=True)
class MotionModel:
    """A motion model as the filter uses it.

    ``motion(pose, u) -> pose'``; ``jacobians(pose, u) -> (∂g/∂pose, ∂g/∂u)``;
    ``noise_cov(u, params) -> control covariance`` (M or Σu), the linearised part
    ``J_u · noise_cov · J_uᵀ`` of the pose noise; ``control_dim`` is the length of u;
    ``linearise(x, y, θ, u, params)`` the scalar prediction (next pose, G by its two
    free entries, R_x); :meth:`pose_noise` that R_x as a 3×3 array (the odometry
    model's adds two sideways terms to V M Vᵀ,
    :func:`slam_env.kernels.base.models.odometry_predict`). ``code`` is the model's
    number in the kernels (:data:`slam_env.kernels.base.models.ODOMETRY` /
    ``VELOCITY``).
    """

    name: str
    code: int
    control_dim: int
    motion: Callable[..., np.ndarray]
    jacobians: Callable[..., tuple[np.ndarray, np.ndarray]]
    noise_cov: Callable[..., np.ndarray]
    linearise: Callable[..., tuple[float, float, float, float, float, tuple[float, ...]]]

    def pose_noise(self, pose, u, params) -> np.ndarray:
        """R_x (3×3), the noise the filter's prediction adds to the pose block."""
        r00, r01, r02, r11, r12, r22 = self.linearise(*_pose_floats(pose), u, params)[5]
        return np.array([[r00, r01, r02], [r01, r11, r12], [r02, r12, r22]])


MOTION_MODELS: dict[str, MotionModel] = {
    "odometry": MotionModel(
        "odometry",
        km.ODOMETRY,
        3,
        odometry_motion,
        odometry_jacobians,
        odometry_action_cov,
        odometry_linearise,
    ),
    "velocity": MotionModel(
        "velocity",
        km.VELOCITY,
        2,
        velocity_motion,
        velocity_jacobians,
        velocity_control_cov,
        velocity_linearise,
    ),
}


# --------------------------------------------------------------------------- measurement


def _many(what: int, model: int, pose, points, width: int) -> np.ndarray:
    """:func:`slam_env.kernels.base.models.measurement_many` over the leading axes of
    ``points: (..., 2)``; returns ``(..., width)``."""
    pts = np.asarray(points, dtype=np.float64)
    lead = pts.shape[:-1]
    flat = np.ascontiguousarray(pts.reshape(-1, 2))
    out = np.empty((flat.shape[0], width))
    km.measurement_many(what, model, *_pose_floats(pose), flat, out)
    return out.reshape(*lead, width)


def _jacobian_blocks(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(H_x (..., 2, 3), H_m (..., 2, 2)) from the rows of [H_x | H_m] (..., 10)."""
    H = rows.reshape(*rows.shape[:-1], 2, 5)
    return H[..., :3].copy(), H[..., 3:].copy()


def _inverse_blocks(lw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(L (..., 2, 3), W (..., 2, 2)) from (l02, l12, w00, w01, w10, w11) (..., 6)."""
    lead = lw.shape[:-1]
    L = np.zeros((*lead, 2, 3))
    L[..., 0, 0] = 1.0
    L[..., 1, 1] = 1.0
    L[..., 0, 2] = lw[..., 0]
    L[..., 1, 2] = lw[..., 1]
    return L, lw[..., 2:].reshape(*lead, 2, 2).copy()


def _linearise(
    model: int,
) -> Callable[..., tuple[float, float, tuple[float, ...], tuple[float, ...]]]:
    def linearise(
        x: float, y: float, th: float, mx: float, my: float
    ) -> tuple[float, float, tuple[float, ...], tuple[float, ...]]:
        if km.singular(model, x, y, mx, my):
            raise ZeroDivisionError("the landmark is on the robot: h cannot be linearised")
        zh0, zh1 = km.observe(model, x, y, th, mx, my)
        rows = km.jacobian(model, x, y, th, mx, my)
        return zh0, zh1, rows[:5], rows[5:]

    return linearise


def range_bearing_h(pose, m) -> np.ndarray:
    """z = h(pose, m) = [r, φ] for landmarks m: (..., 2) → (..., 2); φ wrapped."""
    return _many(km.H, km.RANGE_BEARING, pose, m, 2)


def range_bearing_jacobians(pose, m) -> tuple[np.ndarray, np.ndarray]:
    """(H_x (..., 2, 3), H_m (..., 2, 2)) of the range-bearing model (seed 000 §2.3).

    H_x = [[−dx/√q, −dy/√q, 0], [dy/q, −dx/q, −1]], H_m = [[dx/√q, dy/√q], [−dy/q, dx/q]].
    Undefined at q = 0 (a landmark on the robot): NaN there.
    """
    return _jacobian_blocks(_many(km.H_JACOBIAN, km.RANGE_BEARING, pose, m, 10))


def range_bearing_inverse(pose, z) -> np.ndarray:
    """m = h⁻¹(z, pose) = t + r·[cos(φ + θ), sin(φ + θ)] for z: (..., 2) → (..., 2)."""
    return _many(km.H_INVERSE, km.RANGE_BEARING, pose, z, 2)


def range_bearing_inverse_jacobians(pose, z) -> tuple[np.ndarray, np.ndarray]:
    """(L (..., 2, 3), W (..., 2, 2)) of the range-bearing inverse model (seed 000 §2.2).

    L = [[1, 0, −r·sin(φ+θ)], [0, 1, r·cos(φ+θ)]], W = [[cos(φ+θ), −r·sin(φ+θ)],
    [sin(φ+θ), r·cos(φ+θ)]].
    """
    return _inverse_blocks(_many(km.H_INVERSE_JACOBIAN, km.RANGE_BEARING, pose, z, 6))


range_bearing_linearise = _linearise(km.RANGE_BEARING)
range_bearing_linearise.__doc__ = """Scalar form ``(x, y, θ, mx, my) -> (r̂, φ̂, row 0, row 1)``
with the rows of [H_x | H_m] (2×5). Raises ``ZeroDivisionError`` when the landmark is
on the robot (q = 0)."""


def range_bearing_singular(pose, m) -> np.ndarray:
    """(...,) bool: where the range-bearing Jacobians are undefined (q = 0)."""
    return _many(km.H_SINGULAR, km.RANGE_BEARING, pose, m, 1)[..., 0] != 0.0


def cartesian_h(pose, m) -> np.ndarray:
    """z = R(θ)ᵀ(m − t) for landmarks m: (..., 2) → (..., 2) (seed 004)."""
    return _many(km.H, km.CARTESIAN, pose, m, 2)


def cartesian_jacobians(pose, m) -> tuple[np.ndarray, np.ndarray]:
    """(H_x (..., 2, 3), H_m (..., 2, 2)) of the cartesian model.

    With z = (z1, z2) = h: H_x = [[−cos θ, −sin θ, z2], [sin θ, −cos θ, −z1]],
    H_m = R(θ)ᵀ = [[cos θ, sin θ], [−sin θ, cos θ]].
    """
    return _jacobian_blocks(_many(km.H_JACOBIAN, km.CARTESIAN, pose, m, 10))


def cartesian_inverse(pose, z) -> np.ndarray:
    """m = h⁻¹(z, pose) = t + R(θ)·z for z: (..., 2) → (..., 2)."""
    return _many(km.H_INVERSE, km.CARTESIAN, pose, z, 2)


def cartesian_inverse_jacobians(pose, z) -> tuple[np.ndarray, np.ndarray]:
    """(L (..., 2, 3), W (..., 2, 2)) of the cartesian inverse model.

    L = [[1, 0, −sin θ·z1 − cos θ·z2], [0, 1, cos θ·z1 − sin θ·z2]], W = R(θ).
    """
    return _inverse_blocks(_many(km.H_INVERSE_JACOBIAN, km.CARTESIAN, pose, z, 6))


cartesian_linearise = _linearise(km.CARTESIAN)
cartesian_linearise.__doc__ = """Scalar form ``(x, y, θ, mx, my) -> (ẑ1, ẑ2, row 0, row 1)``
with the rows of [H_x | H_m] (2×5)."""


def cartesian_singular(pose, m) -> np.ndarray:
    """(...,) bool: the cartesian model is linear in m and smooth everywhere."""
    return _many(km.H_SINGULAR, km.CARTESIAN, pose, m, 1)[..., 0] != 0.0


@dataclass(frozen=True)
class MeasurementModel:
    """A measurement model as the filter uses it (all functions above, by model).

    ``angular[i]`` says whether component i of z is an angle, whose innovation is
    wrapped to [−π, π). ``singular(pose, m) -> (k,) bool`` marks landmarks at which
    ``h`` cannot be linearised (range-bearing: a landmark on the robot, q = 0).
    ``code`` is the model's number in the kernels
    (:data:`slam_env.kernels.base.models.RANGE_BEARING` / ``CARTESIAN``).
    """

    name: str
    code: int
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
        km.RANGE_BEARING,
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
        km.CARTESIAN,
        cartesian_h,
        cartesian_jacobians,
        cartesian_inverse,
        cartesian_inverse_jacobians,
        cartesian_linearise,
        (False, False),
        cartesian_singular,
    ),
}
